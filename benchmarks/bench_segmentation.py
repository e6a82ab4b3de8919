"""Segmentation speed (7.2.1): an 8-strain stroke trial and linear scaling.

The issue's targets: segmenting an 8-strain, 7-second trial at least 1000x
faster than real time on one core, with cost linear in trial length (measured
at 10 s and 1000 s of stationary 250 Hz AR(2) strains, where no restart
happens). The ruptures Pelt/Binseg comparison is still to come (issue 4).
"""

from __future__ import annotations

import time

import numpy as np
from scipy.signal import lfilter

from contactlab.acquire.sim import simulate_trial
from contactlab.acquire.spec import load_spec
from contactlab.conditioning import condition_strains
from contactlab.segmentation import segment_signal

FS_LOW = 250.0
REPEATS = 3


def _best(fn, repeats=REPEATS):
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _stationary(seconds: float, *, seed: int = 0) -> np.ndarray:
    """8 channels of a stable AR(2) process at 250 Hz."""
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(int(seconds * FS_LOW), 8))
    return lfilter([1.0], [1.0, -0.6, 0.2], e, axis=0)


def run() -> list[dict]:
    rows = []
    spec = load_spec("stroke-a")
    _plan, result = simulate_trial(spec, 0, 1, duration_s=7.0)
    strain = result.strain
    low = condition_strains(strain, fs=1000.0).low
    segment_signal(low[:200], fs=FS_LOW)  # compile / load the numba kernels
    t_seg = _best(lambda: segment_signal(low, fs=FS_LOW))
    t_all = _best(lambda: segment_signal(condition_strains(strain, fs=1000.0).low, fs=FS_LOW))
    rows.append({"name": "segment 7 s 8-strain stroke trial", "ours_s": t_seg, "peer": None,
                 "peer_s": None, "ratio": None,
                 "notes": f"{7.0 / t_seg:.0f}x real time (target >= 1000x); with 7.1 "
                          f"conditioning {t_all * 1e3:.1f} ms, {7.0 / t_all:.0f}x"})
    per_second = {}
    for seconds in (10.0, 1000.0):
        y = _stationary(seconds)
        t = _best(lambda: segment_signal(y, fs=FS_LOW), repeats=REPEATS if seconds < 100 else 1)
        per_second[seconds] = t / seconds
        rows.append({"name": f"segment {seconds:g} s stationary 8 channels", "ours_s": t,
                     "peer": None, "peer_s": None, "ratio": None,
                     "notes": f"{seconds / t:.0f}x real time"})
    rows[-1]["notes"] += (f"; cost per second of signal at 1000 s / at 10 s = "
                          f"{per_second[1000.0] / per_second[10.0]:.2f} (1.0 = linear)")
    return rows
