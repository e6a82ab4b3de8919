"""Signal conditioning of section 7.1: 1000 Hz strains -> 250 Hz signals.

The thesis samples the strains ``y(n)`` at 1000 Hz and forms

* the first difference ``y_d(n) = y(n) - y(n-1)``;
* ``y_l``: the raw strains lowpassed "with a second order filter at 125 Hz"
  and subsampled 4:1 to 250 Hz.  The filter type is not given; we use a
  **second-order Butterworth** (maximally flat pass band, no ripple to colour
  the measurement noise) designed with ``scipy.signal.butter`` as
  second-order sections;
* ``y_h``: the high-frequency energy signal ``log|y_d(n)|`` "averaged in
  blocks of 8 points and sub-sampled 4:1" -- a causal moving average of 8
  samples taken every 4th sample, so consecutive blocks overlap by 4;
* velocity: position first-differenced and lowpassed (chapter 1), here with
  the same filter and decimation so that every 250 Hz signal shares one
  time base.

Arrays are time-first: ``(N,)`` for one channel or ``(N, C)`` for C channels,
all processed together; outputs keep the input's dimensionality.  Everything
is causal.  Each batch function is the one-chunk case of a streaming class
(:class:`LowpassDecimator`, :class:`LogEnergy`, :class:`Differencer`,
:class:`StrainConditioner`, :class:`VelocityEstimator`) whose ``update(chunk)``
on consecutive chunks returns exactly the batch result.

Output sample times (input sample indices n = 0, 1, ... at ``fs``):

* ``y_l[k]`` is the filter output at input sample ``n = factor * k`` (0, 4,
  8, ...).  The second-order Butterworth at fs/8 delays low frequencies by
  its DC group delay, about 1.71 input samples (1.7 ms at 1000 Hz), so
  ``y_l[k]`` describes the strain at about ``4k - 1.7``
  (:func:`lowpass_delay`).
* ``y_d`` has one sample fewer than ``y``: ``y_d[i]`` belongs to input sample
  ``i + 1`` (there is no ``y(-1)``).
* ``y_h[k]`` averages ``log|y_d|`` over input samples ``4k + 1 ... 4k + 8``:
  it is complete at input sample ``4k + 8`` (a multiple of 4, on the same
  250 Hz grid as ``y_l``: ``y_h[k]`` and ``y_l[k + 2]`` are simultaneous) and
  centred at ``4k + 4.5``, i.e. delayed by ``(block - 1) / 2 = 3.5`` samples.

:class:`Conditioned` carries these indices (``low_index``, ``hf_index``) and
delays.

``log(0)``: quantised strains have exact zeros in ``y_d``.  ``log|y_d|`` is
taken of ``max(|y_d|, floor)``.  The default floor, ``1e-12``, only keeps the
logarithm finite; for quantised data pass ``floor = lsb / 2`` (half the
quantisation step), the natural magnitude of a difference that rounds to zero,
which keeps the zeros from dragging the block averages to -27.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = [
    "DEFAULT_LOG_FLOOR", "butter_sos", "lowpass_delay", "difference", "lowpass_decimate",
    "log_energy", "velocity_from_position", "condition_strains", "Conditioned",
    "quantisation_floor",
    "Differencer", "LowpassDecimator", "LogEnergy", "StrainConditioner", "VelocityEstimator",
]

#: floor under ``|y_d|`` before the logarithm when no quantisation step is known
DEFAULT_LOG_FLOOR = 1e-12

_INITIAL = ("steady", "zero")


# -- helpers ---------------------------------------------------------------------------

def _as_2d(x, name: str) -> tuple[np.ndarray, bool]:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        return a[:, None], True
    if a.ndim != 2:
        raise ValueError(f"{name} must be (N,) or (N, channels) with time first; got {a.shape}")
    return a, False


def _out(a: np.ndarray, squeeze: bool) -> np.ndarray:
    return a[:, 0] if squeeze else a


def _check_positive_int(value, name: str) -> int:
    if not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1; got {value!r}")
    return int(value)


def butter_sos(*, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2) -> np.ndarray:
    """Butterworth lowpass as second-order sections (``scipy.signal.butter``)."""
    _check_positive_int(order, "order")
    if not (fs > 0 and 0 < cutoff_hz < fs / 2):
        raise ValueError(f"cutoff_hz must be between 0 and fs/2 = {fs / 2}; got {cutoff_hz!r}")
    return _designed(float(fs), float(cutoff_hz), int(order))[0].copy()


@functools.lru_cache(maxsize=64)
def _designed(fs: float, cutoff_hz: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """The Butterworth sections and their unit-step initial state (``sosfilt_zi``),
    designed once per setting: a batch of trials conditions each with the same filter,
    and the design costs as much as filtering a 10-s trial."""
    from scipy import signal      # on first use: it costs 0.5 s to import

    sos = signal.butter(order, cutoff_hz, btype="low", fs=fs, output="sos")
    zi = signal.sosfilt_zi(sos)
    sos.flags.writeable = zi.flags.writeable = False
    return sos, zi


def lowpass_delay(*, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2) -> float:
    """DC group delay of :func:`butter_sos`, in input samples (~1.71 for the defaults)."""
    from scipy import signal

    b, a = signal.sos2tf(butter_sos(fs=fs, cutoff_hz=cutoff_hz, order=order))
    _, gd = signal.group_delay((b, a), w=[1e-6])
    return float(gd[0])


# -- streaming stages ------------------------------------------------------------------

class Differencer:
    """Streaming first difference ``y_d(n) = y(n) - y(n-1)``.

    ``pad=False``: the first sample has no predecessor and yields no output
    (``len(out) = len(in) - 1`` overall).  ``pad=True``: ``y(-1) := y(0)``, so
    the first output is 0 and lengths are preserved.
    """

    def __init__(self, *, pad: bool = False):
        self.pad = pad
        self.reset()

    def reset(self) -> "Differencer":
        self.last_ = None
        return self

    def update(self, chunk) -> np.ndarray:
        x, squeeze = _as_2d(chunk, "chunk")
        if len(x) == 0:
            return _out(np.empty((0, x.shape[1])), squeeze)
        if self.last_ is None:
            prev = x[:1] if self.pad else None
        else:
            prev = self.last_[None, :]
        y = np.diff(x, axis=0) if prev is None else np.diff(np.concatenate([prev, x]), axis=0)
        self.last_ = x[-1].copy()
        return _out(y, squeeze)


class LowpassDecimator:
    """Streaming Butterworth lowpass followed by ``factor``:1 decimation.

    Output k is the filter output at input sample ``factor * k``.

    Parameters
    ----------
    fs, cutoff_hz, order : the filter (second-order Butterworth at 125 Hz
        for 1000 Hz input by default, 7.1).
    factor : decimation factor (4: 1000 Hz -> 250 Hz).
    initial : ``"steady"`` (default) starts the filter in the steady state of
        the first sample (as if the signal had held that value forever --
        ``sosfilt_zi * y[0]``, still causal); ``"zero"`` starts from rest.  Raw
        strains carry large offsets, and from rest the filter would ring from
        0 up to the offset, a start-up transient the change detector flags.
    """

    def __init__(self, *, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2,
                 factor: int = 4, initial: str = "steady"):
        self.fs = fs
        self.cutoff_hz = cutoff_hz
        self.order = order
        self.factor = factor
        self.initial = initial
        if initial not in _INITIAL:
            raise ValueError(f"initial must be one of {_INITIAL}; got {initial!r}")
        _check_positive_int(factor, "factor")
        self.sos_ = butter_sos(fs=fs, cutoff_hz=cutoff_hz, order=order)
        self._zi_unit = _designed(float(fs), float(cutoff_hz), int(order))[1]
        self.reset()

    def reset(self) -> "LowpassDecimator":
        self.zi_ = None
        self.n_in_ = 0
        return self

    def update(self, chunk) -> np.ndarray:
        x, squeeze = _as_2d(chunk, "chunk")
        if len(x) == 0:
            return _out(np.empty((0, x.shape[1])), squeeze)
        if self.zi_ is None:
            zi = self._zi_unit[:, :, None]                          # (sections, 2, 1)
            scale = x[0][None, None, :] if self.initial == "steady" else 0.0
            self.zi_ = np.ascontiguousarray(zi * scale * np.ones((1, 1, x.shape[1])))
        first = (-self.n_in_) % self.factor
        self.n_in_ += len(x)
        out = np.empty((len(range(first, len(x), self.factor)), x.shape[1]))
        _sosfilt_every(self.sos_, np.ascontiguousarray(x, dtype=np.float64), self.zi_,
                       first, self.factor, out)
        return _out(out, squeeze)


@njit(cache=True, nogil=True)
def _sosfilt_every(sos, x, zi, first, factor, out):  # pragma: no cover - compiled
    """``scipy.signal.sosfilt(sos, x, axis=0, zi=zi)[first::factor]`` into ``out``, with
    ``zi`` (sections, 2, C) advanced in place: the transposed direct form II of scipy's
    own loop, step for step (the same numbers), keeping only the decimated outputs
    (the 4:1 decimation of 7.1 reads one filter output in four)."""
    n, c = x.shape
    sections = sos.shape[0]
    k = 0
    for i in range(n):
        keep = i >= first and (i - first) % factor == 0
        for ch in range(c):
            x_n = x[i, ch]
            for s in range(sections):
                x_cur = sos[s, 0] * x_n + zi[s, 0, ch]
                zi[s, 0, ch] = sos[s, 1] * x_n - sos[s, 4] * x_cur + zi[s, 1, ch]
                zi[s, 1, ch] = sos[s, 2] * x_n - sos[s, 5] * x_cur
                x_n = x_cur
            if keep:
                out[k, ch] = x_n
        if keep:
            k += 1


class LogEnergy:
    """Streaming ``log|x|`` averaged over blocks of ``block`` samples every ``factor``.

    Output k is the mean of ``log(max(|x|, floor))`` over ``x[factor*k :
    factor*k + block]`` (a causal moving average sampled every ``factor``-th
    sample; with 8 and 4 consecutive blocks overlap by 4).  The sum runs in a
    fixed order, so chunked and batch results are bit-identical.
    """

    def __init__(self, *, block: int = 8, factor: int = 4, floor: float = DEFAULT_LOG_FLOOR):
        self.block = _check_positive_int(block, "block")
        self.factor = _check_positive_int(factor, "factor")
        if not (np.isfinite(floor) and floor > 0):
            raise ValueError(f"floor must be a positive number; got {floor!r}")
        self.floor = float(floor)
        self.reset()

    def reset(self) -> "LogEnergy":
        self.buffer_ = None      # log|x| from the start of the next block on
        self.skip_ = 0           # samples still to drop before the next block starts
        self.n_out_ = 0
        return self

    def update(self, chunk) -> np.ndarray:
        x, squeeze = _as_2d(chunk, "chunk")
        h = np.log(np.maximum(np.abs(x), self.floor))
        if self.skip_:
            drop = min(self.skip_, len(h))
            h = h[drop:]
            self.skip_ -= drop
        buf = h if self.buffer_ is None else np.concatenate([self.buffer_, h])
        n = len(buf)
        K = (n - self.block) // self.factor + 1 if n >= self.block else 0
        out = np.empty((K, x.shape[1]))
        if K:
            span = self.factor * (K - 1) + 1
            acc = buf[0:span:self.factor].copy()
            for j in range(1, self.block):
                acc += buf[j:j + span:self.factor]
            out = acc / self.block
            consumed = self.factor * K
            self.skip_ = max(consumed - n, 0)
            buf = buf[consumed:]
        self.buffer_ = buf
        self.n_out_ += K
        return _out(out, squeeze)


# -- batch functions -----------------------------------------------------------------------

def difference(y, *, prepend=None) -> np.ndarray:
    """First difference ``y_d(n) = y(n) - y(n-1)`` along time (axis 0).

    Without ``prepend`` the result has one sample fewer: ``y_d[i]`` belongs to
    input sample ``i + 1``.  With ``prepend`` (the sample before ``y[0]``,
    shape (C,) or scalar) it has the same length.
    """
    x, squeeze = _as_2d(y, "y")
    d = Differencer()
    if prepend is not None:
        d.last_ = np.broadcast_to(np.asarray(prepend, dtype=np.float64), (x.shape[1],)).copy()
    return _out(d.update(x), squeeze)


def lowpass_decimate(y, *, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2,
                     factor: int = 4, initial: str = "steady") -> np.ndarray:
    """Butterworth lowpass then ``factor``:1 decimation -- ``y_l`` of 7.1.

    Equals ``scipy.signal.sosfilt(butter(order, cutoff_hz, fs=fs, output="sos"),
    y, axis=0, zi=...)[::factor]`` with ``zi`` the steady state of ``y[0]``
    (``initial="steady"``) or zero (``initial="zero"``).  Output k is at input
    sample ``factor * k``; see :func:`lowpass_delay` for the filter delay.
    """
    return LowpassDecimator(fs=fs, cutoff_hz=cutoff_hz, order=order, factor=factor,
                            initial=initial).update(y)


def quantisation_floor(y) -> float:
    """Half the smallest non-zero step of ``y`` along time: half an LSB for quantised
    data, the ``floor`` under ``|y_d|`` that keeps exact zeros of the difference
    from entering y_h as ``log(1e-12)`` (see the module notes).  Falls back to
    :data:`DEFAULT_LOG_FLOOR` for constant data."""
    steps = np.abs(np.diff(np.asarray(y, dtype=np.float64), axis=0))
    steps = steps[steps > 0]
    return float(steps.min() / 2) if steps.size else DEFAULT_LOG_FLOOR


def log_energy(y, *, block: int = 8, factor: int = 4,
               floor: float = DEFAULT_LOG_FLOOR) -> np.ndarray:
    """``y_h`` of 7.1 from ``y`` = the differenced strain ``y_d``.

    Output k is the mean of ``log(max(|y|, floor))`` over ``y[factor*k :
    factor*k + block]``; ``(N - block) // factor + 1`` outputs (none if
    ``N < block``).  See the module notes on the choice of ``floor``.
    """
    return LogEnergy(block=block, factor=factor, floor=floor).update(y)


def velocity_from_position(p, *, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2,
                           factor: int = 4) -> np.ndarray:
    """Velocity from position: first difference times ``fs``, lowpassed, decimated.

    The thesis (chapter 1) differences then lowpasses the encoder position;
    it gives no cutoff, so the default is the strain conditioning's (125 Hz,
    4:1), putting velocity on the same 250 Hz grid as ``y_l``: output k is at
    input sample ``factor * k``.  ``p(-1) := p(0)`` (the robot was at rest
    before the record), so the filter starts from rest with velocity 0.  The
    backward difference adds half a sample to the filter delay.
    """
    return VelocityEstimator(fs=fs, cutoff_hz=cutoff_hz, order=order, factor=factor).update(p)


@dataclass(frozen=True)
class Conditioned:
    """Output of :func:`condition_strains` / :meth:`StrainConditioner.update`.

    Attributes
    ----------
    low : (K_l, C) ``y_l``, lowpassed and decimated strains.
    hf : (K_h, C) ``y_h``, block-averaged ``log|y_d|``.
    fs_out : output rate (250 Hz by default).
    low_index : (K_l,) input sample index of each ``low`` output (its newest input).
    hf_index : (K_h,) input sample index of the newest input in each ``hf`` block.
    low_delay : DC group delay of the lowpass, input samples (``low[k]``
        describes input time ``low_index[k] - low_delay``).
    hf_delay : ``(block - 1) / 2``: ``hf[k]`` is centred at ``hf_index[k] - hf_delay``.
    fs : input rate.
    """

    low: np.ndarray
    hf: np.ndarray
    fs_out: float
    low_index: np.ndarray
    hf_index: np.ndarray
    low_delay: float
    hf_delay: float
    fs: float

    def low_times(self, t0: float = 0.0) -> np.ndarray:
        """Times (s) of the ``low`` samples' newest inputs, input sample 0 at ``t0``."""
        return t0 + self.low_index / self.fs

    def hf_times(self, t0: float = 0.0) -> np.ndarray:
        """Times (s) of the ``hf`` blocks' newest inputs, input sample 0 at ``t0``."""
        return t0 + self.hf_index / self.fs


class StrainConditioner:
    """Streaming form of :func:`condition_strains` (the 7.1 pipeline).

    ``update(chunk)`` on consecutive chunks of the 1000 Hz strains returns the
    new 250 Hz outputs as a :class:`Conditioned` whose indices continue from
    the previous chunk; concatenating them gives the batch result exactly.
    """

    def __init__(self, *, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2,
                 factor: int = 4, block: int = 8, log_floor: float = DEFAULT_LOG_FLOOR,
                 initial: str = "steady"):
        self.fs = fs
        self.cutoff_hz = cutoff_hz
        self.order = order
        self.factor = factor
        self.block = block
        self.log_floor = log_floor
        self.initial = initial
        self._low = LowpassDecimator(fs=fs, cutoff_hz=cutoff_hz, order=order, factor=factor,
                                     initial=initial)
        self._diff = Differencer()
        self._energy = LogEnergy(block=block, factor=factor, floor=log_floor)
        self.low_delay_ = lowpass_delay(fs=fs, cutoff_hz=cutoff_hz, order=order)
        self.reset()

    def reset(self) -> "StrainConditioner":
        self._low.reset()
        self._diff.reset()
        self._energy.reset()
        self._n_low = 0
        return self

    def update(self, chunk) -> Conditioned:
        x, squeeze = _as_2d(chunk, "strain")
        low = self._low.update(x)
        k0 = self._energy.n_out_
        hf = self._energy.update(self._diff.update(x))
        low_index = self.factor * np.arange(self._n_low, self._n_low + len(low))
        hf_index = self.factor * np.arange(k0, k0 + len(hf)) + self.block
        self._n_low += len(low)
        return Conditioned(low=_out(low, squeeze), hf=_out(hf, squeeze),
                           fs_out=self.fs / self.factor, low_index=low_index,
                           hf_index=hf_index, low_delay=self.low_delay_,
                           hf_delay=(self.block - 1) / 2.0, fs=float(self.fs))


class VelocityEstimator:
    """Streaming form of :func:`velocity_from_position`."""

    def __init__(self, *, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2,
                 factor: int = 4):
        self.fs = fs
        self._diff = Differencer(pad=True)
        self._low = LowpassDecimator(fs=fs, cutoff_hz=cutoff_hz, order=order, factor=factor,
                                     initial="zero")

    def reset(self) -> "VelocityEstimator":
        self._diff.reset()
        self._low.reset()
        return self

    def update(self, chunk) -> np.ndarray:
        x, squeeze = _as_2d(chunk, "position")
        return _out(self._low.update(self._diff.update(x) * self.fs), squeeze)


def condition_strains(strain, *, fs: float = 1000.0, cutoff_hz: float = 125.0, order: int = 2,
                      factor: int = 4, block: int = 8, log_floor: float = DEFAULT_LOG_FLOOR,
                      initial: str = "steady") -> Conditioned:
    """The 7.1 pipeline on raw strains (N,) or (N, C) sampled at ``fs``.

    Returns ``low`` (``y_l``: Butterworth lowpass at ``cutoff_hz``, decimated
    ``factor``:1) and ``hf`` (``y_h``: mean of ``log|y_d|`` over ``block``
    samples every ``factor``), both at ``fs / factor``, with the input sample
    index of every output (see the module notes).  For quantised strains pass
    ``log_floor = lsb / 2``.
    """
    return StrainConditioner(fs=fs, cutoff_hz=cutoff_hz, order=order, factor=factor, block=block,
                             log_floor=log_floor, initial=initial).update(strain)
