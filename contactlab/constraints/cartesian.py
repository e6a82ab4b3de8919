"""Cartesian constraint estimation in R^k (thesis 8.1.1).

One module on purpose: the stiffness and constraint forms
of 8.1.1 share the block statistics, the reciprocity-preserving scaling and the
Newton/Powell optimisation over rotations; each form is a class over those helpers.

Two estimators over blocks of motion (position or velocity) and force
measurements, both in units normalised by measurement accuracy with the
reciprocity-preserving scaling of 8.7-8.9 (:mod:`.scaling`):

- :class:`CartesianStiffness` -- the stiffness form (8.12-8.20): the joint
  projection P (2k x k) is the k eigenvectors of the smallest eigenvalues of the
  joint covariance ``I`` (8.19); ``V = P^T I P`` (8.20); log-likelihood 8.18.
- :class:`CartesianConstraint` -- the constraint form (8.21-8.28): P is built
  from one orthonormal frame ``[N, T]`` (normals, free directions) so the two
  bases are reciprocal.  Criteria: the log-likelihood (log-det, 8.22-8.24),
  minimised by batched Newton over the frame (default) or by the thesis's
  Powell search over three Euler angles from the Gram-Schmidt start (8.28);
  or the trace criterion (8.25-8.27), by the thesis's Newton iteration on
  8.27 or in closed form (:mod:`.frames`).  ``degree=None`` decides the
  degree of constraint by the highest log-likelihood over 0..k (8.2).

Both return a fit object (normals, free basis, their uncertainty, per-sample
residuals, innovation covariance, log-likelihood) usable as a feature model.

Choices where the thesis is silent or ambiguous (also in the report):

- Centring (8.19).  Motion positions are centred on their mean; forces are not
  ("for a calibrated and zeroed force ... sensor the mean can be assumed to be
  zero"), so a steady contact force counts as evidence of its constraint.
  Velocities are not centred.  The stiffness form centres both (8.12 has an
  unknown zero point).  ``center=`` overrides.
- Noise floor.  ``V = P^T I P + noise_floor Id``: in normalised units the
  measurement noise variance is 1, and a residual cannot be known better than
  the instruments measure it.  Without the floor, quantised positions that
  never change along a normal make ``det V = 0`` (log-likelihood +inf) for
  every class containing that normal.  ``noise_floor=0`` is the literal
  thesis criterion.
- Determinacy.  A fit is ``undetermined`` (normals and free basis NaN, degree
  None) when its log-likelihood is not finite, when the observed information
  of the frame is singular or the frame's angular standard error exceeds
  ``max_tilt_sd_deg``, and -- for a degree decision -- when the exploration
  diagnostic (:mod:`.exploration`) finds a direction with neither motion nor
  force; a fit of a given degree needs at least one direction moved or pushed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from contactlab.constraints import frames as F
from contactlab.constraints.exploration import DEFAULT_THRESHOLD, exploration
from contactlab.constraints.friction import friction_filter
from contactlab.constraints.scaling import Scaling, canonical_signs, reciprocal_scaling
from contactlab.errors import DataError, UsageError

__all__ = ["POSITION_SD", "FORCE_SD", "VELOCITY_SD", "CartesianConstraint",
           "CartesianStiffness", "ConstraintFit", "StiffnessFit", "BlockFits",
           "min_samples"]

POSITION_SD = 0.03e-3 / math.sqrt(12.0)
"""m: the PHANToM encoder's 0.03 mm step (contactlab.sim.constants.ENCODER_RESOLUTION)
as a uniform quantisation error, step / sqrt(12)."""
FORCE_SD = 0.01
"""N: the simulated fingertip sensor's force noise, 9.6-13.5 mN per axis before
lowpassing (contactlab.sim.sensor.StrainGaugeSensor.wrench_noise_std)."""
VELOCITY_SD = 0.001
"""m/s: not in the thesis (chosen): the encoder step differenced and lowpassed
(contactlab.sim.sensor.Encoders) leaves velocity noise of order 1 mm/s."""

MOTIONS = ("position", "velocity")
CRITERIA = ("logdet", "trace")
STARTS = ("trace", "ratio", "gram-schmidt", "both", "trace+ratio")


def min_samples(k: int = 3) -> int:
    """Fewest samples a block needs: the joint dimension 2k plus one for the mean."""
    return 2 * k + 1


# -- inputs ------------------------------------------------------------------------------------

def _as_blocks(a, name: str, k: int | None = None) -> np.ndarray:
    if a is None:
        return None
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or (k is not None and arr.shape[2] != k):
        want = "(n, k)" if k is None else f"(n, {k})"
        raise UsageError(f"{name} must be {want} or (blocks, n, k); got shape {np.shape(a)}")
    if not np.all(np.isfinite(arr)):
        raise DataError("NaN or infinite values", field=name)
    return arr


def _prepare(est, position, force, velocity):
    """Scaled joint samples y (B, n, 2k), the scaling, and the motion accuracy."""
    pos = _as_blocks(position, "position")
    k = pos.shape[2]
    frc = _as_blocks(force, "force", k)
    vel = _as_blocks(velocity, "velocity", k)
    if frc.shape != pos.shape or (vel is not None and vel.shape != pos.shape):
        raise UsageError(f"position, force (and velocity) must have the same shape; got "
                         f"{pos.shape}, {frc.shape}"
                         + ("" if vel is None else f", {vel.shape}"))
    n = pos.shape[1]
    if n < min_samples(k):
        raise DataError(f"{n} samples; the {2 * k}-dimensional joint covariance needs at "
                        f"least {min_samples(k)}", field="position")
    if est.motion == "velocity":
        if vel is None:
            raise UsageError("motion='velocity' needs velocity measurements")
        motion, motion_sd = vel, est.velocity_sd
    else:
        motion, motion_sd = pos, est.position_sd
    if est.friction:
        if vel is not None:
            v, v_sd = vel, est.velocity_sd
        else:
            v, v_sd = _smooth_velocity(pos, est.position_sd)
        frc = friction_filter(frc, v, min_speed=3.0 * float(np.max(v_sd)))
    scaling = reciprocal_scaling(motion_sd, est.force_sd, k)
    center_motion, center_force = est._centering()
    x = motion - motion.mean(axis=1, keepdims=True) if center_motion else motion
    w = frc - frc.mean(axis=1, keepdims=True) if center_force else frc
    y = np.concatenate([x * scaling.beta, w * scaling.alpha], axis=2)
    return y, scaling


def _smooth_velocity(pos: np.ndarray, position_sd) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample velocity (per sample step) of positions (B, n, k) for the friction
    filter, and its noise standard deviation.

    The filter needs the *direction* of sliding (8.29).  A central difference
    of noisy positions has noise ``sd / sqrt(2)`` per step, which at 0.1 mm of
    position noise and 0.1 mm per step of sliding turns the direction by tens
    of degrees and leaks friction into the free directions as spurious
    constraint force.  A local quadratic (Savitzky-Golay, up to 11 samples,
    44 ms at 250 Hz) cuts that noise by ~8 for an 11-sample window while
    following the slow curvature of a sliding motion.
    """
    from scipy.signal import savgol_filter

    n = pos.shape[1]
    window = min(11, n if n % 2 else n - 1)
    if window < 5:
        return np.gradient(pos, axis=1), np.asarray(position_sd) / math.sqrt(2.0)
    v = savgol_filter(pos, window, 2, deriv=1, axis=1, mode="interp")
    half = (window - 1) // 2
    gain = math.sqrt(3.0 / (half * (half + 1) * (2 * half + 1)))   # sd of the LS slope
    return v, np.asarray(position_sd) * gain


def _information(y: np.ndarray) -> np.ndarray:
    """Joint information (8.19) of scaled samples y (B, n, 2k): ``y^T y / n``."""
    return np.swapaxes(y, 1, 2) @ y / y.shape[1]


def _check_common(est) -> None:
    if est.motion not in MOTIONS:
        raise UsageError(f"motion must be one of {', '.join(MOTIONS)}; got {est.motion!r}")
    if not (np.isfinite(est.noise_floor) and est.noise_floor >= 0):
        raise UsageError(f"noise_floor must be >= 0; got {est.noise_floor!r}")
    if est.center not in (None, "motion", "both", "none"):
        raise UsageError(f"center must be None, 'motion', 'both' or 'none'; got {est.center!r}")
    if not (est.max_tilt_sd_deg > 0):
        raise UsageError(f"max_tilt_sd_deg must be > 0; got {est.max_tilt_sd_deg!r}")


def _nan_like(a: np.ndarray) -> np.ndarray:
    return np.full(a.shape, np.nan)


# -- results -----------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class ConstraintFit:
    """A fitted Cartesian constraint (trailing-underscore attributes, sklearn-like).

    Attributes
    ----------
    degree_ : number of constraints m (None when undetermined).
    normals_ : (k, m) unit normals of the constrained directions, physical frame
        (NaN when undetermined).
    free_ : (k, k-m) unit free directions (NaN when undetermined).
    P_ : (2k, k) joint projection (8.21), normalised units.
    V_ : (k, k) innovation covariance (8.17/8.20 plus the noise floor).
    residuals_ : (n, k) per-sample residuals ``nu_t = P^T y~_t`` (8.14),
        normalised units: motion along the normals, then force along the free
        directions.
    loglik_ : log-likelihood 8.18, ``-n/2 (log det V + k)``.
    log_likelihoods_ : (k+1,) 8.18 of the best frame of each degree 0..k
        (NaN for degrees not fitted).
    cov_ : (d, d) covariance (rad^2) of the m(k-m) small rotations tilting each
        normal toward each free direction (order: normal-major), from the
        observed information ``n/2 * Hessian`` of ``log det V``; normalised units.
    angle_sd_deg_ : the largest standard error of those tilts (deg).
    information_ : (2k, 2k) joint information I (8.19), normalised units.
    explored_ : whether every direction had motion or force (exploration).
    unexplored_ : (k, u) directions lacking information (normalised units).
    status_ : "ok" or "undetermined"; ``reason_`` says why.
    n_ : number of samples; ``iterations_``: solver iterations.
    scaling : the :class:`~contactlab.constraints.scaling.Scaling` used.
    """

    degree_: int | None
    normals_: np.ndarray
    free_: np.ndarray
    P_: np.ndarray
    V_: np.ndarray
    residuals_: np.ndarray
    loglik_: float
    log_likelihoods_: np.ndarray
    cov_: np.ndarray
    angle_sd_deg_: float
    information_: np.ndarray
    explored_: bool
    unexplored_: np.ndarray
    status_: str
    reason_: str
    n_: int
    iterations_: int
    scaling: Scaling
    noise_floor: float = 1.0
    parameters: dict = field(default_factory=dict)

    @property
    def determined_(self) -> bool:
        return self.status_ == "ok"

    def loglik_at(self, normals) -> float:
        """8.18 of this block's data under the frame with the given physical unit
        normals (k, m) -- the feature model's likelihood of a hypothesised frame."""
        N = np.asarray(normals, dtype=np.float64)
        k = self.information_.shape[0] // 2
        if N.ndim != 2 or N.shape[0] != k:
            raise UsageError(f"normals must be (k={k}, m); got {N.shape}")
        R = _frame_from_normals(self.scaling.normals_to_scaled(N), k)
        f = F.logdet_value(self.information_[None], R[None], N.shape[1], self.noise_floor)[0]
        return float(-self.n_ / 2.0 * (f + k))

    def as_dict(self) -> dict:
        """JSON-ready summary."""
        return {"degree": self.degree_, "status": self.status_, "reason": self.reason_,
                "normals": self.normals_.T.tolist(), "free": self.free_.T.tolist(),
                "loglik": self.loglik_, "log_likelihoods": self.log_likelihoods_.tolist(),
                "angle_sd_deg": self.angle_sd_deg_, "explored": bool(self.explored_),
                "n": self.n_}


@dataclass(frozen=True, eq=False)
class StiffnessFit:
    """A fitted stiffness-form relation (8.12-8.20).

    Attributes
    ----------
    P_ : (2k, k) eigenvectors of the k smallest eigenvalues of I (normalised units).
    eigenvalues_ : (2k,) eigenvalues of I, ascending.
    V_ : (k, k) ``P^T I P`` (diagonal) plus the noise floor.
    loglik_ : 8.18.
    alignment_ : (2,) sums of the singular values of the motion and force
        blocks of P (the 8.2 alignment statistic).
    degree_ : m -- given, or ``round(||P_motion||_F^2)`` (how many of the k
        directions of P lie in motion space); None when undetermined.
    normals_ / free_ : (k, m) / (k, k-m) the leading left singular vectors of
        the motion / force block of P, physical frame (NaN when undetermined).
    eigvec_var_ : (k, k) asymptotic variance (rad^2) of the rotation of
        selected eigenvector i toward rejected eigenvector j,
        ``l_i l_j / (n (l_i - l_j)^2)`` (Anderson 1984, the thesis's reference).
    angle_sd_deg_, residuals_, information_, status_, reason_, n_, scaling : as
        in :class:`ConstraintFit`.
    """

    P_: np.ndarray
    eigenvalues_: np.ndarray
    V_: np.ndarray
    loglik_: float
    alignment_: np.ndarray
    degree_: int | None
    normals_: np.ndarray
    free_: np.ndarray
    eigvec_var_: np.ndarray
    angle_sd_deg_: float
    residuals_: np.ndarray
    information_: np.ndarray
    status_: str
    reason_: str
    n_: int
    scaling: Scaling

    @property
    def determined_(self) -> bool:
        return self.status_ == "ok"

    def as_dict(self) -> dict:
        return {"degree": self.degree_, "status": self.status_, "reason": self.reason_,
                "normals": self.normals_.T.tolist(), "free": self.free_.T.tolist(),
                "loglik": self.loglik_, "alignment": self.alignment_.tolist(),
                "angle_sd_deg": self.angle_sd_deg_, "n": self.n_}


@dataclass(frozen=True, eq=False)
class BlockFits:
    """Constraint-form fits of many blocks at once (:meth:`CartesianConstraint.estimate_blocks`).

    Attributes
    ----------
    degree : (B,) decided or requested degree; -1 where undetermined.
    log_likelihoods : (B, k+1) 8.18 of the best frame of each degree (NaN if not fitted).
    frames : (B, k+1, k, k) best frame ``[N, T]`` of each degree, normalised units.
    explored : (B,) exploration diagnostic.
    information : (B, 2k, 2k) joint information, normalised units.
    n : samples per block (an int, or (B,) counts).  scaling : the scaling used.
    """

    degree: np.ndarray
    log_likelihoods: np.ndarray
    frames: np.ndarray
    explored: np.ndarray
    information: np.ndarray
    n: int | np.ndarray
    scaling: Scaling

    def __len__(self) -> int:
        return int(self.degree.size)

    def normals(self, b: int, degree: int | None = None) -> np.ndarray:
        """Physical unit normals (k, m) of block ``b`` for ``degree`` (default: its
        decided degree; NaN when undetermined)."""
        m = int(self.degree[b]) if degree is None else int(degree)
        k = self.frames.shape[-1]
        if m < 0:
            return np.full((k, 0), np.nan)
        return self.scaling.normals_to_physical(self.frames[b, m][:, :m])

    def projections(self, degree: int | None = None) -> np.ndarray:
        """Joint projections P (B, 2k, k), normalised units, of the decided degree
        (or of ``degree``); NaN where undetermined."""
        B, _, k, _ = self.frames.shape
        out = np.full((B, 2 * k, k), np.nan)
        for m in range(k + 1):
            sel = (self.degree == m) if degree is None else np.full(B, m == degree)
            if sel.any():
                out[sel] = F.embed(self.frames[sel, m], m)
        return out


def _frame_from_normals(N: np.ndarray, k: int) -> np.ndarray:
    """The frame ``[N, T]`` (k, k) with T an orthonormal complement of the normals N."""
    m = N.shape[1]
    q, _ = np.linalg.qr(np.concatenate([N, np.eye(k)], axis=1))
    return np.concatenate([N, q[:, m:k]], axis=1)


# -- the constraint form -----------------------------------------------------------------------

class CartesianConstraint:
    """Constraint-form estimator of linear constraints in R^k (8.21-8.28).

    Parameters
    ----------
    degree : number of constraints m in 0..k, or None to decide it by the
        highest log-likelihood over 0..k (8.2).
    criterion : "logdet" (the log-likelihood, 8.22) or "trace" (8.25).
    solver : for "logdet": "newton" (batched, default) or "powell" (the
        thesis: Powell over Euler angles from the Gram-Schmidt start, 8.28);
        for "trace": "newton" (the thesis's iteration on 8.27) or "eigh"
        (closed form).
    start : log-det Newton start: "trace" (the trace criterion's closed-form
        minimiser), "ratio" (generalised eigenvectors of Ixx against Iww,
        :func:`.frames.ratio_start`), "gram-schmidt" (8.28), "both" (trace and
        Gram-Schmidt) or "trace+ratio" (the default); with two starts the frame
        with the higher log-likelihood is kept.
    motion : "position" (default; the thesis's preferred, less noisy) or "velocity".
    position_sd, force_sd, velocity_sd : measurement accuracies (scalar or per
        axis) used to normalise units (8.7-8.9).
    friction : apply the friction compensation filter 8.29 first.
    noise_floor : variance added to V in normalised units (module notes).
    center : override the centring: "motion", "both" or "none" (module notes).
    exploration_threshold : see :mod:`.exploration`.
    max_tilt_sd_deg : a frame with a larger angular standard error is undetermined.
    uncertainty : "hac" (default) or "iid": how the frame's standard error counts
        correlated samples (:meth:`_uncertainty`).

    Examples
    --------
    >>> fit = CartesianConstraint().estimate(position, force)   # (n, 3) each, SI units
    >>> fit.degree_, fit.normals_, fit.angle_sd_deg_, fit.loglik_
    """

    def __init__(self, *, degree: int | None = None, criterion: str = "logdet",
                 solver: str = "newton", start: str = "trace+ratio", motion: str = "position",
                 position_sd=POSITION_SD, force_sd=FORCE_SD, velocity_sd=VELOCITY_SD,
                 friction: bool = False, noise_floor: float = 1.0, center: str | None = None,
                 exploration_threshold: float = DEFAULT_THRESHOLD,
                 max_tilt_sd_deg: float = 30.0, uncertainty: str = "hac"):
        self.degree = degree
        self.uncertainty = uncertainty
        self.criterion = criterion
        self.solver = solver
        self.start = start
        self.motion = motion
        self.position_sd = position_sd
        self.force_sd = force_sd
        self.velocity_sd = velocity_sd
        self.friction = friction
        self.noise_floor = float(noise_floor)
        self.center = center
        self.exploration_threshold = float(exploration_threshold)
        self.max_tilt_sd_deg = float(max_tilt_sd_deg)

    def _centering(self) -> tuple[bool, bool]:
        c = self.center or ("motion" if self.motion == "position" else "none")
        return c in ("motion", "both"), c == "both"

    def _check(self, k: int) -> list[int]:
        _check_common(self)
        if self.uncertainty not in ("hac", "iid"):
            raise UsageError(f"uncertainty must be 'hac' or 'iid'; got {self.uncertainty!r}")
        if self.criterion not in CRITERIA:
            raise UsageError(f"criterion must be one of {', '.join(CRITERIA)}; "
                             f"got {self.criterion!r}")
        solvers = ("newton", "powell") if self.criterion == "logdet" else ("newton", "eigh")
        if self.solver not in solvers:
            raise UsageError(f"solver for the {self.criterion} criterion must be one of "
                             f"{', '.join(solvers)}; got {self.solver!r}")
        if self.start not in STARTS:
            raise UsageError(f"start must be one of {', '.join(STARTS)}; got {self.start!r}")
        if self.degree is None:
            return list(range(k + 1))
        if not isinstance(self.degree, (int, np.integer)) or not 0 <= self.degree <= k:
            raise UsageError(f"degree must be None or an integer in 0..{k}; got {self.degree!r}")
        return [int(self.degree)]

    # -- solving --------------------------------------------------------------------------
    def _solve(self, I: np.ndarray, m: int):
        """Best frames (B, k, k) for degree m and their iteration counts."""
        B, k = I.shape[0], I.shape[-1] // 2
        iters = np.zeros(B, dtype=np.int64)
        if m in (0, k):
            return np.broadcast_to(np.eye(k), (B, k, k)).copy(), iters
        if self.criterion == "trace":
            if self.solver == "eigh":
                return F.trace_closed_form(I, m), iters
            R = np.empty((B, k, k))
            for b in range(B):
                R[b], _, iters[b], _ = F.trace_newton(I[b], m)
            return R, iters
        if self.solver == "powell":
            R = np.empty((B, k, k))
            R0 = F.gram_schmidt_start(I, m)
            for b in range(B):
                R[b], _, _, iters[b] = F.powell_logdet(I[b], R0[b], m, self.noise_floor)
            return R, iters
        ratio = lambda I_, m_: F.ratio_start(I_, m_, self.noise_floor)  # noqa: E731
        starts = {"trace": [F.trace_closed_form], "ratio": [ratio],
                  "gram-schmidt": [F.gram_schmidt_start],
                  "both": [F.trace_closed_form, F.gram_schmidt_start],
                  "trace+ratio": [F.trace_closed_form, ratio]}[self.start]
        best_R, best_f = None, None
        for make in starts:
            R, f, it = F.newton_logdet(I, make(I, m), m, self.noise_floor)
            f = np.where(np.isfinite(f), f, np.inf)
            if best_R is None:
                best_R, best_f, iters = R, f, it
            else:
                better = f < best_f
                best_R[better], best_f[better] = R[better], f[better]
                iters = iters + it
        return best_R, iters

    def _estimate_information(self, I: np.ndarray, n: int, degrees: list[int]):
        B, k = I.shape[0], I.shape[-1] // 2
        frames = np.full((B, k + 1, k, k), np.nan)
        ll = np.full((B, k + 1), np.nan)
        iters = np.zeros(B, dtype=np.int64)
        for m in degrees:
            R, it = self._solve(I, m)
            R = canonical_signs(R)
            frames[:, m] = R
            f = F.logdet_value(I, R, m, self.noise_floor)
            ll[:, m] = -n / 2.0 * (f + k)
            iters += it
        return frames, ll, iters

    def estimate_blocks(self, position, force, velocity=None) -> BlockFits:
        """Fit every block of (B, n, k) arrays at once (no uncertainty, no residuals).

        The fast path for many short blocks (the 8.2 degree test, benchmarks).
        """
        y, scaling = _prepare(self, position, force, velocity)
        return self.estimate_information_blocks(_information(y), y.shape[1], scaling=scaling)

    def estimate_information_blocks(self, information, n, *, scaling: Scaling) -> BlockFits:
        """:meth:`estimate_blocks` from joint information matrices (B, 2k, 2k) of ``n`` samples
        each (an int, or (B,) counts: e.g. the running information of
        :class:`~contactlab.constraints.RecursiveConstraint` at several times) in the
        normalised units of ``scaling``.  The frames depend on ``I`` alone; 8.18 scales
        with each block's own ``n``."""
        I = np.asarray(information, dtype=np.float64)
        I = I[None] if I.ndim == 2 else I
        k = I.shape[-1] // 2
        counts = np.broadcast_to(np.asarray(n, dtype=np.float64), I.shape[:1])
        if np.any(counts < min_samples(k)):
            raise DataError(f"a block of {int(counts.min())} samples; the {2 * k}-dimensional "
                            f"joint covariance needs at least {min_samples(k)}", field="position")
        degrees = self._check(k)
        frames, ll, _ = self._estimate_information(I, 1, degrees)
        ll = ll * counts[:, None]
        expl = exploration(I, threshold=self.exploration_threshold).explored
        if self.degree is None:
            finite = np.isfinite(ll).all(axis=1)
            deg = np.where(finite & expl, np.argmax(np.where(np.isfinite(ll), ll, -np.inf),
                                                    axis=1), -1)
        else:
            deg = np.where(np.isfinite(ll[:, self.degree]), self.degree, -1)
        n_out = int(counts[0]) if np.all(counts == counts[0]) else counts.astype(np.int64)
        return BlockFits(deg.astype(np.int64), ll, frames, expl, I, n_out, scaling)

    def estimate(self, position, force, velocity=None) -> ConstraintFit:
        """Fit one block: ``position``, ``force`` (and ``velocity``), each (n, k).

        Raises DataError for fewer than 2k+1 samples or non-finite data;
        degenerate data (no motion, identical samples) gives an
        ``undetermined`` fit, never a frame.
        """
        y, scaling = _prepare(self, position, force, velocity)
        return self.estimate_information(_information(y)[0], y.shape[1], scaling=scaling,
                                    samples=y[0])

    def estimate_information(self, information, n: int, *, scaling: Scaling,
                        samples=None) -> ConstraintFit:
        """Fit from a joint information matrix (2k, 2k) of ``n`` samples in the
        normalised units of ``scaling`` (the recursive form's entry point).

        ``samples`` (n, 2k), the centred scaled samples, give the residuals;
        without them ``residuals_`` is empty.
        """
        I = np.asarray(information, dtype=np.float64)[None]
        k = I.shape[-1] // 2
        if n < min_samples(k):
            raise DataError(f"{n} samples; the {2 * k}-dimensional joint covariance needs "
                            f"at least {min_samples(k)}", field="position")
        degrees = self._check(k)
        frames, ll, iters = self._estimate_information(I, n, degrees)
        expl = exploration(I, threshold=self.exploration_threshold)
        ll0 = ll[0]
        reason = ""
        if self.degree is None:
            if not np.isfinite(ll0).all():
                m, reason = None, "log-likelihood not finite (singular residual covariance)"
            else:
                m = int(np.argmax(ll0))
                if not expl.explored[0]:
                    reason = (f"insufficient exploration: {int(expl.significant[0])} of {k} "
                              "directions moved or pushed")
        else:
            m = int(self.degree)
            if not np.isfinite(ll0[m]):
                reason = "log-likelihood not finite (singular residual covariance)"
            elif 0 < m < k and expl.significant[0] == 0:
                reason = "insufficient exploration: no direction moved or pushed"
        mm = m if m is not None else 0
        R = frames[0, mm] if m is not None else np.eye(k)
        cov, angle_sd = self._uncertainty(I, R, mm, n, samples) if m is not None \
            else (np.full((0, 0), np.nan), math.nan)
        if not reason and not (angle_sd <= self.max_tilt_sd_deg):
            reason = (f"frame not determined by the data (angular standard error "
                      f"{angle_sd:.3g} deg > {self.max_tilt_sd_deg:g})")
        P = F.embed(R[None], mm)[0]
        V = F.innovation_cov(I, R[None], mm, self.noise_floor)[0]
        normals = scaling.normals_to_physical(R[:, :mm])
        free = scaling.free_to_physical(R[:, mm:])
        status = "ok"
        if reason:
            status = "undetermined"
            normals, free = _nan_like(normals), _nan_like(free)
        loglik = float(ll0[mm]) if m is not None else math.nan
        return ConstraintFit(
            degree_=None if (m is None or (reason and self.degree is None)) else m,
            normals_=normals, free_=free, P_=P, V_=V, residuals_=(np.zeros((0, k)) if samples is None
                        else np.asarray(samples) @ P),
            loglik_=loglik, log_likelihoods_=ll0, cov_=cov, angle_sd_deg_=angle_sd,
            information_=I[0], explored_=bool(expl.explored[0]),
            unexplored_=expl.unexplored(0), status_=status, reason_=reason, n_=n,
            iterations_=int(iters[0]), scaling=scaling, noise_floor=self.noise_floor,
            parameters=self.get_params())

    def _uncertainty(self, I, R, m, n, samples=None):
        """Covariance (rad^2) of the frame's tilts and its largest sd (deg).

        "iid": the inverse observed information ``(n/2 H)^{-1}``, exact for independent
        Gaussian samples.  "hac" (default, when the samples are at hand): the sandwich
        ``H^{-1} Omega H^{-1} / n`` with Omega the long-run covariance of the per-sample
        scores (:func:`.frames.long_run_covariance`), which equals the former for
        independent samples and also counts slow, correlated disturbances (compliance,
        friction, hand motion) that make n samples worth fewer; never below the "iid"
        value (the measurement noise alone gives at least that).
        """
        k = R.shape[0]
        d = m * (k - m)
        if d == 0:
            return np.zeros((0, 0)), 0.0
        H = F.logdet_hessian(I, R[None], m, self.noise_floor)[0]
        info = n / 2.0 * H
        w = np.linalg.eigvalsh(info) if np.all(np.isfinite(info)) else np.array([np.nan])
        if not np.all(np.isfinite(w)) or w.min() <= 0:
            return np.full((d, d), np.nan), math.inf
        cov = np.linalg.inv(info)
        if self.uncertainty == "hac" and samples is not None and len(samples) == n:
            omega, _ = F.long_run_covariance(F.logdet_scores(np.asarray(samples), R, m,
                                                             self.noise_floor))
            Hinv = np.linalg.inv(H)
            sandwich = Hinv @ omega @ Hinv / n
            sandwich = 0.5 * (sandwich + sandwich.T)
            if np.all(np.isfinite(sandwich)):
                cov = sandwich if np.linalg.eigvalsh(sandwich).max() > \
                    np.linalg.eigvalsh(cov).max() else cov
        top = float(np.linalg.eigvalsh(cov).max())
        return cov, float(np.degrees(np.sqrt(top)))

    def get_params(self) -> dict:
        return {"degree": self.degree, "criterion": self.criterion, "solver": self.solver,
                "start": self.start, "motion": self.motion,
                "position_sd": np.asarray(self.position_sd).tolist(),
                "force_sd": np.asarray(self.force_sd).tolist(),
                "velocity_sd": np.asarray(self.velocity_sd).tolist(),
                "friction": self.friction, "noise_floor": self.noise_floor,
                "center": self.center, "exploration_threshold": self.exploration_threshold,
                "max_tilt_sd_deg": self.max_tilt_sd_deg, "uncertainty": self.uncertainty}


# -- the stiffness form ------------------------------------------------------------------------

class CartesianStiffness:
    """Stiffness-form estimator (8.12-8.20): P = eigenvectors of the k smallest
    eigenvalues of the joint covariance I.

    Parameters as :class:`CartesianConstraint` (``degree`` only selects how many
    normals to read out of P; None reads it from the alignment statistic).
    Centring defaults to "both" (8.19 with the unknown zero point of 8.12).
    """

    def __init__(self, *, degree: int | None = None, motion: str = "position",
                 position_sd=POSITION_SD, force_sd=FORCE_SD, velocity_sd=VELOCITY_SD,
                 friction: bool = False, noise_floor: float = 1.0, center: str | None = None,
                 max_tilt_sd_deg: float = 30.0):
        self.degree = degree
        self.motion = motion
        self.position_sd = position_sd
        self.force_sd = force_sd
        self.velocity_sd = velocity_sd
        self.friction = friction
        self.noise_floor = float(noise_floor)
        self.center = center
        self.max_tilt_sd_deg = float(max_tilt_sd_deg)

    def _centering(self) -> tuple[bool, bool]:
        c = self.center or "both"
        return c in ("motion", "both"), c == "both"

    def estimate_blocks(self, position, force, velocity=None) -> tuple[np.ndarray, np.ndarray]:
        """Joint projections P (B, 2k, k) and eigenvalues (B, 2k) of (B, n, k) blocks."""
        _check_common(self)
        y, _ = _prepare(self, position, force, velocity)
        lam, vec = np.linalg.eigh(_information(y))
        return vec[:, :, :y.shape[2] // 2], lam

    def estimate(self, position, force, velocity=None) -> StiffnessFit:
        """Fit one block (n, k) arrays; see :class:`CartesianConstraint.estimate`."""
        _check_common(self)
        y, scaling = _prepare(self, position, force, velocity)
        _, n, kk = y.shape
        k = kk // 2
        if self.degree is not None and (not isinstance(self.degree, (int, np.integer))
                                        or not 0 <= self.degree <= k):
            raise UsageError(f"degree must be None or an integer in 0..{k}; got {self.degree!r}")
        I = _information(y)[0]
        lam, vec = np.linalg.eigh(I)
        P = vec[:, :k]
        V = P.T @ I @ P + self.noise_floor * np.eye(k)
        sign, ld = np.linalg.slogdet(V)
        loglik = -n / 2.0 * (ld + k) if sign > 0 else math.nan
        su = np.linalg.svd(P[:k], compute_uv=False)
        sl = np.linalg.svd(P[k:], compute_uv=False)
        m = int(round(float(np.sum(P[:k] ** 2)))) if self.degree is None else int(self.degree)
        with np.errstate(all="ignore"):
            li, lj = np.clip(lam[:k], 0, None)[:, None], np.clip(lam[k:], 0, None)[None, :]
            var = li * lj / (n * (li - lj) ** 2)
        var = np.where(np.isfinite(var), var, np.inf)
        angle_sd = float(np.degrees(np.sqrt(var.max())))
        reason = ""
        if not np.isfinite(loglik):
            reason = "log-likelihood not finite (singular residual covariance)"
        elif not angle_sd <= self.max_tilt_sd_deg:
            reason = (f"eigenvectors not determined by the data (angular standard error "
                      f"{angle_sd:.3g} deg > {self.max_tilt_sd_deg:g})")
        uu, _, _ = np.linalg.svd(P[:k])
        ul, _, _ = np.linalg.svd(P[k:])
        normals = scaling.normals_to_physical(uu[:, :m])
        free = scaling.free_to_physical(ul[:, :k - m])
        if reason:
            normals, free = _nan_like(normals), _nan_like(free)
        return StiffnessFit(
            P_=P, eigenvalues_=lam, V_=V, loglik_=float(loglik),
            alignment_=np.array([su.sum(), sl.sum()]),
            degree_=None if (reason and self.degree is None) else m,
            normals_=normals, free_=free, eigvec_var_=var, angle_sd_deg_=angle_sd,
            residuals_=y[0] @ P, information_=I, status_="undetermined" if reason else "ok",
            reason_=reason, n_=n, scaling=scaling)
