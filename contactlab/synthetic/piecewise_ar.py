"""Piecewise-stationary multichannel AR(2) signals with known change points.

Each channel is an AR(2) process ``y(n) = a1 y(n-1) + a2 y(n-2) + e(n)`` with
complex poles ``r exp(+-i 2 pi f / fs)`` (a resonance at ``f`` Hz of
sharpness ``r``), so ``a1 = 2 r cos(2 pi f / fs)``, ``a2 = -r^2``, and a
stationary standard deviation ``s`` (the driving noise is scaled so that the
*marginal* variance is ``s^2``; closed form in :func:`ar2_variance`).  At every
change all channels switch to new parameters of one of three kinds:

- ``variance``: ``s`` scaled by ``sqrt(ratio)^(+-1)``, ratio in ``var_ratio``,
  resonance unchanged;
- ``coefficients``: resonance frequency scaled by ``freq_ratio^(+-1)``
  (radius redrawn), marginal variance held -- invisible to a test of the
  innovations' size once the estimator has adapted;
- ``mixed``: both.

Magnitudes vary per channel (drawn independently in the given ranges, one
direction per change).  The filter state runs on across a change (the process
continues, as a physical signal would).  Resonances lie in 12-100 Hz so that
they survive the 7.1 conditioning (125 Hz lowpass, 4:1 decimation), which the
lowpassed copy (:meth:`PiecewiseAR.lowpassed`) applies.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter, lfiltic

__all__ = ["CHANGE_KINDS", "PiecewiseAR", "ar2_coefficients", "ar2_variance", "piecewise_ar",
           "piecewise_ar_trials"]

CHANGE_KINDS = ("variance", "coefficients", "mixed")
FREQ_RANGE_HZ = (12.0, 100.0)
RADIUS_RANGE = (0.90, 0.97)


def ar2_coefficients(freq_hz, radius, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(a1, a2)`` of the AR(2) with poles ``radius * exp(+-2 pi i freq / fs)``."""
    w = 2 * np.pi * np.asarray(freq_hz, float) / fs
    r = np.asarray(radius, float)
    return 2 * r * np.cos(w), -r ** 2


def ar2_variance(a1, a2, noise_var=1.0):
    """Stationary variance of ``y = a1 y(-1) + a2 y(-2) + e``, ``var e = noise_var``
    (Box-Jenkins: ``(1 - a2) / ((1 + a2) ((1 - a2)^2 - a1^2))`` times ``noise_var``)."""
    a1, a2 = np.asarray(a1, float), np.asarray(a2, float)
    return noise_var * (1 - a2) / ((1 + a2) * ((1 - a2) ** 2 - a1 ** 2))


@dataclass(frozen=True, eq=False)
class PiecewiseAR:
    """One trial: ``y`` (N, C) at ``fs`` Hz, change points and per-segment parameters.

    ``boundaries`` are the first samples of segments 2..K; ``kinds`` the kind of
    each change; ``freq_hz``, ``radius``, ``sd`` are (K, C) per segment.
    """

    y: np.ndarray
    fs: float
    boundaries: np.ndarray
    kinds: list
    freq_hz: np.ndarray
    radius: np.ndarray
    sd: np.ndarray
    seed: int = -1
    meta: dict = field(default_factory=dict)

    @property
    def times(self) -> np.ndarray:
        return np.arange(len(self.y)) / self.fs

    @property
    def boundaries_s(self) -> np.ndarray:
        return self.boundaries / self.fs

    def lowpassed(self) -> tuple[np.ndarray, float]:
        """The 7.1 lowpass and decimation of ``y`` (:func:`contactlab.signals.lowpass`):
        ``(y_l, fs / factor)``; boundaries scale by ``1/factor``
        (:func:`contactlab.signals.factor_for`)."""
        from contactlab.signals import factor_for, lowpass
        return lowpass(self.y, fs=self.fs), self.fs / factor_for(self.fs)

    def archive_fields(self) -> dict:
        """Measurements and truth for :func:`contactlab.synthetic.write_archive`: the
        strains at ``fs``, one label per segment."""
        codes = np.zeros(len(self.y), np.int64)
        for b in self.boundaries:
            codes[b:] += 1
        names = [f"segment-{j}" for j in range(len(self.boundaries) + 1)]
        return dict(rate_hz=self.fs, time=self.times, measurements={"strain": self.y},
                    labels=codes, names=names, environment="piecewise-ar",
                    description="piecewise AR(2), changes: " + ", ".join(self.kinds))


def _segment_lengths(rng, n: int, fs: float, seg_s) -> np.ndarray:
    lengths = []
    total = 0
    while total < n:
        m = int(round(rng.uniform(*seg_s) * fs))
        lengths.append(m)
        total += m
    lengths[-1] -= total - n
    if lengths[-1] < seg_s[0] * fs / 2 and len(lengths) > 1:   # no stub at the end
        tail = lengths.pop()
        lengths[-1] += tail
    return np.asarray(lengths)


def piecewise_ar(*, seed: int, duration_s: float = 6.0, fs: float = 1000.0, channels: int = 8,
                 segment_s=(0.8, 1.6), kinds=CHANGE_KINDS, var_ratio=(2.5, 4.0),
                 freq_ratio=(1.6, 2.4), offset_sd: float = 5.0) -> PiecewiseAR:
    """One piecewise AR(2) trial (see the module notes); change kinds drawn from ``kinds``."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * fs))
    lengths = _segment_lengths(rng, n, fs, segment_s)
    k = len(lengths)
    lo, hi = FREQ_RANGE_HZ
    freq = np.empty((k, channels))
    radius = rng.uniform(*RADIUS_RANGE, size=(k, channels))
    sd = np.empty((k, channels))
    freq[0] = np.exp(rng.uniform(np.log(lo), np.log(hi), channels))
    sd[0] = np.exp(rng.uniform(np.log(0.5), np.log(2.0), channels))
    change_kinds = [str(rng.choice(list(kinds))) for _ in range(k - 1)]
    for j, kind in enumerate(change_kinds, start=1):
        freq[j], sd[j] = freq[j - 1], sd[j - 1]
        radius[j] = radius[j - 1] if kind == "variance" else radius[j]
        if kind in ("variance", "mixed"):
            level = sd[j - 1].mean()                     # keep levels within a decade
            up = (rng.random() < 0.5 or level < 0.3) and level < 3.0
            ratio = np.sqrt(rng.uniform(*var_ratio, channels))
            sd[j] = sd[j - 1] * (ratio if up else 1 / ratio)
        if kind in ("coefficients", "mixed"):
            f = freq[j - 1]
            ratio = rng.uniform(*freq_ratio, channels)
            up = f * ratio <= hi                          # go where there is room, per channel
            down = f / ratio >= lo
            go_up = np.where(up & down, rng.random() < 0.5, up)
            freq[j] = np.clip(np.where(go_up, f * ratio, f / ratio), lo, hi)
    a1, a2 = ar2_coefficients(freq, radius, fs)
    drive = sd / np.sqrt(ar2_variance(a1, a2))              # driving noise sd per segment
    e = rng.standard_normal((n, channels))
    y = np.empty((n, channels))
    starts = np.r_[0, np.cumsum(lengths)[:-1]]
    for c in range(channels):
        # start in the stationary distribution of the first segment: burn in 500 samples
        burn = lfilter([drive[0, c]], [1, -a1[0, c], -a2[0, c]], rng.standard_normal(500))
        prev = burn[-2:][::-1]
        for j, (a, m) in enumerate(zip(starts, lengths)):
            b, den = [drive[j, c]], [1, -a1[j, c], -a2[j, c]]
            zi = lfiltic(b, den, prev)
            seg, _ = lfilter(b, den, e[a:a + m, c], zi=zi)
            y[a:a + m, c] = seg
            prev = seg[-2:][::-1] if m >= 2 else np.r_[seg[-1], prev[0]]
    y += rng.normal(0, offset_sd, channels)                  # a constant offset per channel
    return PiecewiseAR(y=y, fs=fs, boundaries=starts[1:].astype(np.int64), kinds=change_kinds,
                       freq_hz=freq, radius=radius, sd=sd, seed=int(seed),
                       meta=dict(duration_s=duration_s, var_ratio=var_ratio,
                                 freq_ratio=freq_ratio))


def piecewise_ar_trials(n_trials: int = 12, *, seed: int = 0, **kwargs) -> list[PiecewiseAR]:
    """``n_trials`` independent trials, trial ``i`` from seed ``(seed, i)``."""
    return [piecewise_ar(seed=int(np.random.SeedSequence([seed, i]).generate_state(1)[0]),
                         **kwargs) for i in range(n_trials)]

