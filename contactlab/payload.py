"""The tool's weight and the sensor's offset in a wrist force sensor's free-space force.

A wrist sensor measures, in free space, the weight ``w`` of what it carries (a constant
vector in the base frame) and its own offset ``o`` (a constant vector in the sensor's
axes).  Rotated into the base frame (:mod:`contactlab.signals` does so for the contact
signals), the free-space force is

    f_b(t) = w + R(t) o,                                                        (1)

``R(t)`` the tool's orientation.  While the tool does not turn, (1) is a constant and a
trained free-space model allows for it; when it turns, the force drifts although nothing
touches the tool.  On the HIRO recordings of ``../shared/data/real``, the failed
assemblies recorded four years after the others turn the tool 18 deg during the approach
with a 4.4 N payload: the base-frame free force drifts by 0.9-1.3 N, more than 10 times
the free-space noise of the trials trained on, and the bundled free-contact graph read the
approach as contact from its middle on.  (1) with ``w`` and ``o`` fitted on the same
approach leaves 0.03-0.17 N.

:func:`fit_payload` fits (1) by least squares over a mask of free-space samples, with a
Gaussian prior on ``w`` and ``o`` (:data:`PRIOR_SD_N` each) that keeps them bounded when
the tool turns too little to tell them apart (then only ``w + R o`` is determined, and
the fit is a constant).  The samples' residuals are correlated over about
:data:`CORRELATION_S` (the payload's swing, the arm's vibration), so each sample counts
as ``1 / (CORRELATION_S * fs)`` of an independent one with sd :data:`RESIDUAL_SD_N`.
:meth:`Payload.correction` is (1) at each sample's orientation: subtracting it leaves
the contact force alone, zero in free space, as a free-space constraint model expects
(8.15: the force is zero-mean in the free directions) -- a tare that follows the tool's
turn.  Training reads its trials as recorded (their sensors zeroed in free space, as
wrist sensors are).

Beyond the thesis, whose fingertip sensor carried no payload.  Recognition
(:func:`contactlab.observer.recognize.recognize_trial`) takes the free-space samples from
a first pass of the observer, fits, and recognises again on the corrected force.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Payload", "fit_payload", "free_mask", "sensor_force", "RESIDUAL_SD_N",
           "CORRELATION_S", "PRIOR_SD_N", "MIN_FREE_S", "MARGIN_S"]

#: sd (N) of a wrist sensor's free-space force about (1): 0.03-0.17 N per axis on the HIRO
#: recordings, 0.9-1.7 N on the wiping demonstration's hand-held tool (a wrist sensor's
#: scale; it weighs the data against the prior only)
RESIDUAL_SD_N = 0.1
#: correlation time (s) of those residuals: the payload's swing and the arm's vibration
#: are a few Hz
CORRELATION_S = 0.1
#: prior sd (N) of the payload's weight and of the sensor's offset, each axis: a tool of
#: up to a kilogram and a sensor not zeroed since it was mounted
PRIOR_SD_N = 5.0
#: free space needed to fit (s): less is left uncorrected
MIN_FREE_S = 0.5
#: free-space samples this close (s) to a change of the first pass are left out of the
#: fit: the change time is an estimate, and a release rings
MARGIN_S = 0.1


@dataclass(frozen=True)
class Payload:
    """A fit of (1): ``weight_n`` (base frame), ``offset_n`` (sensor axes), their
    posterior standard deviations per axis (``weight_sd_n``, ``offset_sd_n``: large where
    the tool turned too little to tell them apart; their sum at the fitted orientations
    is then still known), ``free_s`` (seconds fitted) and ``turn_deg`` (the largest angle
    of a fitted orientation from the first fitted one: how far the tool turned while
    the fit watched)."""

    weight_n: np.ndarray
    offset_n: np.ndarray
    weight_sd_n: np.ndarray
    offset_sd_n: np.ndarray
    free_s: float
    turn_deg: float

    def correction(self, q: np.ndarray) -> np.ndarray:
        """(n, 3) base-frame force to subtract at orientations ``q`` (n, 4; w x y z, tool
        to base): ``w + R(q) o``."""
        from contactlab.archive.importer import rotate_vectors

        q = np.asarray(q, np.float64)
        o = np.broadcast_to(self.offset_n, (len(q), 3))
        return self.weight_n + rotate_vectors(q, o)

    def to_dict(self) -> dict:
        """The fit with each vector's frame in its key."""
        return {"weight_base_n": [float(v) for v in self.weight_n],
                "weight_sd_n": [float(v) for v in self.weight_sd_n],
                "offset_sensor_n": [float(v) for v in self.offset_n],
                "offset_sd_n": [float(v) for v in self.offset_sd_n],
                "free_s": float(self.free_s), "turn_deg": float(self.turn_deg)}

    @classmethod
    def from_dict(cls, d: dict) -> "Payload":
        """The fit back from :meth:`to_dict`."""
        return cls(*(np.asarray(d[k], np.float64) for k in ("weight_base_n", "offset_sensor_n",
                                                            "weight_sd_n", "offset_sd_n")),
                   float(d["free_s"]), float(d["turn_deg"]))

    def text(self) -> str:
        """One line: the base-frame force and the sensor offset with each one's largest
        per-axis sd, the free space and the turn; where the turn was too small to tell
        them apart (an sd above half the vector's size), only their sum is known."""
        def vec(v, sd):
            return "[" + ", ".join(f"{a:.2f}" for a in v) + f"] N (max sd {np.max(sd):.2f})"
        line = (f"payload: constant base-frame force {vec(self.weight_n, self.weight_sd_n)}, "
                f"sensor offset {vec(self.offset_n, self.offset_sd_n)} in its axes; fitted on "
                f"{self.free_s:.1f} s of free space while the tool turned "
                f"{self.turn_deg:.0f} deg")
        if np.max(self.weight_sd_n) > 0.5 * np.linalg.norm(self.weight_n):
            line += " (too little to tell them apart: only their sum, the tare, is known)"
        return line


def fit_payload(q: np.ndarray, force: np.ndarray, mask: np.ndarray, *, fs: float
                ) -> Payload | None:
    """(1) fitted to the sensor-frame ``force`` (n, 3) at orientations ``q`` (n, 4) over
    the samples where ``mask`` is true (module notes); None when they span less than
    :data:`MIN_FREE_S`.

    The normal equations are formed directly: with ``A_t = [I, R_t]``,
    ``sum A_t^T A_t = [[n I, S], [S^T, n I]]`` (``R_t^T R_t = I``), ``S = sum R_t``, and
    ``sum A_t^T f_t = [sum f_t; sum R_t^T f_t]`` with ``f_t = R_t force_t``, so
    ``R_t^T f_t`` is the sensor-frame force itself.
    """
    from contactlab.archive.importer import quaternion_matrices, rotate_vectors

    mask = np.asarray(mask, bool)
    n = int(mask.sum())
    if n < MIN_FREE_S * fs:
        return None
    qf = np.asarray(q, np.float64)[mask]
    fsens = np.asarray(force, np.float64)[mask]
    R = quaternion_matrices(qf)
    fb = rotate_vectors(qf, fsens)
    S = R.sum(axis=0)
    AtA = np.block([[n * np.eye(3), S], [S.T, n * np.eye(3)]])
    Atb = np.concatenate([fb.sum(axis=0), fsens.sum(axis=0)])
    lam = 1.0 / (RESIDUAL_SD_N ** 2 * max(CORRELATION_S * fs, 1.0))
    H = lam * AtA + np.eye(6) / PRIOR_SD_N ** 2        # the posterior precision
    theta = np.linalg.solve(H, lam * Atb)
    w, o = theta[:3], theta[3:]
    sd = np.sqrt(np.diag(np.linalg.inv(H)))
    # the turn the fit saw: the largest angle from the first fitted orientation
    dots = np.abs(qf @ qf[0])
    turn = float(np.degrees(2.0 * np.arccos(np.clip(dots.min(), -1.0, 1.0))))
    return Payload(w, o, sd[:3], sd[3:], n / float(fs), turn)


def sensor_force(trial, q: np.ndarray) -> np.ndarray:
    """The trial's force (n, 3) in the sensor's axes: the wrench as measured, or, for a
    wrench imported in the base frame, rotated back by the orientations ``q`` (n, 4)."""
    from contactlab.archive.importer import rotate_vectors

    f = np.asarray(trial.wrench, np.float64)[: len(q), :3]
    if getattr(trial, "wrench_frame", "sensor") == "base":
        conj = np.asarray(q, np.float64)[: len(f)] * np.array([1.0, -1.0, -1.0, -1.0])
        return rotate_vectors(conj, f)
    return f


def free_mask(path, index: np.ndarray, free_nodes, n_raw: int, *, fs_raw: float
              ) -> np.ndarray:
    """(n_raw,) mask of the raw samples inside a MAP path's segments at ``free_nodes``,
    each shrunk by :data:`MARGIN_S` at both ends.  ``path``: ``[(node, start point),
    ...]`` over the conditioned points whose newest raw sample is ``index``."""
    index = np.asarray(index, np.int64)
    mask = np.zeros(int(n_raw), bool)
    if not len(index):
        return mask
    margin = int(round(MARGIN_S * fs_raw))
    starts = [int(s) for _, s in path] + [len(index)]
    for (node, s), e in zip(path, starts[1:]):
        if node not in free_nodes or e <= max(s, 0):
            continue
        a = int(index[max(s, 0)]) + margin
        b = int(index[e - 1]) + 1 - margin
        if b > a:
            mask[a:b] = True
    return mask
