"""Causal, chunk-consistent conditioning of a live stream (the live form of
:func:`contactlab.signals.trial_signals`).

:class:`LiveConditioner` takes the raw rows of one recording as they arrive (chunks
of ``time``, ``strain``, ``wrench``, ``position``, ``velocity``, ``command``,
``action``, in any split) and returns, per chunk, the observer's measurement
streams for every conditioned sample that is complete: ``{signal: (n, C)}``, the
newest input sample of each (``index``) and its time.  The concatenation of its
outputs over a recording equals ``trial_signals`` on the whole recording for every
split into chunks, bit for bit (y_h to the rounding of its log floor, below): the lowpass/decimation carries its filter
state (:class:`~contactlab.conditioning.LowpassDecimator`), the y_h block averages
carry their partial blocks (:class:`~contactlab.conditioning.LogEnergy`), the
derived velocity its last position, the task-phase lowpass its state.

Two batch quantities need the whole recording and are taken from its start instead:

* the log floor of y_h, half the smallest step of the strains
  (:func:`~contactlab.conditioning.quantisation_floor`): the first
  :data:`FLOOR_WARMUP_S` seconds are held back and the floor taken from them (the
  converter's step appears within milliseconds in noisy quantised strains, so the
  floor is the batch one, to the rounding of the differences it is the least of;
  unquantised strains have a floor far below any difference);
* the friction compensation's noise level (``contact-compensated``): live it is
  measured on the first :data:`COMPENSATION_WARMUP_S` seconds (held back until then),
  offline on the whole recording, so the compensated force can differ where the speed
  is near three times that level.

At the end of the input, :meth:`LiveConditioner.finish` returns the last samples
the batch form gives (a derived velocity clamped at the record's end, as there).
"""

from __future__ import annotations

import numpy as np

from contactlab.conditioning import (Differencer, LogEnergy, LowpassDecimator,
                                     quantisation_floor)
from contactlab.errors import UsageError
from contactlab.signals import (COMPENSATED, CONTACT_SIGNALS, PHASE, SIGNALS, phase_filter,
                                compensate_friction, cutoff_for, factor_for, hf_block_for,
                                source_of, velocity_noise_level)

__all__ = ["LiveConditioner", "needed_fields", "FLOOR_WARMUP_S"]

#: seconds of conditioned samples held back at the start of a recording to measure the
#: velocity's noise level for the friction compensation (8.29; offline it is measured on
#: the whole recording, so a live path may differ from the offline one there)
COMPENSATION_WARMUP_S = 1.0
#: strain held back at the start to find y_h's log floor: this many seconds, and at
#: least :data:`FLOOR_WARMUP_ROWS` rows
FLOOR_WARMUP_S = 0.25
FLOOR_WARMUP_ROWS = 250
_RAW = ("velocity", "position", PHASE)


def needed_fields(signals, *, has_position: bool = True) -> dict[str, tuple[str, ...]]:
    """The raw fields each stream of ``signals`` is computed from (as
    :func:`contactlab.signals.trial_signals` reads them)."""
    out = {}
    for s in signals:
        if s in CONTACT_SIGNALS:
            out[s] = ("wrench", "position")
        elif s == PHASE:
            out[s] = ("wrench",)
        elif s == "velocity":
            out[s] = ("position",) if has_position else ("velocity",)
        else:
            out[s] = (source_of(s),)
    return out


class _Low:
    """The 7.1 lowpass and decimation of :func:`contactlab.signals.lowpass`, streaming."""

    def __init__(self, fs: float, initial: str = "steady"):
        cutoff = cutoff_for(fs)
        self.f = None if cutoff is None else LowpassDecimator(
            fs=fs, cutoff_hz=cutoff, factor=factor_for(fs), initial=initial)

    def update(self, x: np.ndarray) -> np.ndarray:
        return x.copy() if self.f is None else self.f.update(x)


class _Pending:
    """Rows produced but not yet emitted, with the count produced so far."""

    def __init__(self):
        self.parts: list[np.ndarray] = []
        self.produced = 0
        self.first = 0          # global row of parts[0][0]

    def add(self, rows: np.ndarray) -> None:
        if len(rows):
            self.parts.append(rows)
            self.produced += len(rows)

    def take(self, upto: int) -> np.ndarray:
        """Rows ``first .. upto - 1`` (and drop them)."""
        a = np.concatenate(self.parts) if len(self.parts) != 1 else self.parts[0]
        k = upto - self.first
        out, rest = a[:k], a[k:]
        self.parts = [rest] if len(rest) else []
        self.first = upto
        return out

    def rows(self, rows: np.ndarray) -> np.ndarray:
        """Rows at global indices ``rows`` (all >= first, < produced); keeps them."""
        a = np.concatenate(self.parts) if len(self.parts) > 1 else self.parts[0]
        self.parts = [a]
        return a[rows - self.first]

    def drop_before(self, row: int) -> None:
        if row <= self.first or not self.parts:
            return
        a = np.concatenate(self.parts) if len(self.parts) > 1 else self.parts[0]
        a = a[row - self.first:]
        self.parts = [a] if len(a) else []
        self.first = row


class LiveConditioner:
    """The observer's streams of one live recording (see the module notes).

    Parameters
    ----------
    signals : the streams the graph's models read (``Observer.signals``).
    rate_hz : the input rate.
    fields : the raw fields the source gives (``strain``, ``wrench``, ``position``,
        ``velocity``, ...); a stream needing one it lacks is refused (UsageError).
    reduce : ``"mean"`` replaces a conditioned signal's channels by their mean (the
        models file's reduction), ``"none"`` keeps them.
    hf_floor : the log floor of y_h; None: from the first :data:`FLOOR_WARMUP_S` s.
    """

    def __init__(self, signals, *, rate_hz: float, fields, reduce: str = "none",
                 hf_floor: float | None = None, source: str = "the source"):
        self.signals = tuple(signals)
        self.fs = float(rate_hz)
        self.factor = factor_for(self.fs)
        self.block = hf_block_for(self.fs)
        self.reduce = reduce
        fields = set(fields)
        # the friction compensation needs the velocity at the conditioned samples; it is
        # computed for it when the graph's models do not read it themselves
        self._drop = ()
        if COMPENSATED in self.signals and "velocity" not in self.signals:
            self.signals += ("velocity",)
            self._drop = ("velocity",)
        for s, need in needed_fields(self.signals, has_position="position" in fields).items():
            missing = [f for f in need if f not in fields]
            if s == "velocity" and "velocity" in fields:
                missing = []
            if missing:
                raise UsageError(f"{source} gives {', '.join(sorted(fields & set(_FIELDS))) or 'no measurements'}, "
                                 f"no {missing[0]}: the graph's models read the {s!r} signal, "
                                 f"computed from it")
        self.fields = fields
        self.cond = [s for s in self.signals if s not in _RAW]
        for s in self.cond:
            if s not in SIGNALS and s not in CONTACT_SIGNALS:
                raise UsageError(f"unknown signal {s!r}")
        self.hf_floor = hf_floor
        self.reset()

    def reset(self) -> "LiveConditioner":
        """Start a new recording."""
        self.n_in = 0
        self.k_out = 0
        self._hold: list[dict] | None = [] if ("hf" in self.cond and self.hf_floor is None) \
            else None
        self._floor = self.hf_floor
        self._filters: dict[str, object] = {}
        self._out = {s: _Pending() for s in self.cond}
        self._raw = {f: _Pending() for f in ("position", "velocity") if f in self.fields}
        self._vel = None                          # derived velocity
        if "velocity" in self.signals and "velocity" not in self.fields:
            self._vel = (Differencer(pad=True), _Low(self.fs))
            self._vel_out = _Pending()
        self._phase = None
        self._phase_out = _Pending()
        self._act = _Pending()
        self._last_cmd = None
        self._last_time = _Pending()
        self._comp_level = None                   # the velocity's noise level, once known
        self._comp_hold: list = []
        return self

    @property
    def delay_samples(self) -> float:
        """The conditioning's own delay at the conditioned rate: the lowpass's DC group
        delay (input samples, over the decimation), or y_h's half block."""
        from contactlab.conditioning import lowpass_delay

        cutoff = cutoff_for(self.fs)
        d = 0.0 if cutoff is None else lowpass_delay(fs=self.fs, cutoff_hz=cutoff)
        if "hf" in self.cond:
            d = max(d, (self.block - 1) / 2.0)
        return d / self.factor

    # -- input --------------------------------------------------------------------------
    def update(self, chunk: dict) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray,
                                            np.ndarray | None]:
        """Absorb raw rows; return ``(streams, index, times, action)`` of the conditioned
        samples completed (``action``: the raw action channel or, from a ``command``, 1
        where it moves, per emitted sample; None without either)."""
        if self._hold is not None:
            self._hold.append(chunk)
            n_held = sum(len(c["time"]) for c in self._hold)
            if n_held < max(self.block + 1, FLOOR_WARMUP_ROWS, round(FLOOR_WARMUP_S * self.fs)):
                return self._empty()
            held, self._hold = self._hold, None
            strain = np.concatenate([np.asarray(c["strain"], np.float64) for c in held])
            self._floor = quantisation_floor(strain)
            chunk = {k: np.concatenate([np.asarray(c[k]) for c in held]) for k in held[0]}
        self._absorb(chunk)
        return self._compensated(self._emit(final=False), final=False)

    def finish(self) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray | None]:
        """The end of the recording: what is left (held rows, the clamped tail)."""
        if self._hold:
            held, self._hold = self._hold, None
            strain = np.concatenate([np.asarray(c["strain"], np.float64) for c in held])
            self._floor = quantisation_floor(strain)
            self._absorb({k: np.concatenate([np.asarray(c[k]) for c in held]) for k in held[0]})
        return self._compensated(self._emit(final=True), final=True)

    def _compensated(self, out, *, final: bool):
        """``out`` with the friction compensation applied to its contact-compensated
        stream: the velocity's noise level is taken from the first
        :data:`COMPENSATION_WARMUP_S` seconds, whose samples are held back until then."""
        if COMPENSATED not in self.signals:
            return out
        if self._comp_level is None:
            if len(out[1]):
                self._comp_hold.append(out)
            held = sum(len(o[1]) for o in self._comp_hold)
            first = int(round(COMPENSATION_WARMUP_S * self.fs / self.factor))
            if held < first and not final:
                return self._empty()
            hold, self._comp_hold = self._comp_hold, []
            if not hold:
                return self._empty()
            data = {s: np.concatenate([o[0][s] for o in hold]) for s in hold[0][0]}
            acts = [o[3] for o in hold]
            out = (data, np.concatenate([o[1] for o in hold]),
                   np.concatenate([o[2] for o in hold]),
                   None if any(a is None for a in acts) else np.concatenate(acts))
            self._comp_level = velocity_noise_level(data["velocity"][:first, :3])
        data = dict(out[0])
        if len(out[1]):
            c = data[COMPENSATED].copy()
            c[:, 3:6] = compensate_friction(c[:, 3:6], data["velocity"][:, :3],
                                            level=self._comp_level)
            data[COMPENSATED] = c
        for s in self._drop:
            data.pop(s, None)
        return (data, *out[1:])

    def _empty(self):
        data = {s: np.zeros((0, 1)) for s in self.signals if s not in self._drop}
        return data, np.zeros(0, np.int64), np.zeros(0), None

    def _filter(self, key: str, make):
        if key not in self._filters:
            self._filters[key] = make()
        return self._filters[key]

    def _absorb(self, chunk: dict) -> None:
        n = len(chunk["time"])
        if n == 0:
            return
        arr = {k: np.asarray(v, np.float64 if k != "action" else np.int64)
               for k, v in chunk.items() if v is not None}
        for k in ("strain", "wrench", "position", "velocity", "command"):
            if k in arr and arr[k].ndim == 1:
                arr[k] = arr[k][:, None]
        self._last_time.add(arr["time"])
        for s in self.cond:
            if s in CONTACT_SIGNALS:
                w = self._filter("wrench", lambda: _Low(self.fs)).update(arr["wrench"])
                p = self._filter("position", lambda: _Low(self.fs)).update(arr["position"])
                self._out[s].add(np.concatenate([p[:, :3], w[:, :3]], axis=1))
            elif s == "hf":
                d = self._filter("diff", Differencer).update(arr["strain"])
                e = self._filter("hf", lambda: LogEnergy(block=self.block, factor=self.factor,
                                                         floor=self._floor)).update(d)
                self._out[s].add(self._reduced(e))
            else:
                y = self._filter(s, lambda: _Low(self.fs)).update(arr[source_of(s)])
                self._out[s].add(self._reduced(y))
        for f, pend in self._raw.items():
            pend.add(arr[f])
        if self._vel is not None:
            diff, low = self._vel
            self._vel_out.add(low.update(diff.update(arr["position"]) * self.fs))
        if PHASE in self.signals:
            self._phase_out.add(self._phase_rows(arr))
        if "action" in arr:
            self._act.add(arr["action"].reshape(-1))
        elif "command" in arr:
            c = arr["command"]
            prev = c[:1] if self._last_cmd is None else self._last_cmd[None, :]
            moving = np.any(np.diff(np.concatenate([prev, c]), axis=0) != 0, axis=1)
            self._last_cmd = c[-1].copy()
            self._act.add(moving.astype(np.int64))
        self.n_in += n

    def _reduced(self, y: np.ndarray) -> np.ndarray:
        if self.reduce == "mean" and y.ndim == 2 and y.shape[1] > 1:
            return y.mean(axis=1, keepdims=True)
        return y

    def _phase_rows(self, arr: dict) -> np.ndarray:
        from scipy.signal import lfilter, lfilter_zi

        parts = [arr["wrench"]]
        if "velocity" in arr:
            parts.append(arr["velocity"][:, :3])
        elif "position" in arr:
            p = arr["position"][:, :3]
            prev = p[:1] if self._phase is None else self._phase[1][None, :]
            parts.append(np.diff(np.concatenate([prev, p]), axis=0) * self.fs)
        x = np.concatenate(parts, axis=1)
        b, a = phase_filter(self.fs)
        zi = lfilter_zi(b, a)[:, None] * x[:1] if self._phase is None else self._phase[0]
        y, zf = lfilter(b, a, x, axis=0, zi=zi)
        self._phase = (zf, arr["position"][-1, :3].copy() if "position" in arr else None)
        return y

    # -- output -------------------------------------------------------------------------
    def _index_of(self, k: np.ndarray) -> np.ndarray:
        if not self.cond:
            return self.factor - 1 + self.factor * k
        return self.factor * k + (self.block if self.cond[0] == "hf" else 0)

    def _emit(self, *, final: bool):
        ready = min((self._out[s].produced for s in self.cond), default=None)
        if ready is None:                         # kinematics only: every factor-th sample
            ready = max(0, (self.n_in - (self.factor - 1) + self.factor - 1) // self.factor)
        k = np.arange(self.k_out, ready)
        index = np.minimum(self._index_of(k), max(self.n_in - 1, 0))
        # the raw rows must have arrived; a derived velocity's row too (clamped at the end)
        ok = index < self.n_in
        if self._vel is not None and not final:
            ok &= index // self.factor < self._vel_out.produced
        n = int(np.argmin(ok)) if not ok.all() else len(k)
        k, index = k[:n], index[:n]
        if n == 0:
            return self._empty()
        stop = self.k_out + n
        data = {}
        for s in self.signals:
            if s in self._out:
                data[s] = self._out[s].take(stop)
            elif s == "velocity" and self._vel is not None:
                j = np.minimum(index // self.factor, self._vel_out.produced - 1)
                data[s] = self._vel_out.rows(j)
            elif s == PHASE:
                data[s] = self._phase_out.rows(index)
            else:
                data[s] = self._raw[s].rows(index)
        times = self._last_time.rows(index)
        action = self._act.rows(index) if self._act.produced else None
        # rows no later sample can need
        nxt = int(self._index_of(np.array([stop]))[0])
        for pend in (*self._raw.values(), self._phase_out, self._act, self._last_time):
            pend.drop_before(min(nxt, pend.produced))
        if self._vel is not None:
            self._vel_out.drop_before(min(nxt // self.factor, self._vel_out.produced - 1))
        self.k_out = stop
        return ({s: np.ascontiguousarray(v) for s, v in data.items()}, index,
                np.asarray(times, np.float64), action)


_FIELDS = ("strain", "wrench", "position", "velocity")
