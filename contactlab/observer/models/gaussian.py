"""A Gaussian measurement model of a task phase on a multi-channel stream (6.1, A.2.3).

Each node of a graph learned from labels (:mod:`contactlab.observer.graph_learn`) carries
a statistical measurement model of its phase: the samples of the ``phase`` stream
(:func:`contactlab.signals.phase_stream`: the lowpassed wrench and velocity) are
independent draws of ``N(mu, Sigma)`` with a mean and a full covariance trained from
the labelled samples of the phase -- the AR(0)-with-mean form of A.2.3, its parameters
fixed at their training values (a node of 6.1 whose parameter distribution is a point;
the phases differ in force level, velocity direction and the gripper's load, which a
trained mean and covariance separate and a constraint frame does not).

Per sample: the log-likelihood ``-chi/2 - log det(2 pi Sigma)/2`` and the chi-square
``chi = |W (x - mu)|^2`` (``W = L^-1``, ``Sigma = L L^T``) that the covariance-increase
test reads (``tests = ("increase",)``: data closer to the mean than the trained spread
are still this phase).  The model is stateless, so every instance scores a sample
alike: :meth:`GaussianFeature.run` scores the block once (vectorised), and the
observer's compiled core runs it as a directly scored model
(:func:`gaussian_step`, :data:`contactlab.observer.engine.REG_GAUSSIAN`).

:meth:`GaussianFeature.from_segments` fits it; the covariance gets a ridge of
:data:`RIDGE` times each channel's variance (plus a floor) so that a channel constant
within a phase (a still axis) does not make the phase infinitely sure of itself.
"""

from __future__ import annotations

import numba
import numpy as np

from contactlab.observer.models.base import LOG_2PI, FeatureModel

__all__ = ["GaussianFeature", "gaussian_step", "RIDGE", "write_gaussian_models",
           "read_gaussian_models"]

#: ridge added to the trained covariance's diagonal, relative to each channel's variance
RIDGE = 1e-3
#: absolute floor of that ridge (units of the stream squared)
FLOOR = 1e-12


class GaussianFeature(FeatureModel):
    """``x ~ N(mean, cov)`` per sample (``mean`` (C,), ``cov`` (C, C) positive definite)."""

    kind = "gaussian"
    tests = ("increase",)

    def __init__(self, *, name: str, mean, cov, signal: str = "phase",
                 change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        mean = np.asarray(mean, dtype=np.float64).reshape(-1)
        cov = np.asarray(cov, dtype=np.float64)
        C = len(mean)
        if C < 1 or cov.shape != (C, C) or not np.all(np.isfinite(cov)) \
                or not np.all(np.isfinite(mean)):
            raise ValueError(f"{name}: need a finite mean (C,) and covariance (C, C); got "
                             f"{mean.shape} and {cov.shape}")
        try:
            L = np.linalg.cholesky(0.5 * (cov + cov.T))
        except np.linalg.LinAlgError:
            raise ValueError(f"{name}: covariance is not positive definite") from None
        self.mean, self.cov = mean, cov
        W = np.linalg.inv(L)
        const = -float(np.sum(np.log(np.diag(L)))) - 0.5 * C * LOG_2PI
        self._W = np.tril(W)
        self._const = const
        self._p = np.concatenate([[C, const], mean, self._W.reshape(-1)])

    @property
    def channels(self) -> int:
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
        """``(loglik (N,), chi-square (N,))`` of samples ``x`` (N, C)."""
        d = (np.asarray(x, dtype=np.float64) - self.mean) @ self._W.T
        chi = np.einsum("nc,nc->n", d, d)
        return self._const - 0.5 * chi, chi

    def run(self, state, x, *, t0, starts):
        ll, chi = self.score(x)
        U = len(starts)
        return (np.repeat(ll[:, None], U, axis=1), np.repeat(chi[:, None], U, axis=1))

    def core_spec(self, channels):
        if type(self).run is not GaussianFeature.run:
            return None
        from contactlab.observer.engine import REG_GAUSSIAN

        return {"reg": REG_GAUSSIAN, "channels": channels, "prior": np.zeros(1),
                "params": self._p}

    @classmethod
    def from_segments(cls, segments, *, name: str, signal: str = "phase",
                      ridge: float = RIDGE) -> "GaussianFeature":
        """The mean and covariance of every sample of ``segments`` (a list of (n_i, C))."""
        segs = [np.asarray(s, dtype=np.float64) for s in segments if len(s)]
        if not segs:
            raise ValueError(f"no samples to train Gaussian model {name!r}")
        x = np.concatenate(segs)
        if len(x) < 2:
            raise ValueError(f"Gaussian model {name!r} needs at least 2 labelled samples; "
                             f"got {len(x)}")
        mean = x.mean(axis=0)
        cov = np.atleast_2d(np.cov(x, rowvar=False))
        cov = cov + np.diag(ridge * np.diag(cov) + FLOOR)
        m = cls(name=name, mean=mean, cov=cov, signal=signal)
        m.n_samples_ = len(x)
        m.n_segments_ = len(segs)
        return m


@numba.njit(cache=True)
def gaussian_step(p, x):  # pragma: no cover - compiled
    """Score one sample ``x`` (C channels): ``(log-likelihood, chi-square)``; ``p``: C, the
    constant ``-log det(2 pi Sigma) / 2``, the mean (C) and ``W = L^-1`` row by row (C x C,
    lower triangular)."""
    C = x.shape[0]
    chi = 0.0
    for i in range(C):
        s = 0.0
        for j in range(i + 1):
            s += p[2 + C + i * C + j] * (x[j] - p[2 + j])
        chi += s * s
    return p[1] - 0.5 * chi, chi


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

