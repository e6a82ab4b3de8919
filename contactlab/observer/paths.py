"""Path bookkeeping for the observer (6.1, 6.4): path histories, change events,
and the trimmed time-indexed buffers (measurements, path log-likelihoods).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Segment", "PathInfo", "ChangeEvent", "EventLog", "RowBuffer", "history",
           "count_changes"]


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

    Attributes
    ----------
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


class EventLog(Sequence):
    """An observer's change history: its :class:`ChangeEvent` records, in order.

    The observer's compiled core hands over its event tables a batch at a time (one row per
    event: time, then start and count of its alarms ``(path id, node, model, change
    time)``, candidate log-likelihoods, kept indices, spawned and merged ``(node, start)``);
    they are kept as arrays and a record is made when it is read, so that tens of thousands
    of detected changes an hour are not as many Python objects for the collector to scan.
    Records appended one at a time (the general form) are kept as they are.  Slices are
    views of the log.
    """

    def __init__(self, node_names, model_names):
        self._names = tuple(node_names)
        self._models = tuple(model_names)
        self._blocks: list = []       # a list of records, or (tables, record -> (row, alarm))
        self._ends: list[int] = []    # records up to the end of each block

    def __len__(self) -> int:
        return self._ends[-1] if self._ends else 0

    def append(self, event: ChangeEvent) -> None:
        if self._blocks and not isinstance(self._blocks[-1][0], tuple):
            self._blocks[-1].append(event)
            self._ends[-1] += 1
        else:
            self._blocks.append([event])
            self._ends.append(len(self) + 1)

    def add_tables(self, ev, al, cand, keep, sp, mg) -> None:
        """A batch of the compiled core's event tables (copied)."""
        ev = np.array(ev)
        n = len(al) + int(np.count_nonzero(ev[:, 2] == 0))   # one record per alarm, or one
        tables = (ev, np.array(al), np.array(cand), np.array(keep), np.array(sp), np.array(mg))
        self._blocks.append([tables, None])
        self._ends.append(len(self) + n)

    @staticmethod
    def _index(ev) -> tuple[np.ndarray, np.ndarray]:
        """Each record's event row and alarm number."""
        n_rec = np.maximum(ev[:, 2], 1)
        row = np.repeat(np.arange(len(ev)), n_rec)
        first = np.cumsum(n_rec) - n_rec
        return row, np.arange(int(n_rec.sum())) - np.repeat(first, n_rec)

    def _record(self, i: int) -> ChangeEvent:
        b = bisect.bisect_right(self._ends, i)
        block = self._blocks[b]
        j = i - (self._ends[b - 1] if b else 0)
        if not isinstance(block[0], tuple):
            return block[j]
        if block[1] is None:
            block[1] = self._index(block[0][0])
        (ev, al, cand, keep, sp, mg), (rows, alarms) = block
        ta, a0, na, c0, nc, k0, nk, s0, ns, m0, nm = ev[rows[j]].tolist()
        cl, kp = cand[c0:c0 + nc], keep[k0:k0 + nk]
        if na == 0:
            return ChangeEvent._of(ta, None, None, None, None, [], [], cl, kp)
        a = int(alarms[j])
        pid, node, k, r = al[a0 + a].tolist()
        names = self._names
        spawned = [(names[n], t) for n, t in sp[s0:s0 + ns].tolist()] if a == 0 else []
        merged = [(names[n], t) for n, t in mg[m0:m0 + nm].tolist()] if a == 0 else []
        return ChangeEvent._of(ta, pid, names[node], self._models[k], r, spawned, merged, cl, kp)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return _EventView(self, range(len(self))[i])
        n = len(self)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError("event index out of range")
        return self._record(i)

    def __iter__(self):
        for i in range(len(self)):
            yield self._record(i)

    def change_flags(self) -> np.ndarray:
        """Per record: True for a detected change (``model`` set), False for a pruning
        step, without making the records."""
        out = []
        for block in self._blocks:
            if isinstance(block[0], tuple):
                na = block[0][0][:, 2]
                out.append(np.repeat(na > 0, np.maximum(na, 1)))
            else:
                out.append(np.array([e.model is not None for e in block], dtype=bool))
        return np.concatenate(out) if out else np.zeros(0, dtype=bool)


def count_changes(events) -> int:
    """The detected changes among ``events`` (records whose ``model`` is set): an
    observer's :class:`EventLog`, a slice of one, or any sequence of records."""
    if isinstance(events, (EventLog, _EventView)):
        return int(events.change_flags().sum())
    return sum(e.model is not None for e in events)


class _EventView(Sequence):
    """A slice of an :class:`EventLog` (the events of one chunk)."""

    def __init__(self, log: EventLog, idx: range):
        self._log, self._idx = log, idx

    def __len__(self) -> int:
        return len(self._idx)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return _EventView(self._log, self._idx[i])
        return self._log._record(self._idx[i])

    def __iter__(self):
        for i in self._idx:
            yield self._log._record(i)

    def change_flags(self) -> np.ndarray:
        """:meth:`EventLog.change_flags` of the slice's records."""
        return self._log.change_flags()[self._idx.start:self._idx.stop:self._idx.step]

    def __eq__(self, other) -> bool:
        return list(self) == list(other)

    def __repr__(self) -> str:
        return repr(list(self))


class RowBuffer:
    """Rows indexed by global sample number, appended at the end, trimmed at the front.

    Capacity grows to twice the live rows plus the rows appended (geometric for small
    appends; a large one, an observer's chunk of 4096 samples over a few live rows, is
    given little more than its own room); when the end is reached and the live rows
    are at most half the storage, they move to the front (cost ``n``, after at least
    ``n`` rows were appended since the last move), so appends and trims are amortised
    O(rows).  ``width`` may grow (new columns are zero).
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
        cap, have = self.a.shape
        n = self.t_end - self.t0
        if (width is None or width <= have) and self.off + n + rows <= cap:
            return
        width = have if width is None else max(width, have)
        if width == have and n + rows <= cap and 2 * n <= cap:
            # the live rows and the new ones fit once moved to the front: move them there
            self.a[:n] = self.a[self.off:self.off + n]
            self.off = 0
            return
        if n + rows > cap or (width == have and 2 * n > cap):   # no room, or too much to move
            cap = max(cap, 2 * n + rows, 1024)
        new = np.zeros((cap, width), dtype=self.a.dtype)
        new[:n, :self.width] = self.a[self.off:self.off + n]
        self.a, self.off = new, 0

    def widen(self, width: int) -> None:
        if width > self.width:
            self._reserve(0, width)

    def append(self, rows: np.ndarray) -> None:
        rows = np.asarray(rows)
        k = rows.shape[0]
        self._reserve(k)
        s = self.off + self.t_end - self.t0
        self.a[s:s + k, :rows.shape[1]] = rows
        self.t_end += k

    def extend_to(self, t_end: int, *, zero: bool = True) -> None:
        """Grow to ``t_end`` with zero rows (``zero=False``: rows left as the storage holds
        them, for a writer that sets every entry before it is read)."""
        if t_end > self.t_end:
            k = t_end - self.t_end
            self._reserve(k)
            if zero:
                s = self.off + self.t_end - self.t0
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
        n = self.t_end - keep_from
        if self.off >= max(n, 1024):
            self.a[:n] = self.a[self.off:self.off + n]
            self.off = 0
