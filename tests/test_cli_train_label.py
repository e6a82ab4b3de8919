"""contactlab train / label from the command line."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import one_json_object, run_cli
from test_temporal_train import SEPARATED, write_ar_archive

from contactlab.archive import open_archive, validate_archive
from contactlab.temporal import ModelSet


@pytest.fixture(scope="module")
def sep(tmp_path_factory):
    return write_ar_archive(tmp_path_factory.mktemp("cli") / "sep.h5", SEPARATED, rest=300)


def test_train_then_label_json(sep, tmp_path):
    models = tmp_path / "m.h5"
    r = run_cli("train", sep, "--labels", "truth", "--out", models, "--json", "--quiet")
    assert r.exit_code == 0, r.output
    info = one_json_object(r.stdout)
    assert info["labels"] == ["rough", "smooth"] and info["skipped"] == {"rest": 0}
    loaded = ModelSet.load(models)
    assert loaded.provenance["command"].startswith("contactlab") and loaded.order == 2

    r = run_cli("label", sep, "--models", models, "--json", "--quiet")
    assert r.exit_code == 0, r.output
    out = one_json_object(r.stdout)
    assert out["accuracy"] >= 0.97
    conf = out["confusion"]
    assert conf["labels"] == ["rough", "smooth"]
    assert np.asarray(conf["matrix"]).sum() == out["n_blocks"] == 40
    assert "predicted_error" in out and 0 <= out["predicted_error"] <= 0.5
    assert validate_archive(sep) == []
    with open_archive(sep) as arch:
        res = arch.trial("t0").results("label")
        assert list(res.attrs["label_names"]) == ["rough", "smooth"]
        n = len(out["trials"]["t0"]["predicted"])
        assert res["predicted"].shape == (n,) and res["loglik"].shape == (n, 2)
        np.testing.assert_array_equal(
            np.asarray(["rough", "smooth"])[res["predicted"]], out["trials"]["t0"]["predicted"])

    r = run_cli("label", sep, "--models", models, "--loo", "--json", "--quiet")
    assert r.exit_code == 0, r.output
    assert one_json_object(r.stdout)["loo"] == "trial"
    r = run_cli("label", sep, "--models", models, "--loo", "--loo-unit", "block", "--quiet")
    assert r.exit_code == 0 and "leave-one-block-out" in r.stdout


def test_train_text_output_and_force(sep, tmp_path):
    models = tmp_path / "m.h5"
    r = run_cli("train", sep, "--out", models, "--signal", "hf", "--mean", "--order", "1",
                "--quiet")
    assert r.exit_code == 0, r.output
    assert "rough:" in r.stdout and "rest: skipped" in r.stdout
    assert ModelSet.load(models).signal == "hf" and ModelSet.load(models).mean
    again = run_cli("train", sep, "--out", models, "--quiet")
    assert again.exit_code == 1 and "--force" in again.stderr
    assert run_cli("train", sep, "--out", models, "--quiet", "--force").exit_code == 0


@pytest.mark.parametrize("args, code, words", [
    (["--classes", "rough,gravel"], 1, "unknown label 'gravel'"),
    (["--classes", "rough,rest"], 1, "empty class 'rest'"),
    (["--block", "3"], 1, "shorter than AR(2) needs"),
    (["--labels", "segment"], 1, "no such results stage"),
    (["--order", "0"], 2, "--order"),
    (["--signal", "nope"], 2, "--signal"),
])
def test_train_bad_inputs_one_line(sep, tmp_path, args, code, words):
    r = run_cli("train", sep, "--out", tmp_path / "m.h5", "--quiet", *args)
    assert r.exit_code == code, r.output
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err and words in err, err
    assert not (tmp_path / "m.h5").exists()


def test_label_bad_models_file(sep, tmp_path):
    r = run_cli("label", sep, "--models", sep, "--quiet")
    assert r.exit_code == 1 and "not a contactlab models file" in r.stderr
    r = run_cli("label", sep, "--models", tmp_path / "none.h5", "--quiet")
    assert r.exit_code == 1 and "no such file" in r.stderr and len(r.stderr.splitlines()) == 1
