"""Path bookkeeping for the observer (6.1, 6.4): path histories, change events,
and the trimmed time-indexed buffers (measurements, path log-likelihoods).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Segment", "PathInfo", "ChangeEvent", "RowBuffer", "history"]


@dataclass(frozen=True)
class Segment:
    """One feature instance ``a_{i,t} = (N_i, t)`` of a path (6.1), linked to the previous one."""

    node: int
    start: int
    prev: "Segment | None" = None


def history(seg: Segment | None) -> list[tuple[int, int]]:
    """``[(node, start), ...]`` oldest first."""
    out = []
    while seg is not None:
        out.append((seg.node, seg.start))
        seg = seg.prev
    return out[::-1]


@dataclass(frozen=True)
class PathInfo:
    """A snapshot of one active path."""

    id: int
    node: str
    start: int
    loglik: float
    probability: float
    history: list[tuple[str, int]]


@dataclass(frozen=True)
class ChangeEvent:
    """A change detected on a path, or a pruning step (``model is None``).

    time : sample at which the detector crossed ``T^2`` (6.16).
    path, node, model : the spawning path's id, its node, the model (role) whose
        detector fired.
    change_time : estimated start of the new regime, one sample after the
        detector's last zero (fig 6.4).
    spawned : ``[(node, change_time)]`` new paths actually started (after the
        maximisation over paths sharing node and start time).
    merged : ``[(node, change_time)]`` existing paths that the candidate replaced
        (higher initial path log-likelihood).
    candidates_loglik, kept : path log-likelihoods before pruning and the
        indices into it of the paths kept.
    """

    time: int
    path: int | None
    node: str | None
    model: str | None
    change_time: int | None
    spawned: list
    merged: list
    candidates_loglik: np.ndarray
    kept: np.ndarray

    @classmethod
    def _of(cls, time, path, node, model, change_time, spawned, merged, candidates_loglik,
            kept) -> "ChangeEvent":
        """The same record as the constructor, without its per-field frozen-attribute
        checks (the observer's compiled core makes tens of thousands of them an hour)."""
        e = object.__new__(cls)
        e.__dict__.update(time=time, path=path, node=node, model=model,
                          change_time=change_time, spawned=spawned, merged=merged,
                          candidates_loglik=candidates_loglik, kept=kept)
        return e

    def to_dict(self) -> dict:
        return {"time": self.time, "path": self.path, "node": self.node, "model": self.model,
                "change_time": self.change_time, "spawned": self.spawned, "merged": self.merged,
                "n_candidates": int(len(self.candidates_loglik)), "n_kept": int(len(self.kept))}


class RowBuffer:
    """Rows indexed by global sample number, appended at the end, trimmed at the front.

    Capacity grows geometrically; trimming moves the kept rows to the front
    only when the dead prefix is at least half the storage, so appends and
    trims are amortised O(rows).  ``width`` may grow (new columns are zero).
    """

    def __init__(self, width: int, *, t0: int = 0, dtype=np.float64, capacity: int = 1024):
        self.a = np.zeros((capacity, width), dtype=dtype)
        self.off = 0          # storage row of global row t0
        self.t0 = t0          # first retained global row
        self.t_end = t0       # one past the last row

    def __len__(self) -> int:
        return self.t_end - self.t0

    @property
    def width(self) -> int:
        return self.a.shape[1]

    def _reserve(self, rows: int, width: int | None = None) -> None:
        width = self.width if width is None else max(width, self.width)
        n = len(self)
        need = self.off + n + rows
        if need <= self.a.shape[0] and width == self.width:
            return
        cap = max(self.a.shape[0], 2 * (n + rows), 1024) if need > self.a.shape[0] else self.a.shape[0]
        new = np.zeros((cap, width), dtype=self.a.dtype)
        new[:n, :self.width] = self.a[self.off:self.off + n]
        self.a, self.off = new, 0

    def widen(self, width: int) -> None:
        if width > self.width:
            self._reserve(0, width)

    def append(self, rows: np.ndarray) -> None:
        rows = np.asarray(rows)
        self._reserve(len(rows))
        s = self.off + len(self)
        self.a[s:s + len(rows), :rows.shape[1]] = rows
        self.t_end += len(rows)

    def extend_to(self, t_end: int) -> None:
        """Grow to ``t_end`` with zero rows."""
        if t_end > self.t_end:
            k = t_end - self.t_end
            self._reserve(k)
            s = self.off + len(self)
            self.a[s:s + k] = 0
            self.t_end = t_end

    def rows(self, a: int, b: int) -> np.ndarray:
        """View of global rows ``a .. b-1``."""
        if a < self.t0 or b > self.t_end or a > b:
            raise IndexError(f"rows {a}..{b} outside the buffer {self.t0}..{self.t_end}")
        return self.a[self.off + a - self.t0:self.off + b - self.t0]

    def trim(self, keep_from: int) -> None:
        """Forget rows before ``keep_from``."""
        keep_from = min(max(keep_from, self.t0), self.t_end)
        self.off += keep_from - self.t0
        self.t0 = keep_from
        if self.off >= max(len(self), 1024):
            n = len(self)
            self.a[:n] = self.a[self.off:self.off + n]
            self.off = 0
