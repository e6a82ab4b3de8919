"""A Gaussian measurement model of a task phase on a multi-channel stream (6.1, A.2.3).

Each node of a graph learned from labels (:mod:`contactlab.observer.graph_learn`) carries
a statistical measurement model of its phase: the samples of the ``phase`` stream
(:func:`contactlab.signals.phase_stream`: the lowpassed wrench and velocity) are
independent draws of ``N(mu, Sigma)`` with a mean and a full covariance trained from
the labelled samples of the phase -- the AR(0)-with-mean form of A.2.3, its parameters
fixed at their training values (a node of 6.1 whose parameter distribution is a point;
the phases differ in force level, velocity direction and the gripper's load, which a
trained mean and covariance separate and a constraint frame does not).

Per sample: the log-likelihood ``w (-chi/2 - log det(2 pi Sigma)/2)`` and the chi-square
``chi = |W (x - mu)|^2`` (``W = L^-1``, ``Sigma = L L^T``) that the covariance-increase
test reads (data closer to the mean than the trained spread are still this phase).

``w`` is the share of an independent sample one sample carries
(:func:`contactlab.signals.sample_weight`; :func:`rate_weighted` sets it for the rate of
the data scored): the phase stream is lowpassed, so neighbouring samples repeat one
another, and counting each as a full draw would make a phase's evidence -- every
comparison of two phases, and the detector's statistic -- grow with the recording's
rate (about ninefold at 100 Hz); y_h's overlapping blocks (7.1) give it ``w = 1/2``.
The chi-square is per sample and unweighted; the covariance tests' increments carry the
weight as the log-likelihood does.

**Rivals.** The covariance test cannot see a change into a phase whose samples lie
inside this phase's spread (a broad "engage" Gaussian over 6 and 12 N, then "mated" at
3 N: the chi-square stays at its expected level).  Where the phases that may follow are
known Gaussians, Page's own test applies (Page 1954; the thesis's 6.3.1 is its
covariance-change case): the cumulative sum of the log-likelihood ratio of the
alternative over the current model.  The observer gives each Gaussian model the Gaussian
models of the nodes that may follow its node (its ``rivals``,
:meth:`GaussianFeature.with_rivals`); the model then reports ``z = max_r (ll_r - ll)``
in the place of the normalised innovation, and its ``rival`` test (increments ``z``)
alarms when some rival has explained the samples since the statistic's last zero better
by more than the threshold (nats, as every Page-Hinkley threshold of 6.18).  Measured:
Baxter pick-and-place phases 0.43 / 0.35 -> 0.66 / 0.72 of points, HIRO 0.937 / 0.997
-> 0.948 / 0.998 (``benchmarks/bench_real_phases.py``, with the weights); on the
simulated hf runs, seeds 2-10, ``hf-gaussian`` with learned edges 91.4 -> 91.9 % and
without context 74.7 -> 70.6 % (every node rivals every other there: more false
alarms, each starting a path where the rival fitted best).  The model is stateless, so
every instance scores a sample alike: :meth:`GaussianFeature.run` scores the block once (vectorised), and the
observer's compiled core runs it as a directly scored model
(:func:`gaussian_step`, :data:`contactlab.observer.engine.REG_GAUSSIAN`).

:meth:`GaussianFeature.fit` fits it; the covariance gets a ridge of
:data:`RIDGE` times each channel's variance (plus a floor) so that a channel constant
within a phase (a still axis) does not make the phase infinitely sure of itself.

**Between recordings.** The samples of one recording tell a phase's spread within that
recording only.  The same phase in another recording has its mean moved by what differs
between recordings -- a wrist sensor's offset, the grasp -- which ``offset_sd`` (per
channel) adds to the covariance as a random offset's variance: the phase models of a
graph learned from labels read the phase stream with
:data:`contactlab.signals.PHASE_OFFSET_SD` on its wrench (1 N, 0.1 N m;
:func:`contactlab.signals.phase_offset_sd`).  Trained on some recordings, recognising
others (bench_real_phases): HIRO 0.945 -> 0.969 and 0.998 (unchanged), Baxter 0.882 ->
0.947 and 0.853 -> 0.945; a learned free/contact graph on the wiping recording 92.7 ->
95.7 %.
"""

from __future__ import annotations

import numba
import numpy as np

from contactlab.observer.models.base import LOG_2PI, FeatureModel

__all__ = ["GaussianFeature", "gaussian_step", "RIDGE", "write_gaussian_models",
           "read_gaussian_models", "rate_weighted"]

#: ridge added to the trained covariance's diagonal, relative to each channel's variance
RIDGE = 1e-3
#: absolute floor of that ridge (units of the stream squared)
FLOOR = 1e-12


class GaussianFeature(FeatureModel):
    """``x ~ N(mean, cov)`` per sample (``mean`` (C,), ``cov`` (C, C) positive definite)."""

    kind = "gaussian"
    tests = ("increase",)

    def __init__(self, *, name: str, mean=None, cov=None, signal: str = "phase",
                 change_size: float | None = None, weight: float = 1.0, rivals=(),
                 ridge: float = RIDGE, offset_sd=None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        weight = float(weight)
        if not 0.0 < weight <= 1.0:
            raise ValueError(f"{name}: a sample's weight must be in (0, 1]; got {weight!r}")
        if not (np.ndim(ridge) == 0 and ridge >= 0):
            raise ValueError(f"{name}: ridge must be a number >= 0; got {ridge!r}")
        if offset_sd is not None:
            offset_sd = np.asarray(offset_sd, dtype=np.float64).reshape(-1)
            if not (np.all(np.isfinite(offset_sd)) and np.all(offset_sd >= 0)):
                raise ValueError(f"{name}: offset_sd must be finite numbers >= 0")
        self.weight, self.ridge, self.offset_sd = weight, float(ridge), offset_sd
        self.mean = self.cov = None
        self.rivals = tuple(rivals)
        if mean is not None or cov is not None:
            self._set(mean, cov)

    def _set(self, mean, cov) -> None:
        name = self.name
        if mean is None or cov is None:
            raise ValueError(f"{name}: give the mean and the covariance together (or call fit)")
        mean = np.asarray(mean, dtype=np.float64).reshape(-1)
        cov = np.asarray(cov, dtype=np.float64)
        C = len(mean)
        if C < 1 or cov.shape != (C, C) or not np.all(np.isfinite(cov)) \
                or not np.all(np.isfinite(mean)):
            raise ValueError(f"{name}: need a finite mean (C,) and covariance (C, C); got "
                             f"{mean.shape} and {cov.shape}")
        rivals = self.rivals
        for r in rivals:
            if not isinstance(r, GaussianFeature) or r.channels != C or r.rivals:
                raise ValueError(f"{name}: a rival must be a Gaussian model of {C} channels "
                                 f"without rivals of its own")
        try:
            L = np.linalg.cholesky(0.5 * (cov + cov.T))
        except np.linalg.LinAlgError:
            raise ValueError(f"{name}: covariance is not positive definite") from None
        self.mean, self.cov = mean, cov
        W = np.linalg.inv(L)
        const = -float(np.sum(np.log(np.diag(L)))) - 0.5 * C * LOG_2PI
        self._W = np.tril(W)
        self._const = const
        if rivals:
            self.tests = ("increase", "rival")
        # the compiled step's row: C, then each model (this one, then its rivals) as
        # weight, constant, mean (C), W (C x C)
        self._p = np.concatenate([[C, len(rivals)]] + [
            np.concatenate([[m.weight, m._const], m.mean, m._W.reshape(-1)])
            for m in (self,) + rivals])

    def fit(self, X, y=None) -> "GaussianFeature":
        """The mean and covariance of every sample of the segments ``X`` (a list of
        (n_i, C)), the covariance's diagonal raised by ``ridge`` times each channel's
        variance plus a floor, and by ``offset_sd**2`` where given (module notes)."""
        segs = [s for s in self._segments(X, self.name) if len(s)]
        x = np.concatenate(segs)
        if len(x) < 2:
            raise ValueError(f"Gaussian model {self.name!r} needs at least 2 labelled "
                             f"samples; got {len(x)}")
        cov = np.atleast_2d(np.cov(x, rowvar=False))
        between = np.zeros(len(cov))
        if self.offset_sd is not None:
            if len(self.offset_sd) != len(cov):
                raise ValueError(f"Gaussian model {self.name!r}: offset_sd has "
                                 f"{len(self.offset_sd)} values for {len(cov)} channels")
            between = self.offset_sd ** 2
        self._set(x.mean(axis=0),
                  cov + np.diag(self.ridge * np.diag(cov) + FLOOR + between))
        self._record(segs)
        return self

    @property
    def channels(self) -> int:
        self._fitted("mean", "cov")
        return len(self.mean)

    def check_channels(self, channels: int) -> None:
        if channels != self.channels:
            raise ValueError(f"model {self.name!r} was trained on {self.channels} channels; "
                             f"the {self.signal!r} signal has {channels}")

    def dim(self, channels: int) -> int:
        return self.channels

    def init_state(self, starts, channels):
        return {}

    def batch_key(self):
        return None

    def score(self, x) -> tuple[np.ndarray, np.ndarray]:
        """``(loglik (N,), chi-square (N,))`` of samples ``x`` (N, C); the log-likelihood
        weighted by :attr:`weight`."""
        self._fitted("mean", "cov")
        d = (np.asarray(x, dtype=np.float64) - self.mean) @ self._W.T
        chi = np.einsum("nc,nc->n", d, d)
        return self.weight * (self._const - 0.5 * chi), chi

    def rival_margin(self, x, ll=None) -> np.ndarray:
        """``z = max_r (ll_r - ll)`` per sample of ``x`` over the rivals (0 without any)."""
        if ll is None:
            ll = self.score(x)[0]
        if not self.rivals:
            return np.zeros(len(ll))
        best = np.max([r.score(x)[0] for r in self.rivals], axis=0)
        return best - ll

    def run(self, state, x, *, t0, starts):
        ll, chi = self.score(x)
        z = self.rival_margin(x, ll)
        U = len(starts)
        stat = np.stack([chi, z], axis=-1)
        return (np.repeat(ll[:, None], U, axis=1),
                np.repeat(stat[:, None, :], U, axis=1))

    def with_weight(self, weight: float) -> "GaussianFeature":
        """The same model with the log-likelihood weight ``weight`` (self if unchanged)."""
        if float(weight) == self.weight:
            return self
        return self._copy(weight=float(weight), rivals=self.rivals)

    def with_rivals(self, rivals) -> "GaussianFeature":
        """The same model testing for a change into any of ``rivals`` (module notes)."""
        rivals = tuple(r for r in rivals if r is not self)
        if rivals == self.rivals:
            return self
        return self._copy(weight=self.weight, rivals=rivals)

    def _copy(self, *, weight, rivals) -> "GaussianFeature":
        self._fitted("mean", "cov")
        m = type(self)(name=self.name, mean=self.mean, cov=self.cov, signal=self.signal,
                       change_size=self.change_size, weight=weight, rivals=rivals,
                       ridge=self.ridge)
        m.__dict__.update({k: v for k, v in self.__dict__.items()
                           if k.endswith("_") and not k.startswith("_")})
        return m

    def core_spec(self, channels):
        if type(self).run is not GaussianFeature.run:
            return None
        from contactlab.observer.engine import REG_GAUSSIAN

        return {"reg": REG_GAUSSIAN, "channels": channels, "prior": np.zeros(1),
                "params": self._p}


@numba.njit(cache=True, inline="always")
def _gaussian_part(p, o, x, C):  # pragma: no cover - compiled
    """``(weighted log-likelihood, chi-square)`` of ``x`` under the model whose row starts
    at ``p[o]``: weight, constant, mean (C), W (C x C)."""
    chi = 0.0
    for i in range(C):
        s = 0.0
        for j in range(i + 1):
            s += p[o + 2 + C + i * C + j] * (x[j] - p[o + 2 + j])
        chi += s * s
    return p[o] * (p[o + 1] - 0.5 * chi), chi


@numba.njit(cache=True)
def gaussian_step(p, x):  # pragma: no cover - compiled
    """Score one sample ``x`` (C channels): ``(log-likelihood, chi-square, rival margin)``;
    ``p``: C, the number of rivals R, then the model and each rival as weight, constant
    ``-log det(2 pi Sigma) / 2``, mean (C) and ``W = L^-1`` row by row (C x C, lower
    triangular).  The margin is ``max_r ll_r - ll`` (0 without rivals)."""
    C = x.shape[0]
    R = int(p[1])
    width = 2 + C + C * C
    ll, chi = _gaussian_part(p, 2, x, C)
    if R == 0:
        return ll, chi, 0.0
    best = -np.inf
    for r in range(R):
        lr, _ = _gaussian_part(p, 2 + (r + 1) * width, x, C)
        best = lr if lr > best else best
    return ll, chi, best - ll


def write_gaussian_models(h5, models: dict) -> None:
    """Store ``{label: GaussianFeature}`` under ``/gaussian/<i>`` of a models file."""
    g = h5.create_group("gaussian")
    for i, (label, m) in enumerate(models.items()):
        sub = g.create_group(str(i))
        sub.attrs["label"] = label
        sub.attrs["signal"] = m.signal
        sub.attrs["n_samples"] = int(getattr(m, "n_samples_", 0))
        sub.create_dataset("mean", data=np.asarray(m.mean, np.float64))
        sub.create_dataset("cov", data=np.asarray(m.cov, np.float64))


def _read(sub):
    label = sub.attrs["label"]
    label = label.decode() if isinstance(label, bytes) else str(label)
    sig = sub.attrs.get("signal", "phase")
    sig = sig.decode() if isinstance(sig, bytes) else str(sig)
    m = GaussianFeature(name=label, mean=sub["mean"][()], cov=sub["cov"][()], signal=sig)
    m.n_samples_ = int(sub.attrs.get("n_samples", 0))
    return label, m


def read_gaussian_models(h5, path) -> dict:
    """The models :func:`write_gaussian_models` stored (empty when absent)."""
    from contactlab.observer.kinematics import read_groups

    return read_groups(h5, "gaussian", path, "Gaussian model", _read)


def rate_weighted(models: dict, rate_hz: float) -> dict:
    """``models`` with every :class:`GaussianFeature` weighted for its stream recorded at
    ``rate_hz`` (:func:`contactlab.signals.sample_weight`; the other models unchanged).
    The weight belongs to the data scored, not to the training: a model trained at 100 Hz
    scores a 200 Hz recording with the 200 Hz weight."""
    from contactlab.signals import sample_weight

    return {k: (m.with_weight(sample_weight(m.signal, rate_hz))
                if isinstance(m, GaussianFeature) else m) for k, m in models.items()}
