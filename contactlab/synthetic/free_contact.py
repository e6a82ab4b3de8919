"""Wrench-and-position recordings of a hand-held tool touching one surface.

What a user's wrist sensor records, generated without the simulator: a tool
of mass ``tool_kg`` held by hand moves through free space, touches down on
one flat surface (a plane of random orientation drawn from ``surface_seed``:
recordings of one setup share it), slides and presses on it, lifts off, and again; ``cycles`` times.

* Free motion: minimum-jerk moves between random waypoints 1-5 cm above the
  surface (0.6-1.2 s each), plus the band-limited (3-12 Hz) tremor of a hand
  holding a tool (``jitter_m`` rms).  The sensor between hand and tool
  measures the force that accelerates the tool: ``-tool_kg * a`` (gravity
  compensated), so free motion is *not* force-free.
* Touch-down: a minimum-jerk descent onto the plane ending at rest on it; an
  impact transient along the normal, a damped 60 Hz oscillation of 1-3 N
  decaying in 10 ms (a stiff contact's ring-down).
* Contact: sliding along the plane (slow sinusoids of 0.5-2 cm in the free
  directions) while pressing with a force varying slowly about ``0.1-1.5 N``
  (light touches included), Coulomb friction ``-mu |g| v/|v|`` (``mu``
  0.1-0.4), tremor in force along the normal (``jitter_n`` rms); the position
  along the normal stays on the plane.
* Lift-off: a minimum-jerk move 2-4 cm away from the plane.

White Gaussian noise of ``position_sd`` and ``force_sd`` is added at ``fs``.
Labels per sample: 1 free before a contact (approach), 2 contact (the impact
included: a user marks contact, not its transient), 3 free after lift-off
(retreat); the map ``1=free,2=contact,3=free`` puts them on the free-contact
graph's nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from contactlab.synthetic.contacts import _jitter

__all__ = ["FreeContactRecording", "free_contact_recording", "LABELS"]

LABELS = {1: "approach", 2: "contact", 3: "retreat"}


@dataclass(frozen=True, eq=False)
class FreeContactRecording:
    """``position`` (n, 3) m, ``force`` (n, 3) N, ``labels`` (n,) codes 1-3 at ``fs``;
    ``normal`` (3,) of the surface; ``contact_starts`` (sample of each touch-down)."""

    position: np.ndarray
    force: np.ndarray
    labels: np.ndarray
    fs: float
    normal: np.ndarray
    contact_starts: np.ndarray

    @property
    def times(self) -> np.ndarray:
        return np.arange(len(self.position)) / self.fs

    def csv_columns(self) -> dict:
        """Columns of a CSV a user would export: t, fx..tz, x, y, z, state."""
        n = len(self.position)
        cols = {"t": self.times}
        for i, c in enumerate(("fx", "fy", "fz")):
            cols[c] = self.force[:, i]
        for c in ("tx", "ty", "tz"):
            cols[c] = np.zeros(n)
        for i, c in enumerate(("x", "y", "z")):
            cols[c] = self.position[:, i]
        cols["state"] = self.labels
        return cols


def _min_jerk(p0, p1, n):
    s = np.linspace(0.0, 1.0, n)[:, None]
    return p0 + (p1 - p0) * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)


def free_contact_recording(*, seed: int, fs: float = 500.0, cycles: int = 6,
                           surface_seed: int = 0,
                           tool_kg: float = 0.2, position_sd: float = 0.05e-3,
                           force_sd: float = 0.02, jitter_m: float = 0.1e-3,
                           jitter_n: float = 0.03, friction=(0.1, 0.4),
                           press=(0.1, 1.5)) -> FreeContactRecording:
    """One recording of ``cycles`` approach-contact-retreat cycles (module notes)."""
    srng = np.random.default_rng(surface_seed)
    R = Rotation.from_euler("xy", srng.uniform(-25, 25, 2), degrees=True).as_matrix()
    N, T = R[:, 2], R[:, :2]
    origin = srng.uniform(-0.05, 0.05, 3)
    rng = np.random.default_rng(seed)

    def above(h):
        return origin + T @ rng.uniform(-0.03, 0.03, 2) + N * h

    pos, frc, lab, starts = [], [], [], []
    p = above(0.03)
    for c in range(cycles):
        # approach: 1-2 free moves above the surface, then the descent
        seg = []
        for _ in range(int(rng.integers(1, 3))):
            q = above(rng.uniform(0.01, 0.05))
            seg.append(_min_jerk(p, q, int(fs * rng.uniform(0.6, 1.2))))
            p = q
        touch = p - N * (N @ (p - origin))
        seg.append(_min_jerk(p, touch, int(fs * rng.uniform(0.4, 0.8))))
        free = np.concatenate(seg)
        pos.append(free)
        frc.append(np.zeros_like(free))
        lab.append(np.full(len(free), 1))
        # contact: slide and press
        n = int(fs * rng.uniform(2.0, 4.0))
        t = np.arange(n) / fs
        s = np.zeros((n, 2))
        for _ in range(2):
            f = rng.uniform(0.2, 0.8, 2)
            ph = rng.uniform(0, 2 * np.pi, 2)
            s += rng.uniform(0.005, 0.02, 2) * (np.sin(2 * np.pi * f * t[:, None] + ph)
                                                - np.sin(ph))
        path = touch + s @ T.T
        g0 = rng.uniform(*press)
        g = g0 * (1 + 0.3 * np.sin(2 * np.pi * rng.uniform(0.2, 0.6) * t)) \
            + _jitter(rng, n, 1, jitter_n, fs)[:, 0]
        g = np.maximum(g, 0.02)
        v = np.gradient(path, 1.0 / fs, axis=0)
        speed = np.linalg.norm(v, axis=1, keepdims=True)
        mu = rng.uniform(*friction)
        force = g[:, None] * N - mu * g[:, None] * v / np.maximum(speed, 1e-9)
        tau, amp = 0.010, rng.uniform(1.0, 3.0)
        ring = amp * np.exp(-t / tau) * np.cos(2 * np.pi * 60.0 * t)
        force += ring[:, None] * N
        starts.append(sum(len(a) for a in pos))
        pos.append(path)
        frc.append(force)
        lab.append(np.full(n, 2))
        p = path[-1]
        # retreat
        q = p + N * rng.uniform(0.02, 0.04) + T @ rng.uniform(-0.01, 0.01, 2)
        back = _min_jerk(p, q, int(fs * rng.uniform(0.4, 0.8)))
        pos.append(back)
        frc.append(np.zeros_like(back))
        lab.append(np.full(len(back), 3))
        p = q
    position = np.concatenate(pos)
    force = np.concatenate(frc)
    labels = np.concatenate(lab).astype(np.int64)
    free = labels != 2
    # tremor in every free-space direction, faded out over 50 ms at the contacts; the
    # tool's inertia on the sensor
    w = max(int(0.05 * fs), 1)
    taper = np.convolve(free.astype(float), np.hanning(2 * w + 1) / np.hanning(2 * w + 1).sum(),
                        mode="same") * free
    position += taper[:, None] * _jitter(rng, len(position), 3, jitter_m, fs)
    acc = np.gradient(np.gradient(position, 1.0 / fs, axis=0), 1.0 / fs, axis=0)
    force[free] += -tool_kg * acc[free]
    position = position + rng.normal(0, position_sd, position.shape)
    force = force + rng.normal(0, force_sd, force.shape)
    return FreeContactRecording(position, force, labels, float(fs), N, np.asarray(starts))
