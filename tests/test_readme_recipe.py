"""The README's recipe for recognising one's own recording runs exactly as written, on a
recording labelled as it says (codes 1-4, 0 unlabelled), and its map names every label."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pandas as pd

from contactlab.synthetic.free_contact import free_contact_recording

from conftest import run_cli

README = Path(__file__).resolve().parents[1] / "README.md"


def _recipe() -> list[str]:
    text = README.read_text(encoding="utf-8")
    block = re.search(r"recognise the others\..*?```sh\n(.*?)```", text, re.S).group(1)
    return [line.split("  #")[0].strip() for line in block.splitlines() if line.strip()]


def _recording(path: Path, seed: int) -> set[int]:
    cols = pd.DataFrame(free_contact_recording(seed=seed, fs=100.0, cycles=3).csv_columns())
    state = cols["state"].to_numpy().copy()
    contact = np.flatnonzero(state == 2)
    state[contact[len(contact) // 2: len(contact) // 2 + 30]] = 4   # a lighter touch
    state[-20:] = 0                                                 # unlabelled
    cols["state"] = state
    cols.to_csv(path, index=False)
    return set(state.tolist())


def test_readme_recipe_runs_as_written(tmp_path, monkeypatch):
    labels = _recording(tmp_path / "rec1.csv", 11) | _recording(tmp_path / "rec2.csv", 12)
    lines = _recipe()
    mapped = re.search(r'--label-map "([^"]+)"', " ".join(lines)).group(1)
    assert {int(e.split("=")[0]) for e in mapped.split(",")} == labels - {0}
    monkeypatch.chdir(tmp_path)
    for line in lines:
        r = run_cli(*shlex.split(line)[1:])
        assert r.exit_code == 0, f"{line}\n{r.output}"
    assert (tmp_path / "rec2-path.csv").exists()
    assert (tmp_path / "rec2-path-boundaries.csv").exists()
