"""Results survive kills, interrupts and concurrent stages (separate processes).

``make test`` runs a handful of each; ``make stress`` (CONTACTLAB_STRESS=1) runs
100 SIGKILLs during results writes and 20 concurrent segment + label pairs.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import numpy as np
import pytest
from conftest import run_cli
from test_stages import measurement_bytes as _measurements
from test_temporal_train import SEPARATED, write_ar_archive

from contactlab.archive import validate_archive
from contactlab.fileio import stale_temp_files as stale_temps

STRESS = bool(os.environ.get("CONTACTLAB_STRESS"))
KILLS = 100 if STRESS else 4
PAIRS = 20 if STRESS else 2
TRIALS = ("t0", "t1", "t2", "t3")

WRITER = textwrap.dedent("""
    import sys
    import numpy as np
    from contactlab.archive import TrialResults, write_stage
    path, trials = sys.argv[1], sys.argv[2].split(",")
    print("ready", flush=True)
    i = 0
    while True:
        i += 1
        write_stage(path, "segment", {t: TrialResults({"x": np.full(100_000, float(i))},
                                                      parameters={"i": i}) for t in trials})
""")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    return write_ar_archive(tmp_path_factory.mktemp("crash") / "runs.h5", SEPARATED,
                            trials=len(TRIALS), seg=1000, rest=300)


@pytest.fixture(scope="module")
def models(runs, tmp_path_factory):
    out = tmp_path_factory.mktemp("models") / "m.h5"
    r = run_cli("train", runs, "--labels", "truth", "--out", out, "--quiet")
    assert r.exit_code == 0, r.output
    return out


def _parameters(path, stage):
    """Each trial's results/<stage> parameters (None when it has none)."""
    with h5py.File(path, "r") as f:
        return {tid: (json.loads(f["trials"][tid][f"results/{stage}"].attrs["parameters"])
                      if f"results/{stage}" in f["trials"][tid] else None)
                for tid in f["trials"]}


def _contactlab(*args):
    return subprocess.Popen([sys.executable, "-m", "contactlab", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_sigkill_during_results_writes_leaves_old_or_new_and_measurements(runs, tmp_path):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    before = _measurements(path)
    rng = random.Random(13)
    seen = set()
    for _ in range(KILLS):
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), ",".join(TRIALS)],
                                stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(rng.uniform(0.0, 0.5))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
        assert validate_archive(path) == []
        assert _measurements(path) == before
        with h5py.File(path, "r") as f:
            stored = set()
            for tid in TRIALS:
                group = f["trials"][tid].get("results/segment")
                if group is None:
                    stored.add(None)
                    continue
                i = json.loads(group.attrs["parameters"])["i"]
                x = group["x"][()]
                assert x.shape == (100_000,) and np.all(x == i)
                stored.add(i)
        assert len(stored) == 1, stored        # all trials from one write, never a mix
        seen |= stored
    assert len(seen - {None}) >= 1             # some writes completed between kills
    subprocess.run([sys.executable, "-c", "import sys; from contactlab.archive import "
                    "write_results; import numpy as np; write_results(sys.argv[1], 't0', "
                    "'other', datasets={'y': np.zeros(2)})", str(path)], check=True,
                   capture_output=True)
    assert stale_temps(path) == []             # a later write cleared what kills left


def test_concurrent_segment_and_label_both_land(runs, models, tmp_path):
    for k in range(PAIRS):
        path = tmp_path / f"pair{k}.h5"
        path.write_bytes(runs.read_bytes())
        procs = [_contactlab("segment", path, "--quiet"),
                 _contactlab("label", path, "--models", models, "--quiet")]
        for proc in procs:
            out, err = proc.communicate(timeout=300)
            assert proc.returncode == 0, err
        for stage in ("segment", "label"):
            params = _parameters(path, stage)
            assert all(p is not None for p in params.values()), (k, stage, params)
        assert validate_archive(path) == []


def test_sigint_mid_stage_keeps_all_old_results_or_writes_all_new(runs, tmp_path):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    r = run_cli("segment", path, "--threshold", "100", "--quiet")
    assert r.exit_code == 0, r.output
    before = _measurements(path)
    rng = random.Random(5)
    outcomes = []
    for _ in range(10 if STRESS else 1):
        proc = _contactlab("segment", path, "--threshold", "300", "--quiet")
        time.sleep(rng.uniform(0.5, 2.5))
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=300)
        thresholds = {p["threshold"] for p in _parameters(path, "segment").values()}
        assert len(thresholds) == 1, thresholds        # never a mix of old and new
        outcomes.append((proc.returncode, thresholds.pop()))
        if outcomes[-1][1] == 100.0:
            assert proc.returncode != 0                 # interrupted: says so, keeps old
        assert _measurements(path) == before and stale_temps(path) == []
        assert validate_archive(path) == []
