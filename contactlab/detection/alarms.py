"""The alarms a bank of change detectors raised, as flat arrays.

Both detectors of section 6.3.1 (Page-Hinkley and lowpass+threshold) return an
:class:`Alarms`: one row per alarm, sorted by time and then by detector, so the
alarms of a streaming run (one :meth:`update` per sample) concatenate to the
alarms of a batch :meth:`run` over the same samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit


@dataclass(frozen=True, eq=False)
class Alarms:
    """Alarms of ``D`` detectors run side by side.

    Attributes
    ----------
    time : (N,) int64 -- sample index of each alarm (global: counts every sample
        the detector has seen since it was created or :meth:`reset`).
    detector : (N,) int64 -- which of the ``D`` detectors (column) alarmed.
    side : (N,) int64 -- which one-sided test fired, an index into ``sides``
        (for a two-sided test, the side whose statistic was larger).
    change_time : (N,) int64 or None -- the Page-Hinkley change-time estimate:
        the last sample index at which the firing statistic was zero (thesis,
        fig 6.4); -1 means "before the first sample". The maximiser ``r`` of
        (6.15), the first sample of the new regime, is ``change_time + 1``
        (:attr:`onset`). ``None`` for the lowpass detector, which gives no
        estimate (fig 6.6).
    sides : names of the one-sided tests, e.g. ``("increase", "decrease")``.
    trace : the statistic at every sample, shape (n, D, K), when asked for.
    """

    time: np.ndarray
    detector: np.ndarray
    side: np.ndarray
    change_time: np.ndarray | None
    sides: tuple[str, ...] = ("up",)
    trace: np.ndarray | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return int(self.time.size)

    @property
    def onset(self) -> np.ndarray | None:
        """First sample of the new regime, the maximising ``r`` of (6.15)."""
        return None if self.change_time is None else self.change_time + 1

    @property
    def side_name(self) -> np.ndarray:
        """The name of the side that fired, per alarm."""
        return np.asarray(self.sides, dtype=object)[self.side]

    def select(self, mask: np.ndarray) -> Alarms:
        """The alarms where boolean ``mask`` (length N) is true."""
        ct = None if self.change_time is None else self.change_time[mask]
        return Alarms(self.time[mask], self.detector[mask], self.side[mask], ct, self.sides)

    def first(self, n_detectors: int, *, at_or_after: int = 0
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per detector, the first alarm at or after sample ``at_or_after``.

        Returns ``(time, change_time, side)``, each of shape (n_detectors,),
        with -1 time (and -1 side) where a detector raised no such alarm;
        change_time is all -2 for a detector without change-time estimates.
        """
        keep = self.time >= at_or_after
        det = self.detector[keep]
        uniq, idx = np.unique(det, return_index=True)  # alarms are time-sorted
        time = np.full(n_detectors, -1, dtype=np.int64)
        side = np.full(n_detectors, -1, dtype=np.int64)
        change = np.full(n_detectors, -2, dtype=np.int64)
        time[uniq] = self.time[keep][idx]
        side[uniq] = self.side[keep][idx]
        if self.change_time is not None:
            change[uniq] = self.change_time[keep][idx]
        return time, change, side

    @staticmethod
    def concat(parts: list[Alarms]) -> Alarms:
        """Alarms of consecutive runs of the same bank, in order."""
        if not parts:
            raise ValueError("concat needs at least one Alarms")
        has_ct = parts[0].change_time is not None
        return Alarms(
            np.concatenate([p.time for p in parts]),
            np.concatenate([p.detector for p in parts]),
            np.concatenate([p.side for p in parts]),
            np.concatenate([p.change_time for p in parts]) if has_ct else None,
            parts[0].sides)

    def as_rows(self) -> list[dict]:
        """One dict per alarm (for JSON output)."""
        rows = []
        for i in range(len(self)):
            row = {"time": int(self.time[i]), "detector": int(self.detector[i]),
                   "side": str(self.sides[self.side[i]])}
            if self.change_time is not None:
                row["change_time"] = int(self.change_time[i])
            rows.append(row)
        return rows


def empty_alarms(*, sides: tuple[str, ...], with_change_time: bool) -> Alarms:
    """No alarms."""
    e = np.empty(0, dtype=np.int64)
    return Alarms(e, e.copy(), e.copy(), e.copy() if with_change_time else None, sides)


def alarms_from_table(table: np.ndarray, *, sides: tuple[str, ...], with_change_time: bool,
                      trace: np.ndarray | None = None) -> Alarms:
    """Alarms from an (N, 4) int64 table of (time, detector, side, change_time)."""
    cols = np.array(np.asarray(table, dtype=np.int64).reshape(-1, 4).T, order="C")  # one copy
    return Alarms(cols[0], cols[1], cols[2], cols[3] if with_change_time else None, sides, trace)


@njit(cache=True)
def push_alarm(out, m, t, d, side, change_time):  # pragma: no cover - compiled
    """Append the alarm row (t, d, side, change_time) at row ``m`` of the growing
    table ``out`` (doubling it when full) and return the table; for numba kernels."""
    if m == out.shape[0]:
        grown = np.empty((2 * out.shape[0], 4), dtype=np.int64)
        grown[:m] = out[:m]
        out = grown
    out[m, 0] = t
    out[m, 1] = d
    out[m, 2] = side
    out[m, 3] = change_time
    return out
