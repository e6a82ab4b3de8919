"""Point contacts with known constraint frames (free, plane, edge, corner).

A point (the fingertip) touches ``m`` = 0..3 mutually orthogonal rigid
surfaces whose normals ``N`` (3, m) are the first ``m`` columns of a random
rotation; it moves only in the free directions ``T`` (the other columns) and
pushes only along the normals (8.1.1, the constraint form): position
``p(t) = p0 + T s(t)`` with ``s`` a sum of slow sinusoids (a few mm at
0.3-1.5 Hz in each free direction), force ``f(t) = N g(t) + f_friction``
with a pressing force ``g`` of 0.5-2 N per normal varying slowly, and Coulomb
friction ``-mu |g| v / |v|`` opposing the motion (``mu`` 0.1-0.4).  On top,
the jitter of a hand holding the tool: band-limited (3-12 Hz, the band of
physiological tremor) random motion of ``jitter_m`` rms in every free
direction and random force of ``jitter_n`` rms along every normal, so that
even 0.1-s blocks move or push in every direction they can.  Free
space (``m = 0``) has motion in all directions and no force; a corner
(``m = 3``) has no motion and force in all directions.  White Gaussian
noise of ``position_sd`` (m) and ``force_sd`` (N) per axis is added at
``fs`` -- the measurement noise a user's instruments would have, not known to
the estimator.

Disturbances a real contact has (all off by default):

- ``stiffness`` (N/m): a compliant contact.  The fingertip sinks into each surface
  by ``g / stiffness`` along its normal, so the penetration varies with the
  pressing force (``press_n`` sets its range; e.g. 0.2-2 N on 2000 N/m is
  0.1-1 mm).
- ``drift_deg``: the constraint frame turns by this total angle over the run,
  at a constant rate about a random axis (a workpiece shifting in a vice, a
  sensor mount creeping).  The truth is then per sample
  (``normals_at``, the archive's ``contact_normals``).
- ``friction``: Coulomb friction along the motion (as above).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["ContactTrial", "contact_trial", "contact_trials", "DEGREE_NAMES"]

DEGREE_NAMES = ("free", "plane", "edge", "corner")


@dataclass(frozen=True, eq=False)
class ContactTrial:
    """One run: ``position``, ``force`` (N, 3) at ``fs``; the true ``normals`` (3, m)."""

    position: np.ndarray
    force: np.ndarray
    fs: float
    degree: int
    normals: np.ndarray
    friction: float
    position_sd: float
    force_sd: float
    seed: int = -1
    frames: np.ndarray | None = None       # (N, 3, 3) per-sample frame [N, T] when drifting

    def normals_at(self, i) -> np.ndarray:
        """True normals (..., 3, m) at sample(s) ``i``."""
        if self.frames is None:
            return np.broadcast_to(self.normals, np.shape(i) + self.normals.shape)
        return self.frames[i][..., :self.degree]

    @property
    def times(self) -> np.ndarray:
        return np.arange(len(self.position)) / self.fs

    def archive_fields(self) -> dict:
        """Measurements (wrench with zero torques, position) and truth: one label, the
        contact flags and normals of three surfaces (the first ``degree`` touched)."""
        n = len(self.position)
        wrench = np.concatenate([self.force, np.zeros((n, 3))], axis=1)
        normals = np.zeros((n, 3, 3))               # (sample, surface, xyz)
        normals[:, :self.degree] = np.swapaxes(self.normals_at(np.arange(n)), 1, 2)
        contact = np.zeros((n, 3), bool)
        contact[:, :self.degree] = True
        return dict(rate_hz=self.fs, time=self.times,
                    measurements={"wrench": wrench, "position": self.position},
                    labels=np.full(n, self.degree, np.int64), names=list(DEGREE_NAMES),
                    environment=f"synthetic point contact: {DEGREE_NAMES[self.degree]}",
                    description=f"mu {self.friction:.2f}, noise {self.position_sd * 1e3:g} mm "
                                f"/ {self.force_sd * 1e3:g} mN",
                    truth=dict(contact=contact, surfaces=["s1", "s2", "s3"],
                               contact_normals=normals))


def _slow(rng, t, k, amp, freq=(0.3, 1.5)):
    """(N, k) sums of three sinusoids per column, amplitude ~``amp``."""
    out = np.zeros((len(t), k))
    for _ in range(3):
        f = rng.uniform(*freq, k)
        ph = rng.uniform(0, 2 * np.pi, k)
        a = amp * rng.uniform(0.5, 1.0, k)
        out += a * np.sin(2 * np.pi * f * t[:, None] + ph)
    return out


def _jitter(rng, n, k, rms, fs):
    """(n, k) band-limited (3-12 Hz) Gaussian noise of the given rms per column."""
    from scipy.signal import butter, sosfiltfilt
    if k == 0 or rms == 0:
        return np.zeros((n, k))
    sos = butter(2, (3.0, 12.0), btype="band", fs=fs, output="sos")
    x = sosfiltfilt(sos, rng.standard_normal((n + 2000, k)), axis=0)[1000:1000 + n]
    return rms * x / x.std(axis=0)


def contact_trial(*, seed: int, degree: int, duration_s: float = 2.0, fs: float = 1000.0,
                  position_sd: float = 0.1e-3, force_sd: float = 0.02,
                  amplitude_m: float = 4e-3, jitter_m: float = 0.2e-3,
                  jitter_n: float = 0.05, friction=(0.1, 0.4), stiffness: float | None = None,
                  press_n=(0.5, 2.0), drift_deg: float = 0.0) -> ContactTrial:
    """One run of the given ``degree`` (0 free, 1 plane, 2 edge, 3 corner); the
    disturbances ``stiffness``, ``press_n`` and ``drift_deg`` as in the module notes."""
    if degree not in (0, 1, 2, 3):
        raise ValueError(f"degree must be 0..3; got {degree!r}")
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration_s * fs))) / fs
    frame = Rotation.random(random_state=rng).as_matrix()
    N, T = frame[:, :degree], frame[:, degree:]
    p0 = rng.uniform(-0.05, 0.05, 3)
    s = _slow(rng, t, 3 - degree, amplitude_m) + _jitter(rng, len(t), 3 - degree, jitter_m, fs)
    lo, hi = press_n
    g = (rng.uniform(lo, hi, degree) + _slow(rng, t, degree, 0.2 * (hi - lo) / 1.5)
         + _jitter(rng, len(t), degree, jitter_n, fs))
    if stiffness and degree:                 # a compliant contact cannot pull
        g = np.clip(g, 0.5 * lo, None)
    frames = None
    if drift_deg:
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        turn = Rotation.from_rotvec(np.radians(drift_deg) * (t / t[-1] - 0.5)[:, None] * axis)
        frames = turn.as_matrix() @ frame
        Nt, Tt = frames[:, :, :degree], frames[:, :, degree:]
        position = slide = p0 + np.einsum("nij,nj->ni", Tt, s)
        force = np.einsum("nij,nj->ni", Nt, g)
        if stiffness and degree:
            position = position - np.einsum("nij,nj->ni", Nt, g) / stiffness
    else:
        position = slide = p0 + s @ T.T
        force = g @ N.T
        if stiffness and degree:
            position = position - (g / stiffness) @ N.T
    mu = float(rng.uniform(*friction))
    if 0 < degree < 3:
        v = np.gradient(slide, 1.0 / fs, axis=0)      # friction opposes the sliding
        speed = np.linalg.norm(v, axis=1, keepdims=True)
        force = force - mu * np.linalg.norm(g, axis=1, keepdims=True) * v / np.maximum(
            speed, 1e-9)
    position = position + rng.normal(0, position_sd, position.shape)
    force = force + rng.normal(0, force_sd, force.shape)
    return ContactTrial(position=position, force=force, fs=fs, degree=degree, normals=N,
                        friction=mu, position_sd=position_sd, force_sd=force_sd, seed=int(seed),
                        frames=frames)


def contact_trials(n_per_degree: int = 10, *, seed: int = 0, **kwargs) -> list[ContactTrial]:
    """``n_per_degree`` runs of each degree 0..3 (free, plane, edge, corner), interleaved."""
    out = []
    for i in range(n_per_degree):
        for d in range(4):
            s = int(np.random.SeedSequence([seed, i, d]).generate_state(1)[0])
            out.append(contact_trial(seed=s, degree=d, **kwargs))
    return out
