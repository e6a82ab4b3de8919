"""Labelled runs of a trial's conditioned signal, and the blocks cut from them.

Two label sources:

* ``"truth"`` -- the archive's per-sample ground truth (``ground_truth/labels``),
  read at each conditioned sample's time (the newest input sample it uses);
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

from dataclasses import dataclass

import numpy as np

from contactlab.errors import DataError, UsageError
from contactlab.segmentation import SIGNALS, conditioned_signal

__all__ = ["TrialSignal", "load_signal", "truth_at", "runs_from_codes", "runs_from_stage",
           "cut_blocks", "label_runs"]


@dataclass(frozen=True, eq=False)
class TrialSignal:
    """One trial's conditioned signal: ``y`` (N, C), ``times`` (N,) s, ``fs`` Hz."""

    trial_id: str
    y: np.ndarray
    times: np.ndarray
    fs: float


def load_signal(trial, signal: str, *, path=None) -> TrialSignal:
    """The 7.1-conditioned ``signal`` of ``trial`` (see
    :func:`contactlab.segmentation.conditioned_signal`); DataError naming the file."""
    if signal not in SIGNALS:
        raise UsageError(f"signal must be one of {', '.join(SIGNALS)}; got {signal!r}")
    try:
        y, times, fs = conditioned_signal(trial, signal)
    except DataError as err:
        raise DataError(err.message, file=str(path) if path else err.file,
                        field=err.field) from None
    y = np.asarray(y, dtype=np.float64)
    if y.ndim == 1:
        y = y[:, None]
    if not np.isfinite(y).all():
        raise DataError("conditioned signal has NaN or infinite values", file=path,
                        field=f"/trials/{trial.id}/measurements/"
                              f"{'wrench' if signal == 'wrench' else 'strain'}")
    return TrialSignal(trial.id, y, np.asarray(times, dtype=np.float64), float(fs))


def truth_at(trial, times, *, path=None) -> tuple[np.ndarray, list[str]] | None:
    """Ground-truth label codes at the conditioned samples ``times`` and their names;
    None when the trial has no per-sample labels."""
    raw = trial.labels
    if raw is None:
        return None
    field = f"/trials/{trial.id}/ground_truth/labels"
    names = trial.label_names
    if names is None:
        raise DataError("labels have no 'names' attribute", file=path, field=field)
    raw = np.asarray(raw)
    if raw.ndim != 1 or raw.shape[0] != len(trial.time):
        raise DataError(f"expected one label per sample ({len(trial.time)}); got shape "
                        f"{raw.shape}", file=path, field=field)
    bad = (raw < -1) | (raw >= len(names))
    if bad.any():
        raise DataError(f"unknown label code {int(raw[bad][0])} (names has {len(names)})",
                        file=path, field=field)
    idx = np.clip(np.searchsorted(trial.time, times), 0, len(raw) - 1)
    return raw[idx].astype(np.int64), list(names)


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
    truth = truth_at(trial, sig.times, path=path)
    codes, names = (None, None) if truth is None else truth
    if labels == "truth":
        if codes is None:
            return np.zeros((0, 3), dtype=np.int64), None
        return runs_from_codes(codes), names
    return runs_from_stage(trial, labels, sig.times, codes, path=path), names
