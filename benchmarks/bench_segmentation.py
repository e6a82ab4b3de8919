"""Segmentation speed (7.2.1): an 8-strain stroke trial and linear scaling.

The targets: segmenting an 8-strain, 7-second trial at least 1000x
faster than real time on one core, with cost linear in trial length (measured
at 10 s and 1000 s of stationary 250 Hz AR(2) strains, where no restart
happens); and the peer side by side on one simulated stroke-a trial (the
stroke-segmentation experiment does all 16): ruptures' Pelt and Binseg with
ruptures' ``CostAR`` (order 2) applied per strain and summed (``CostAR`` itself
reads a multichannel signal wrongly; see
:mod:`contactlab.experiments.stroke_segmentation`), min_size 10, jump 5, each at
the penalty beta sigma^2 log n that gives its best boundary F1 on this trial
(grid of 13 betas, computed with the identical prefix-sum cost), against
contactlab at the thesis's threshold 200 and at its own best threshold. Truth:
the trial's merged phase boundaries (tolerance 0.1 s). Wall time is one
fit + predict at the chosen setting with ruptures' own cost.

Every contactlab row is given for both combinations of the channels: ``sum``
(the thesis: one chi-square(8) Page-Hinkley test) and ``channel`` (one test per
strain, a change when any fires; beyond the thesis), each at its own best
threshold where F1 is reported.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from contactlab.acquire.sim import simulate_trial
from contactlab.acquire.spec import load_spec
from contactlab.signals import condition_array
from contactlab.segmentation import boundary_metrics, segment_glr, segment_signal

from benchmarks.timing import best_time

FS_LOW = 250.0
REPEATS = 3




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
    low = condition_array(strain, "strain", fs=1000.0).y
    for mode in ("sum", "channel"):
        tag = "" if mode == "sum" else " (combine=channel)"
        segment_signal(low[:200], fs=FS_LOW, combine=mode)  # compile / load the numba kernels
        t_seg = best_time(lambda: segment_signal(low, fs=FS_LOW, combine=mode))
        t_all = best_time(lambda: segment_signal(condition_array(strain, "strain", fs=1000.0).y,
                                                 fs=FS_LOW, combine=mode))
        rows.append({"name": f"segment 7 s 8-strain stroke trial{tag}", "ours_s": t_seg,
                     "peer": None, "peer_s": None, "ratio": None,
                     "notes": f"{7.0 / t_seg:.0f}x real time (target >= 1000x); with 7.1 "
                              f"conditioning {t_all * 1e3:.1f} ms, {7.0 / t_all:.0f}x"})
        per_second = {}
        for seconds in (10.0, 1000.0):
            y = _stationary(seconds)
            t = best_time(lambda: segment_signal(y, fs=FS_LOW, combine=mode),
                          repeats=REPEATS if seconds < 100 else 1)
            per_second[seconds] = t / seconds
            rows.append({"name": f"segment {seconds:g} s stationary 8 channels{tag}",
                         "ours_s": t, "peer": None, "peer_s": None, "ratio": None,
                         "notes": f"{seconds / t:.0f}x real time"})
        rows[-1]["notes"] += (f"; cost per second of signal at 1000 s / at 10 s = "
                              f"{per_second[1000.0] / per_second[10.0]:.2f} (1.0 = linear)")
    rows += _peers()
    return rows


def _peers() -> list[dict]:
    from contactlab.acquire.stroke_phases import stroke_truth
    from contactlab.defaults import THRESHOLD_SWEEP as SWEEP
    from contactlab.peers.ruptures_ar import BETA_GRID, peer_boundaries
    from contactlab.signals import condition

    plan, r = simulate_trial(load_spec("stroke-a"), 0, 1)
    sig = condition(r, "strain")
    y, times, fs = sig.y, sig.times, sig.fs
    truth = np.array([p["start_s"] for p in stroke_truth(plan, r)["phases"][1:]])

    def f1(found_s):
        return boundary_metrics(truth, found_s, times=times)["f1"]

    best = {}
    rows = []
    for mode in ("sum", "channel"):
        ours = {thr: segment_signal(y, fs=fs, times=times, threshold=thr,
                                    combine=mode).boundaries_s for thr in SWEEP}
        best_thr = max(SWEEP, key=lambda thr: (f1(ours[thr]), thr))
        t_ours = best_time(lambda: segment_signal(y, fs=fs, times=times, threshold=best_thr,
                                                  combine=mode))
        best[mode] = (t_ours, f1(ours[best_thr]), best_thr)
        tag = "" if mode == "sum" else " (combine=channel)"
        rows.append({"name": f"contactlab segment, stroke-a trial{tag}", "ours_s": t_ours,
                     "peer": None, "peer_s": None, "ratio": None,
                     "notes": f"boundary F1 {f1(ours[200.0]):.2f} at the thesis's threshold "
                              f"200, {f1(ours[best_thr]):.2f} at its best threshold "
                              f"{best_thr:g} (tolerance 0.1 s, {len(truth)} true boundaries)"})
    glr = segment_glr(y, fs=fs, times=times)                  # the verb's default, no sweep
    t_glr = best_time(lambda: segment_glr(y, fs=fs, times=times))
    best["glr"] = (t_glr, f1(glr.boundaries_s), "default")
    rows.append({"name": "contactlab segment, stroke-a trial (method glr)", "ours_s": t_glr,
                 "peer": None, "peer_s": None, "ratio": None,
                 "notes": f"boundary F1 {f1(glr.boundaries_s):.2f} with the defaults"})
    tags = {"sum": "", "channel": " (combine=channel)", "glr": " (method glr)"}
    for name in ("Binseg", "Pelt"):
        scores = {b: f1(peer_boundaries(y, times, algo=name, beta=b)) for b in BETA_GRID}
        beta = max(scores, key=lambda b: (scores[b], b))
        t_peer = best_time(lambda: peer_boundaries(y, times, algo=name, beta=beta, fast=False),
                           repeats=1 if name == "Pelt" else REPEATS)
        for mode, (t_ours, f1_ours, thr) in best.items():
            tag = tags[mode]
            rows.append({"name": f"segment stroke-a trial vs ruptures {name}{tag}",
                         "ours_s": t_ours, "peer": f"ruptures {name} (CostAR per strain)",
                         "peer_s": t_peer, "ratio": t_peer / t_ours,
                         "notes": f"peer F1 {scores[beta]:.2f} at its best beta {beta:.3g} "
                                  f"(grid of {len(BETA_GRID)}), ours {f1_ours:.2f} at "
                                  f"threshold {thr}"})
    return rows
