"""Stage cost over whole archives: linear in the trials, and the speed-up of workers.

``contactlab segment`` (strain, the defaults) over archives imported from CSV
(``contactlab import``) of 20 and of 200 ten-second 8-strain trials at
1000 Hz: AR(2) strains whose noise level steps every 2.5 s, so the detector
restarts. The goal: the 200-trial run within 1.3x of ten times the 20-trial
run (the row's ratio is 10 x t20 / t200, so >= 0.77 meets it) and >= 1000x
real time overall; and the 200-trial run on 2 local worker processes against
1 (ratio: the speed-up). Every run includes reading the archive, all trials'
segmentation and the one atomic write of all trials' results.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from contactlab.archive import import_csv
from contactlab.segmentation import run_archive

from benchmarks.timing import best_time

FS = 1000.0
SECONDS = 10.0
CHANNELS = 8
DISTINCT = 20


def _write_csvs(folder: Path, n: int) -> list[Path]:
    """``n`` CSV files (``DISTINCT`` different recordings, repeated under new names)."""
    rng = np.random.default_rng(7)
    m = int(SECONDS * FS)
    t = np.arange(m) / FS
    level = 1.0 + 3.0 * ((t // 2.5) % 2)                     # steps every 2.5 s
    header = "t," + ",".join(f"s{i}" for i in range(CHANNELS))
    made = []
    for i in range(DISTINCT):
        e = rng.standard_normal((m, CHANNELS)) * level[:, None]
        y = lfilter([1.0], [1.0, -1.2, 0.5], e, axis=0)
        path = folder / f"trial-{i:03d}.csv"
        np.savetxt(path, np.column_stack([t, y]), fmt="%.6g", delimiter=",",
                   header=header, comments="")
        made.append(path)
    out = []
    for k in range(n):
        path = folder / f"trial-{k:03d}.csv"
        if k >= DISTINCT:
            shutil.copyfile(made[k % DISTINCT], path)
        out.append(path)
    return out


def run() -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        csvs = _write_csvs(tmp, 200)
        columns = {"time": "t", "strain": "s*"}
        a20 = import_csv(csvs[:20], out=tmp / "a20.h5", columns=columns, quiet=True)
        a200 = import_csv(csvs, out=tmp / "a200.h5", columns=columns, quiet=True)
        run_archive(a20, quiet=True)                          # load the numba kernels
        t20 = best_time(lambda: run_archive(a20, quiet=True), repeats=3)
        t200 = best_time(lambda: run_archive(a200, quiet=True), repeats=1)
        t200w = best_time(lambda: run_archive(a200, quiet=True, workers=2), repeats=1)
    realtime = 200 * SECONDS / t200
    return [
        {"name": "segment 200 imported 10 s trials", "ours_s": t200,
         "peer": "10 x segment of 20 trials", "peer_s": 10 * t20, "ratio": 10 * t20 / t200,
         "notes": f"linear cost: ratio >= 0.77 meets 'within 1.3x'; {realtime:.0f}x real "
                  f"time over 200 trials (goal >= 1000x); 20 trials {t20:.2f} s"},
        {"name": "segment 200 trials, 2 worker processes", "ours_s": t200w,
         "peer": "1 worker (in process)", "peer_s": t200, "ratio": t200 / t200w,
         "notes": "ratio = speed-up of --workers 2 (processes share the machine's cores "
                  "with whatever else runs)"},
    ]
