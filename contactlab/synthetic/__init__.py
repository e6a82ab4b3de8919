"""Synthetic data with known truth, generated without the simulator.

The benchmark suite of ``make bench`` (and the small cases of ``make test``)
runs every stage on data whose truth is known by construction and that owes
nothing to :mod:`contactlab.sim`, with the standard peers side by side:

- :mod:`.piecewise_ar` -- piecewise-stationary multichannel AR(2) with changes
  of variance only, of coefficients only (marginal variance held) or both,
  at 1000 Hz (segmentation; ruptures is the peer);
- :mod:`.textures` -- AR(2) texture classes, one differing only in frequency,
  one only in level, with per-segment and per-trial variation (labelling; a
  linear discriminant is the peer);
- :mod:`.switching` -- switching states (noise, two vibrations) with decaying
  impact bursts, with fixed or per-segment parameters (recognition by the
  6.4 observer; a supervised Gaussian HMM is the peer);
- :mod:`.contacts` -- point contacts (free, plane, edge, corner) with known
  constraint frames, Coulomb friction and position/force noise (constraint
  decisions, 8.2);
- :mod:`.archives` -- writes any of them as an HDF5 trace archive that the
  CLI reads like a recording.

Generators are pure functions of a seed (``numpy.random.default_rng``).
"""

from contactlab.synthetic.archives import write_archive
from contactlab.synthetic.contacts import ContactTrial, contact_trial, contact_trials
from contactlab.synthetic.piecewise_ar import (
    CHANGE_KINDS,
    PiecewiseAR,
    ar2_coefficients,
    ar2_variance,
    piecewise_ar,
    piecewise_ar_trials,
)
from contactlab.synthetic.switching import SwitchingTrial, switching_trial, switching_trials
from contactlab.synthetic.textures import TEXTURES, TextureTrial, texture_trial, texture_trials

__all__ = ["CHANGE_KINDS", "ContactTrial", "PiecewiseAR", "TEXTURES", "TextureTrial",
           "ar2_coefficients", "ar2_variance", "contact_trial", "contact_trials",
           "piecewise_ar", "piecewise_ar_trials", "SwitchingTrial", "switching_trial",
           "switching_trials", "texture_trial",
           "texture_trials", "write_archive"]
