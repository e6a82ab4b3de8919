"""Labelled runs of a trial's conditioned signal, and the blocks cut from them.

Two label sources:

* ``"truth"`` -- the archive's per-sample ground truth (``ground_truth/labels``),
  read at each conditioned sample's newest input sample
  (:func:`contactlab.signals.truth_codes`);
  a run is a maximal stretch of one label; unlabelled samples (-1) belong to
  no run.
* a results stage (e.g. ``"segment"``) -- that stage's ``boundaries_s`` cut
  the signal into segments, and each segment is labelled by the **majority
  ground-truth label** of its conditioned samples (unlabelled samples count
  as a label of their own; a segment whose majority is unlabelled is left
  out).  This needs ground truth; without it the segments are unlabelled
  (fine for labelling, an error for training).

Each run ``[s, e)`` gives ``(e - s) // block`` blocks starting at ``s, s +
block, ...`` (the remainder is dropped), so no block spans a label change.
"""

from __future__ import annotations


import numpy as np

from contactlab.errors import DataError
from contactlab.signals import Signal, window_of, condition, source_of, truth_codes

__all__ = ["TrialSignal", "load_signal", "runs_from_codes", "mask_runs", "runs_from_stage",
           "cut_blocks", "code_blocks", "label_runs", "truth_blocks"]

#: one trial's conditioned signal (:class:`contactlab.signals.Signal`)
TrialSignal = Signal


def load_signal(trial, signal: str | None, *, path=None) -> Signal:
    """The 7.1-conditioned ``signal`` of ``trial`` (:func:`contactlab.signals.condition`)
    with finite values; DataError naming the file."""
    try:
        sig = condition(trial, signal, path=path)
    except DataError as err:
        raise DataError(err.message, file=str(path) if path else err.file,
                        field=err.field) from None
    if not np.isfinite(sig.y).all():
        raise DataError("conditioned signal has NaN or infinite values", file=path,
                        field=f"/trials/{trial.id}/measurements/{source_of(sig.name)}")
    return sig


def runs_from_codes(codes: np.ndarray) -> np.ndarray:
    """(R, 3) rows ``[start, end, code]`` of the maximal runs of one code >= 0."""
    codes = np.asarray(codes, dtype=np.int64)
    n = codes.size
    if n == 0:
        return np.zeros((0, 3), dtype=np.int64)
    change = np.flatnonzero(np.diff(codes) != 0) + 1
    starts = np.concatenate([[0], change])
    ends = np.concatenate([change, [n]])
    rows = np.column_stack([starts, ends, codes[starts]])
    return rows[rows[:, 2] >= 0]


def mask_runs(mask) -> list[tuple[int, int]]:
    """``[start, end)`` of the runs of True in a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    edges = np.flatnonzero(np.diff(m.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def runs_from_stage(trial, stage: str, times, codes, *, path=None) -> np.ndarray:
    """(R, 3) segments ``[start, end, majority code]`` from ``results/<stage>``'s
    ``boundaries_s``; code -1 when ``codes`` is None or the majority is unlabelled."""
    try:
        res = trial.results(stage)
    except DataError as err:
        raise DataError(f"{err.message} (--labels {stage})", file=path, field=err.field) from None
    if "boundaries_s" not in res:
        raise DataError(f"results stage {stage!r} has no boundaries_s", file=path,
                        field=f"/trials/{trial.id}/results/{stage}/boundaries_s")
    b = np.searchsorted(times, np.asarray(res["boundaries_s"], dtype=np.float64).ravel())
    n = len(times)
    edges = np.unique(np.concatenate([[0], b[(b > 0) & (b < n)], [n]]))
    starts, ends = edges[:-1], edges[1:]
    out = np.column_stack([starts, ends, np.full(starts.size, -1)]).astype(np.int64)
    if codes is not None:
        shift = np.asarray(codes, dtype=np.int64) + 1          # -1 -> 0
        for i, (s, e) in enumerate(zip(starts, ends)):
            out[i, 2] = int(np.argmax(np.bincount(shift[s:e]))) - 1
    return out


def cut_blocks(runs: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """Block starts (K,) and codes (K,) of the whole blocks inside each run."""
    runs = np.asarray(runs, dtype=np.int64).reshape(-1, 3)
    count = (runs[:, 1] - runs[:, 0]) // int(block)
    which = np.repeat(np.arange(len(runs)), count)
    offset = np.arange(which.size) - np.repeat(np.cumsum(count) - count, count)
    starts = runs[which, 0] + offset * int(block)
    return starts.astype(np.int64), runs[which, 2].astype(np.int64)


def label_runs(trial, sig: TrialSignal, labels: str, *, path=None
               ) -> tuple[np.ndarray, list[str] | None]:
    """Runs ``[start, end, code]`` of ``sig`` from the label source ``labels``
    ("truth" or a results stage) and the names of the codes (None without truth)."""
    codes = truth_codes(trial, sig.index, path=path)
    names = None if codes is None else list(trial.label_names)
    if labels == "truth":
        if codes is None:
            return np.zeros((0, 3), dtype=np.int64), None
        return runs_from_codes(codes), names
    return runs_from_stage(trial, labels, sig.times, codes, path=path), names


def code_blocks(codes, *, block: int, classes=None) -> tuple[np.ndarray, np.ndarray]:
    """Block starts (K,) and codes (K,) of the whole blocks of ``block`` samples inside
    each maximal run of one code ``>= 0`` (and in ``classes`` if given), in time order."""
    if int(block) < 1:
        raise ValueError(f"block must be >= 1; got {block}")
    runs = runs_from_codes(codes)
    if classes is not None:
        runs = runs[np.isin(runs[:, 2], np.asarray(list(classes), np.int64))]
    return cut_blocks(runs, block)


def truth_blocks(trial, *, signal: str | None, block: int, classes=None, path=None) -> dict:
    """The conditioned ``signal`` of ``trial`` and its pure-truth blocks.

    ``y`` (K, C) conditioned signal; ``codes`` (K,) the trial's label code of each
    conditioned sample, -1 unless its whole input window (:func:`contactlab.signals.window_of`)
    has that label; ``starts``, ``labels``: the blocks of :func:`code_blocks`.
    """
    sig = load_signal(trial, signal, path=path)
    codes = truth_codes(trial, sig.index, window=window_of(sig.name, trial.rate_hz), path=path)
    if codes is None:
        raise DataError("trial has no ground-truth labels", file=str(path) if path else None,
                        field=f"/trials/{trial.id}/ground_truth/labels")
    starts, labels = code_blocks(codes, block=block, classes=classes)
    return {"y": sig.y, "codes": codes, "starts": starts, "labels": labels}
