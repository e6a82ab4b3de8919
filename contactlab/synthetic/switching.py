"""Switching states with impacts: the recognition data of the observer (6.4, 7.3).

Four states named like the nodes of the bundled ``hf-context-free`` graph:

- ``H0`` (noise): white noise at the floor level only;
- ``H1`` (vibration): a sharp resonance (AR(2), 60 Hz, pole radius 0.985)
  over the floor;
- ``H2`` (other vibration): a broad resonance (AR(2), 220 Hz, pole radius
  0.80) over the floor;
- ``H3`` (impact): a broadband burst (an impact excites every frequency, 7.1)
  whose amplitude decays exponentially over the impact's duration, so its log
  energy falls linearly (the impact model of 7.1), down to the level at which
  its first difference has the energy of the state that follows (the impact
  is labelled while it stands out of that state).

A trial at 1000 Hz is a sequence of segments of 0.5-1.4 s of ``H0``-``H2``
(no two neighbours alike); with probability ``impact_p`` a change of state
is announced by an impact of 0.08-0.2 s.  The channels see the state through
fixed gains (0.7-1.3, one draw: the sensor) with independent realisations;
the strains are quantised to a converter step (so ``y_h``'s log floor is a
real one).  The resonances' filter states run on across a change (the
process continues, as a physical signal would).

Two variants (``fresh``):

- fixed (``fresh=False``): every segment of a state has the state's level
  (:data:`LEVELS`) -- a supervised HMM on ``y_h`` is near perfect here;
- fresh (``fresh=True``): every segment draws its level afresh,
  log-uniformly over a range shared by all three states
  (:data:`FRESH_RANGE`), so the states differ only in their spectra, i.e.
  in the dynamics of ``y_h`` within a segment, not in its level -- the
  thesis's argument for estimating parameters per segment (6.1).

Generators are pure functions of a seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from contactlab.synthetic.piecewise_ar import ar2_coefficients, ar2_variance

__all__ = ["STATES", "LEVELS", "FRESH_RANGE", "SwitchingTrial", "switching_trial",
           "switching_trials"]

#: state name -> (resonance Hz, pole radius) of its AR(2) part (None: floor only)
STATES = {"H0": None, "H1": (60.0, 0.985), "H2": (220.0, 0.80), "H3": None}
#: standard deviation of each state's resonance (fixed variant; the floor is 1)
LEVELS = {"H0": 0.0, "H1": 4.0, "H2": 12.0}
#: range of the resonance's standard deviation in the fresh variant (all states but H0,
#: whose segments draw a floor factor in the same ratio)
FRESH_RANGE = (3.0, 15.0)
FLOOR_SD = 1.0
IMPACT_LEVEL = (40.0, 120.0)      # burst standard deviation at the impact's start
IMPACT_S = (0.08, 0.2)
STEP = 0.05                       # converter step of the strains
_GAIN_SEED = 54321


@dataclass(frozen=True, eq=False)
class SwitchingTrial:
    """One trial: strains ``y`` (N, C) at ``fs``; per-sample state ``codes`` into ``names``;
    ``starts`` the first sample of every segment; ``fresh`` the variant."""

    y: np.ndarray
    fs: float
    codes: np.ndarray
    names: list
    starts: np.ndarray
    fresh: bool = False
    seed: int = -1

    @property
    def times(self) -> np.ndarray:
        return np.arange(len(self.y)) / self.fs

    def archive_fields(self) -> dict:
        kind = "fresh" if self.fresh else "fixed"
        return dict(rate_hz=self.fs, time=self.times, measurements={"strain": self.y},
                    labels=self.codes, names=self.names,
                    environment=f"synthetic switching ({kind} parameters)",
                    description="noise / vibration / other vibration / impact bursts")


def _ar2(rng, f, r, fs, m, channels, state):
    """``m`` samples of the unit-variance AR(2) per channel, continuing ``state``."""
    a1, a2 = ar2_coefficients(f, r, fs)
    drive = 1.0 / np.sqrt(ar2_variance(a1, a2))
    e = rng.standard_normal((m, channels)) * drive
    out = np.empty((m, channels))
    for c in range(channels):
        zi = np.array([a1 * state[c, 0] + a2 * state[c, 1], a2 * state[c, 0]])
        out[:, c], _ = lfilter([1.0], [1.0, -a1, -a2], e[:, c], zi=zi)
        state[c] = (out[-1, c], out[-2, c] if m > 1 else state[c, 0])
    return out


def _white_level(name: str, level: float, floor: float, fs: float) -> float:
    """The white-noise standard deviation whose first difference has the energy of the
    state's signal (floor plus resonance): ``var(diff) = 2 var (1 - rho_1)`` with the
    AR(2)'s lag-1 autocorrelation ``rho_1 = a1 / (1 - a2)``."""
    if STATES[name] is None or level == 0:
        return floor
    a1, a2 = ar2_coefficients(*STATES[name], fs)
    return float(np.sqrt(floor ** 2 + level ** 2 * (1 - a1 / (1 - a2))))


def switching_trial(*, seed: int, fresh: bool = False, duration_s: float = 10.0,
                    fs: float = 1000.0, channels: int = 4, segment_s=(0.5, 1.4),
                    impact_p: float = 0.35) -> SwitchingTrial:
    """One trial of switching states (see the module notes)."""
    rng = np.random.default_rng(seed)
    names = list(STATES)
    gains = np.random.default_rng(_GAIN_SEED).uniform(0.7, 1.3, channels)
    n = int(round(duration_s * fs))
    y = np.empty((n, channels))
    codes = np.empty(n, np.int64)
    starts = []
    ar_state = {k: np.zeros((channels, 2)) for k in ("H1", "H2")}
    a, prev = 0, -1
    while a < n:
        cls = int(rng.choice([c for c in range(3) if c != prev]))
        name = names[cls]
        level = np.exp(rng.uniform(*np.log(FRESH_RANGE))) if fresh else LEVELS[name]
        if name == "H0":                       # the floor itself varies in the fresh variant
            floor = FLOOR_SD * (level / np.sqrt(np.prod(FRESH_RANGE)) if fresh else 1.0)
            level = 0.0
        else:
            floor = FLOOR_SD
        if prev >= 0 and rng.random() < impact_p:              # an impact announces it
            m = min(int(round(rng.uniform(*IMPACT_S) * fs)), n - a)
            peak = np.exp(rng.uniform(*np.log(IMPACT_LEVEL)))
            end = _white_level(name, level, floor, fs)
            env = peak * (end / peak) ** (np.arange(m) / m)       # log-linear down to `end`
            y[a:a + m] = env[:, None] * rng.standard_normal((m, channels))
            codes[a:a + m] = 3
            starts.append(a)
            a += m
            if a >= n:
                break
        m = min(int(round(rng.uniform(*segment_s) * fs)), n - a)
        seg = floor * rng.standard_normal((m, channels))
        if level > 0:
            seg += level * _ar2(rng, *STATES[name], fs, m, channels, ar_state[name])
        y[a:a + m] = seg
        codes[a:a + m] = cls
        starts.append(a)
        a += m
        prev = cls
    y = y * gains
    y = np.round(y / STEP) * STEP
    return SwitchingTrial(y=y, fs=fs, codes=codes, names=names, starts=np.asarray(starts),
                          fresh=bool(fresh), seed=int(seed))


def switching_trials(n_trials: int = 12, *, seed: int = 0, **kwargs) -> list[SwitchingTrial]:
    """``n_trials`` independent trials, trial ``i`` from seed ``(seed, i)``."""
    return [switching_trial(seed=int(np.random.SeedSequence([seed, i]).generate_state(1)[0]),
                            **kwargs) for i in range(n_trials)]
