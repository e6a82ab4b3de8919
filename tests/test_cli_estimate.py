"""contactlab estimate on a simulated cartesian archive (the four hand-moved groups)."""

import shutil

import pytest

from contactlab.archive import open_archive
from tests.conftest import one_json_object, run_cli


@pytest.fixture(scope="module")
def cartesian_archive(tmp_path_factory):
    from contactlab.acquire.record import record
    from contactlab.acquire.sim import SimSource
    from contactlab.acquire.spec import load_spec

    path = tmp_path_factory.mktemp("est") / "cart.h5"
    record(SimSource(load_spec("cartesian")), out=path, n_trials=16, seed=3, quiet=True,
           log=lambda m: None)
    return path


@pytest.fixture
def archive(cartesian_archive, tmp_path):
    dst = tmp_path / "cart.h5"
    shutil.copy(cartesian_archive, dst)
    return dst


def test_json_degrees_normals_and_results(archive):
    res = run_cli("estimate", archive, "--json", "--quiet")
    assert res.exit_code == 0, res.output
    out = one_json_object(res.stdout)
    assert len(out["trials"]) == 16
    with open_archive(archive) as a:
        for tid, entry in out["trials"].items():
            trial = a.trial(tid)
            long = [r for r in entry["segments"] if r["n"] >= 200]
            assert long, tid
            for r in long:
                for key in ("degree", "normals", "log_likelihoods"):
                    assert key in r
                assert r["degree"] == int(r["label"])           # ground-truth class
                assert len(r["normals"]) == r["degree"]
                assert r["angle_error_deg"] < 1.0
            stored = trial.results("estimate")
            assert stored["degree"].shape == (len(entry["segments"]),)
            assert stored["log_likelihoods"].shape == (len(entry["segments"]), 4)
            assert stored.attrs["model"] == "cartesian"


def test_blocks_and_text_output(archive):
    res = run_cli("estimate", archive, "--block", "25", "--trial", "cartesian-004", "--quiet")
    assert res.exit_code == 0, res.output
    assert "pieces" in res.stdout and "cartesian-004" in res.stdout
    res = run_cli("estimate", archive, "--block", "25", "--trial", "cartesian-004", "--json",
                  "--quiet")
    rows = one_json_object(res.stdout)["trials"]["cartesian-004"]["segments"]
    assert len(rows) == 16 and all(r["n"] == 25 for r in rows)
    for r in rows:      # decided (degree and normals) or explicitly undetermined
        assert r["status"] in ("ok", "undetermined")
        assert (r["degree"] is None) == (r["status"] == "undetermined")
        assert len(r["log_likelihoods"]) == 4


def test_auto_segments(archive):
    res = run_cli("estimate", archive, "--segments", "auto", "--trial", "cartesian-012",
                  "--json", "--quiet")
    assert res.exit_code == 0, res.output
    rows = one_json_object(res.stdout)["trials"]["cartesian-012"]["segments"]
    assert all(r["degree"] in (None, 3) for r in rows)
    assert any(r["degree"] == 3 for r in rows)


def test_errors_are_one_line(archive, tmp_path):
    res = run_cli("estimate", archive, "--model", "polygon-A")
    assert res.exit_code == 2 and "not available yet" in res.output
    res = run_cli("estimate", tmp_path / "missing.h5")
    assert res.exit_code == 1 and len(res.output.strip().splitlines()) == 1
    res = run_cli("estimate", archive, "--segments", "nostage", "--quiet")
    assert res.exit_code == 1 and "results/nostage" in res.output
    res = run_cli("estimate", archive, "--trial", "nope", "--quiet")
    assert res.exit_code == 1 and "/trials/nope" in res.output
    assert "Example" in run_cli("estimate", "--help").output
