"""``contactlab report`` draws every trial and every results stage of an archive."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from contactlab.archive import open_archive, write_results
from contactlab.cli import main
from conftest import write_archive


def test_report_has_a_figure_per_trial_and_per_results_stage(tmp_path):
    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01", "t02"))
    with open_archive(path) as archive:
        n = archive.trial("t01").n_samples
    write_results(path, "t01", "segment", datasets={"boundaries_s": np.array([0.3, 0.9]),
                                                    "statistic": np.linspace(0, 1, n)})
    out = tmp_path / "rep"
    result = CliRunner().invoke(main, ["report", str(path), "--out", str(out), "--json", "-q"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["trials"] == ["t01", "t02"]
    assert set(summary["figures"]) == {"trial-t01", "trial-t02", "trial-t01-segment"}
    html = (out / "index.html").read_text()
    for name in summary["figures"]:
        assert f"{name}.png" in html and (out / f"{name}.png").stat().st_size > 5000
    assert (out / "report.pdf").read_bytes().startswith(b"%PDF")


def test_report_rejects_an_unknown_trial_in_one_line(tmp_path):
    path = tmp_path / "runs.h5"
    write_archive(path, trials=("t01",))
    result = CliRunner().invoke(main, ["report", str(path), "--trial", "zz", "--out",
                                       str(tmp_path / "r")])
    assert result.exit_code == 1
    assert result.stderr.strip().count("\n") == 0 and "zz" in result.stderr
