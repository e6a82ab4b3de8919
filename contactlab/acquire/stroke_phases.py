"""Ground-truth phases of a simulated stroke (7.2) from the simulator's state.

The thesis's seven phases of a stroke over a two-texture sample (7.2): resting
before the motion command; the start-of-motion burst (an impact interval
before the finger first slides); strain build-up (command running, finger not
yet sliding); sliding over the first (rough) and the second (smooth) texture;
the drop at the stop (from the end of the command until the noise-free wrench
has settled within :data:`SETTLE_FRACTION` of its step, judged
:data:`SETTLE_WINDOW_S` after the command end); and resting.  The simulator has
regimes the thesis does not list: the finger stops while the decelerating
command still runs ("stopped, command running") and slides off the sample.

Truth flickers at stick-slip (the finger's ``moving`` flag toggles for 3-80 ms
at breakaway and at the stop), so :func:`merge_short_runs` gives phases
shorter than :data:`MIN_PHASE_S` to the phase before them: a restarted AR(2)
segmenter needs 19 conditioned samples (76 ms) before it tests again, so a
shorter run cannot be resolved.  :func:`stroke_truth` does all three steps for
a simulated trial.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PHASES", "THESIS_PHASES", "MIN_PHASE_S", "SETTLE_FRACTION", "SETTLE_WINDOW_S",
           "phase_codes", "merge_short_runs", "truth_phases", "stroke_truth"]

PHASES = ("resting", "start-of-motion burst", "strain build-up", "rough texture",
          "smooth texture", "stopped, command running", "drop at stop", "resting after stop",
          "sliding off the sample")
#: the phases the thesis names (7.2)
THESIS_PHASES = (0, 1, 2, 3, 4, 6, 7)
#: shortest phase kept (s); shorter runs go to the phase before them
MIN_PHASE_S = 0.1
#: drop phase: until the true wrench is within this fraction of its step ...
SETTLE_FRACTION = 0.1
#: ... of its value this long (s) after the command end
SETTLE_WINDOW_S = 0.2


def phase_codes(*, time, moving, impact, texture, wrench, command_start_s: float,
                command_end_s: float) -> np.ndarray:
    """Per-sample phase (index into :data:`PHASES`) from the simulator's state.

    ``texture`` is the index of the material under the finger (0 the first,
    rough one; -1 off the sample); ``wrench`` the noise-free wrench (N, >=3).
    """
    time = np.asarray(time, float)
    moving = np.asarray(moving, bool)
    n = len(time)
    codes = np.zeros(n, np.int64)
    started = time >= command_start_s
    ended = time >= command_end_s
    first_move = int(np.argmax(moving)) if moving.any() else n
    before = np.arange(n) < first_move
    codes[started & before] = 2
    codes[started & before & np.asarray(impact, bool)] = 1
    sliding = ~before & ~ended
    texture = np.asarray(texture)
    codes[sliding & moving & (texture == 0)] = 3
    codes[sliding & moving & (texture >= 1)] = 4
    codes[sliding & moving & (texture < 0)] = 8
    codes[sliding & ~moving] = 5
    codes[ended] = 7
    i_end = int(np.searchsorted(time, command_end_s))
    if i_end < n:
        f = np.asarray(wrench, float)[:, :3]
        i_ref = min(n - 1, int(np.searchsorted(time, command_end_s + SETTLE_WINDOW_S)))
        step = np.linalg.norm(f[max(i_end - 1, 0)] - f[i_ref])
        off = np.linalg.norm(f[i_end:i_ref + 1] - f[i_ref], axis=1) > SETTLE_FRACTION * step
        settle = i_end + (int(np.flatnonzero(off)[-1]) + 1 if off.any() else 0)
        codes[i_end:settle] = 6
    return codes


def merge_short_runs(codes, *, min_len: int) -> np.ndarray:
    """Give runs of equal code shorter than ``min_len`` samples to the phase before them.

    A phase change is confirmed by a run of the new code at least ``min_len``
    long and starts at that run's first sample; shorter runs (flicker) take the
    code of the last long run before them (runs before the first long run, that
    of the first long run).  Without any long run the codes are returned as they are.
    """
    codes = np.asarray(codes)
    if codes.size == 0:
        return codes.copy()
    edges = np.flatnonzero(np.diff(codes)) + 1
    starts = np.r_[0, edges]
    lengths = np.diff(np.r_[starts, codes.size])
    long = lengths >= min_len
    if not long.any():
        return codes.copy()
    owner = np.maximum.accumulate(np.where(long, np.arange(len(starts)), -1))
    owner[owner < 0] = int(np.argmax(long))
    return np.repeat(codes[starts[owner]], lengths)


def truth_phases(codes, time) -> list[dict]:
    """The runs of ``codes`` as phases: ``{"code", "name", "start_s", "end_s"}``."""
    time = np.asarray(time, float)
    edges = np.flatnonzero(np.diff(codes)) + 1
    starts, ends = np.r_[0, edges], np.r_[edges, len(codes)]
    dt = float(np.median(np.diff(time)))
    return [{"code": int(codes[a]), "name": PHASES[int(codes[a])], "start_s": float(time[a]),
             "end_s": float(time[b - 1] + dt)} for a, b in zip(starts, ends)]


def stroke_truth(plan, result, *, min_phase_s: float = MIN_PHASE_S) -> dict:
    """The truth of one simulated stroke (``plan, result`` of
    :func:`contactlab.acquire.simulate_trial`): ``raw`` per-sample phase codes,
    ``merged`` after :func:`merge_short_runs`, and ``phases`` (:func:`truth_phases`)."""
    r, c = result, plan.controller
    raw = phase_codes(time=r.time, moving=r.moving, impact=r.impact, texture=r.texture,
                      wrench=r.wrench_true, command_start_s=c.command_start_s,
                      command_end_s=c.command_start_s + c.command_s)
    merged = merge_short_runs(raw, min_len=round(min_phase_s * r.rate_hz))
    return {"raw": raw, "merged": merged, "phases": truth_phases(merged, r.time)}
