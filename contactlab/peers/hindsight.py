"""Where the signal itself changes near each labelled transition, found in hindsight.

A label says when the world changed (the simulator's "moving" is the fingertip's speed
above 1 mm/s; a person marks a boundary by eye); a detector can only mark when the
signal it reads changed.  :func:`hindsight_path` places, for every true transition of a
labelled trial, the single best change point of the signal between the midpoints to the
neighbouring transitions -- ruptures' binary segmentation with one breakpoint and the l2
cost (a change of mean), which for one breakpoint is the exact two-segment least-squares
split -- knowing the labels, the whole trial and that exactly one change lies there.
Scored like an observer's path (:func:`contactlab.observer.recognize.detection_delays`),
its misses are transitions whose signal does not change within the tolerance of the
label: a bound on what any detector of that signal can mark, not a competitor.
"""

from __future__ import annotations

import numpy as np

__all__ = ["hindsight_path"]


def hindsight_path(y, truth, node_names, *, min_run: int = 0) -> list[tuple[str, int]]:
    """``[(node, start_sample), ...]``: the labelled trial's first node from sample 0, then
    each true transition's node from its hindsight change point of ``y`` (module notes).

    ``y`` (n,) or (n, C) on the same samples as ``truth`` (n,) label codes (-1
    unlabelled) indexing ``node_names``; label runs shorter than ``min_run`` samples
    are taken as the run before them, as :func:`detection_delays` takes them.
    """
    import ruptures as rpt

    from contactlab.observer.recognize import _debounced

    names = list(node_names)
    t = np.asarray(truth, np.int64)
    y = np.asarray(y, np.float64)
    if y.shape[0] != t.shape[0]:
        raise ValueError(f"y has {y.shape[0]} samples, truth {t.shape[0]}")
    y = y.reshape(len(y), -1)
    idx = np.flatnonzero(t >= 0)
    if not len(idx):
        return []
    lab = _debounced(t[idx], min_run) if min_run > 1 else t[idx]
    ch = idx[np.flatnonzero(np.diff(lab) != 0) + 1]
    new = lab[np.flatnonzero(np.diff(lab) != 0) + 1]
    edges = np.r_[0, ch, len(t)]
    path = [(names[lab[0]], 0)]
    for k, c in enumerate(ch):
        a, b = (edges[k] + c) // 2, (c + edges[k + 2]) // 2
        if b - a < 4:                       # too little signal to split: the label itself
            path.append((names[new[k]], int(c)))
            continue
        split = rpt.Binseg(model="l2", min_size=2, jump=1).fit(y[a:b]).predict(n_bkps=1)[0]
        path.append((names[new[k]], int(a + split)))
    return path
