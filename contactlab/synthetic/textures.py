"""Texture classes: stretches of multichannel AR(2) with class-specific spectra and level.

Three classes, as a fingertip stroking three surfaces might see them:

- ``rough``: a resonance at 30 Hz (pole radius 0.95), level 1;
- ``fine``: the same level, resonance at 45 Hz -- differs **only in frequency**;
- ``loud``: the resonance of ``rough``, level 1.6 -- differs **only in level**.

Nothing is fixed exactly: every trial draws its own level factor (log-normal,
``trial_level_sd``) and frequency factor (``trial_freq_sd``) -- a new sample,
a new contact force -- and every segment inside it draws another pair
(``segment_level_sd``, ``segment_freq_sd``).  The eight channels see the
texture through fixed gains (0.5-1.5; the gauges' placement) with independent
realisations.  A trial is a sequence of segments of 0.8-1.6 s with classes
drawn at random (no two neighbours alike), at 1000 Hz; the labels are the
ground truth.  Resonances sit below the 125 Hz of the 7.1 lowpass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from contactlab.synthetic.piecewise_ar import ar2_coefficients, ar2_variance

__all__ = ["TEXTURES", "TextureTrial", "texture_trial", "texture_trials"]

#: class name -> (resonance Hz, pole radius, level)
TEXTURES = {"rough": (30.0, 0.95, 1.0), "fine": (45.0, 0.95, 1.0), "loud": (30.0, 0.95, 1.6)}
_GAIN_SEED = 12345          # the channel gains are a property of the sensor: one draw


@dataclass(frozen=True, eq=False)
class TextureTrial:
    """One trial: ``y`` (N, C) at ``fs``; per-sample class ``codes`` into ``names``."""

    y: np.ndarray
    fs: float
    codes: np.ndarray
    names: list
    seed: int = -1

    @property
    def times(self) -> np.ndarray:
        return np.arange(len(self.y)) / self.fs

    def archive_fields(self) -> dict:
        return dict(rate_hz=self.fs, time=self.times, measurements={"strain": self.y},
                    labels=self.codes, names=self.names, environment="synthetic textures",
                    description="AR(2) textures: " + ", ".join(self.names))


def texture_trial(*, seed: int, duration_s: float = 8.0, fs: float = 1000.0, channels: int = 8,
                  segment_s=(0.8, 1.6), trial_level_sd: float = 0.15,
                  segment_level_sd: float = 0.10, trial_freq_sd: float = 0.05,
                  segment_freq_sd: float = 0.03) -> TextureTrial:
    """One trial of random texture segments (see the module notes)."""
    rng = np.random.default_rng(seed)
    names = list(TEXTURES)
    gains = np.random.default_rng(_GAIN_SEED).uniform(0.5, 1.5, channels)
    n = int(round(duration_s * fs))
    level_t = np.exp(rng.normal(0, trial_level_sd))
    freq_t = np.exp(rng.normal(0, trial_freq_sd))
    y = np.empty((n, channels))
    codes = np.empty(n, np.int64)
    a, prev = 0, -1
    state = np.zeros((channels, 2))
    while a < n:
        m = min(int(round(rng.uniform(*segment_s) * fs)), n - a)
        cls = int(rng.choice([c for c in range(len(names)) if c != prev]))
        f0, r, lev = TEXTURES[names[cls]]
        f = f0 * freq_t * np.exp(rng.normal(0, segment_freq_sd))
        level = lev * level_t * np.exp(rng.normal(0, segment_level_sd))
        a1, a2 = ar2_coefficients(f, r, fs)
        drive = level / np.sqrt(ar2_variance(a1, a2))
        e = rng.standard_normal((m, channels)) * drive * gains
        for c in range(channels):
            zi = np.array([a1 * state[c, 0] + a2 * state[c, 1], a2 * state[c, 0]])
            seg, _ = lfilter([1.0], [1.0, -a1, -a2], e[:, c], zi=zi)
            y[a:a + m, c] = seg
            state[c] = (seg[-1], seg[-2] if m > 1 else state[c, 0])
        codes[a:a + m] = cls
        a += m
        prev = cls
    return TextureTrial(y=y, fs=fs, codes=codes, names=names, seed=int(seed))


def texture_trials(n_trials: int = 12, *, seed: int = 0, **kwargs) -> list[TextureTrial]:
    """``n_trials`` independent trials, trial ``i`` from seed ``(seed, i)``."""
    return [texture_trial(seed=int(np.random.SeedSequence([seed, i]).generate_state(1)[0]),
                          **kwargs) for i in range(n_trials)]
