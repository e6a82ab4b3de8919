"""The one interface every feature model implements (6.1, 6.3), and the bank of its instances.

A feature model is a parameterised Markov measurement process with a prior on
its parameters (6.1).  The observer runs one *instance* of it per active path
that uses it (an estimator started at the path's start time, 6.4) and needs
from each instance, per sample, the log-likelihood of the measurement given
the past (6.10) and the chi-square statistic ``nu^T V^-1 nu`` of its
innovation (6.11) that the Page-Hinkley detector tests (6.14).

A model is a small object (parameters in ``__init__``) with

* ``fit(X, y=None) -> self`` (scikit-learn's convention) -- the model's parameters
  estimated from ``X``, a list of labelled segments ((n_i, C) arrays, every one a run
  of the situation the model describes; ``y`` is not used), in place; the counts
  ``n_samples_`` and ``n_segments_`` record what it learned from.  A model built
  without its parameters (``FixedVelocity(name="F")``) must be fitted before it
  scores; one built with them (a graph file's values, a models file's) need not be;

* ``name``, ``signal`` (which measurement stream it reads), ``lag`` (past
  samples its first prediction needs), ``change_size`` (None: the observer's q);
* ``dim(channels) -> m`` -- the size of the innovation vector for (6.14);
* ``tests`` -- the observer's detector tests (its ``sides``) whose alternative the
  model's innovation can show; None (the default) for all of them;
* ``init_state(starts, channels) -> dict`` -- the prior state of ``U`` new
  instances (arrays with a leading unit axis; ``{}`` for stateless models); the
  prior of an instance does not depend on its start time (the observer stacks one
  instance's prior per model and copies rows of it);
* ``run(state, x, *, t0, starts) -> (loglik, stat)`` -- advance every instance
  over the samples ``t0 .. t0+N-1``: ``x`` is ``(lag + N, C)``, the measurements
  from ``t0 - lag``; returns the ``(N, U)`` log-likelihoods and either the
  ``(N, U)`` chi-square statistics or ``(N, U, 2)``: the chi-square and the
  normalised innovation ``z`` (N(0, 1) under the model; e.g. ``sum_c alpha_c /
  sqrt(C)``) that the mean tests of the detector read (a model giving only the
  chi-square has ``z = 0``: its mean tests never fire); updates ``state`` in
  place.  Running consecutive blocks must equal one run on their union.

:class:`ModelBank` holds all instances of one model as one batch, so paths
that share a model share one vectorised update.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["FeatureModel", "ModelBank", "LOG_2PI"]

LOG_2PI = math.log(2.0 * math.pi)


class FeatureModel:
    """Base class of the feature models (see the module notes for the contract)."""

    #: the graph-file kind this class implements
    kind = ""
    lag = 0
    #: the detector tests (the observer's ``sides``: ``increase``, ``decrease``, ``up``,
    #: ``down``) whose alternative is a change of this model's measurements; None: all.
    #: A model whose innovation is a measurement residual under a trained noise level
    #: (the fixed velocity F, constraint models) takes ``("increase",)``: a residual
    #: *smaller* than its noise is still best explained by the same model, so the
    #: covariance-decrease test fired on every quiet stretch (a stuck encoder, a force
    #: below its noise) and spawned successors the graph's other nodes explain worse.
    tests: tuple[str, ...] | None = None

    def __init__(self, *, name: str, signal: str, change_size: float | None = None):
        self.name = name
        self.signal = signal
        self.change_size = change_size

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, signal={self.signal!r})"

    def fit(self, X, y=None) -> "FeatureModel":
        """Estimate the model's parameters from the labelled segments ``X`` (module notes)."""
        raise NotImplementedError(f"{type(self).__name__} has no training from segments")

    def _fitted(self, *params) -> None:
        """Raise ValueError unless every parameter named is set (given or fitted)."""
        missing = [p for p in params if getattr(self, p, None) is None]
        if missing:
            raise ValueError(f"model {self.name!r} has no {', '.join(missing)}: give "
                             f"{'it' if len(missing) == 1 else 'them'} or call fit(segments)")

    @staticmethod
    def _segments(X, name: str) -> list[np.ndarray]:
        """``X`` as a list of float (n_i, C) arrays (a single 2-d array is one segment)."""
        if isinstance(X, np.ndarray) and X.ndim == 2:
            X = [X]
        segs = [np.asarray(s, dtype=np.float64) for s in X]
        segs = [s.reshape(len(s), -1) for s in segs]
        if not segs or sum(len(s) for s in segs) == 0:
            raise ValueError(f"{name}: no labelled samples")
        return segs

    def _record(self, segs) -> None:
        self.n_samples_ = int(sum(len(s) for s in segs))
        self.n_segments_ = len(segs)

    def check_channels(self, channels: int) -> None:
        """Raise ValueError if the signal's channel count does not fit the model."""

    def dim(self, channels: int) -> int:
        return channels

    def init_state(self, starts: np.ndarray, channels: int) -> dict:
        return {}

    def batch_key(self):
        """None, or a hashable key: models with equal keys may ``run`` each other's
        (concatenated) states, as their instances are advanced by the same arithmetic
        from their own state alone."""
        return None

    def run(self, state: dict, x: np.ndarray, *, t0: int, starts: np.ndarray):
        raise NotImplementedError

    def kalman_spec(self, channels: int) -> dict | None:
        """None, or how the observer's compiled core (:mod:`contactlab.observer.engine`)
        runs this model itself: a square-root Kalman filter per channel (m = 1) with
        ``reg`` (``REG_AR``: AR regressors of ``order`` with a constant first if ``mean``;
        ``REG_TIME``: ``[1, t - start]``), ``q`` parameters, ``mode``, ``estimate_noise``,
        ``noise_prior_count``, ``channels`` and ``prior`` (:meth:`init_state` of one
        instance), exactly as :meth:`run` would."""
        return None

    def core_spec(self, channels: int) -> dict | None:
        """None, or how the compiled core runs this model: :meth:`kalman_spec`, or for a
        model scored directly by a compiled step (``reg``: ``REG_VELOCITY``,
        ``REG_CONSTRAINT``) the columns it reads (``channels``), its ``params`` row and
        the ``prior`` state row of one instance; the step is the one :meth:`run` loops."""
        return self.kalman_spec(channels)


class ModelBank:
    """All active instances of one :class:`FeatureModel`, as one batch.

    ``starts`` (U,) are the instances' start times; ``state`` the model's state
    arrays with a leading unit axis.
    """

    def __init__(self, model: FeatureModel, channels: int):
        model.check_channels(channels)
        self.model = model
        self.channels = channels
        self.starts = np.empty(0, dtype=np.int64)
        self.state = model.init_state(self.starts, channels)

    def __len__(self) -> int:
        return len(self.starts)

    def new(self, starts, model: FeatureModel | None = None) -> tuple[np.ndarray, dict]:
        """Prior state of new instances started at ``starts`` (not yet in the bank), of
        ``model`` (default the bank's; another model of the same ``batch_key``)."""
        starts = np.asarray(starts, dtype=np.int64).reshape(-1)
        return starts, (self.model if model is None else model).init_state(starts, self.channels)

    def run(self, x, *, t0: int, starts=None, state=None):
        """Advance the bank (or a detached ``state`` from :meth:`new`) over ``x``:
        ``(loglik (N, U), stat (N, U, 2))`` (chi-square, normalised innovation)."""
        if state is None:
            starts, state = self.starts, self.state
        ll, stat = self.model.run(state, x, t0=t0, starts=starts)
        stat = np.asarray(stat, dtype=np.float64)
        if stat.ndim == 2:
            stat = np.stack([stat, np.zeros_like(stat)], axis=-1)
        return ll, stat

    def extend(self, starts: np.ndarray, state: dict) -> None:
        self.starts = np.concatenate([self.starts, starts])
        self.state = {k: np.concatenate([v, state[k]]) for k, v in self.state.items()}

    def keep(self, rows) -> None:
        rows = np.asarray(rows, dtype=np.intp)
        self.starts = self.starts[rows]
        self.state = {k: v[rows] for k, v in self.state.items()}      # new C-ordered arrays
