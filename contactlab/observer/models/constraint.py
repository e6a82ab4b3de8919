"""Constraint feature models (8.1.1, 8.3, 9.1.1): the Cartesian constraint form in the observer.

A constraint model of degree ``m`` (0 free, 1 a plane, 2 an edge, 3 a corner
in R^3; the graph files name the constrained axes: ``0``, ``Z``, ``XZ``,
``YZ``, ``XYZ`` or ``3``) says that, in a frame ``R = [N, T]`` of ``m`` unit
normals and ``k - m`` free directions, the reciprocity residual (8.10-8.11,
8.14) of every sample

    nu_t = [ N^T beta (x_t - x0) ;  T^T alpha w_t ]          (k values)

-- motion along the normals about the surface point, force along the free
directions -- is zero-mean normal with covariance ``V`` (8.15), in the units
normalised by the measurement accuracies (8.7-8.9, :mod:`contactlab.constraints.scaling`).
The model reads the ``contact`` signal: position (k) then force (k) per
sample.  The force along the normals (the constraint force) and the motion
along the free directions are not modelled here: the velocity models (F, M)
of the node's triple describe motion (9.1.1).

Per instance (one per active path, started at the path's start) the model is
a sequential estimator, and the observer receives the *predictive*
log-likelihood of each sample given the instance's earlier samples (6.10):

* The surface point along the normals, ``N^T beta x0``, is unknown and
  estimated from the instance's samples (the centring of 8.19) under the
  conjugate prior ``N(0, V_nn / kappa0)``, ``kappa0 = mean(diag V_nn) /
  (beta offset_sd)^2`` (about ``offset_sd`` metres of prior standard
  deviation): after ``c`` samples its posterior mean is ``sum z / (kappa0 + c)``
  and the normal block of the residual has predictive covariance
  ``V_nn (1 + 1/(kappa0 + c))``; the sum of these predictive terms is the
  exact marginal log-likelihood of the segment.  (Our choice: the thesis's 8.18 is a maximised
  likelihood of a whole block, which favours every extra parameter on short
  segments; the predictive form compares paths of any length fairly.)
* ``mode="fixed"``: the frame is given (a nominal frame, or one estimated by
  the chapter-8 estimator from labelled segments, :meth:`ConstraintFeature.fit`).
* ``mode="estimated"``: the frame is re-estimated after every sample from the
  instance's joint information (8.19, the running sums of
  :mod:`contactlab.constraints.recursive`) by the trace criterion's closed
  form (8.25: the eigenvectors of the centred information, as
  :func:`contactlab.constraints.frames.trace_closed_form`; here by Jacobi
  rotations from the instance's previous estimate, :func:`constraint_step`), with
  the nominal frame as prior: ``prior_samples`` pseudo-samples whose motion
  spans the nominal free directions and whose force spans the nominal normals
  (our conjugate form of the 8.69-8.70 alignment prior: it pulls the estimate
  toward the nominal frame with the weight of that many samples).  Sample t is
  scored under the frame estimated from samples before t.  The score carries
  8.70's prior term ``log(a) - a alpha`` of the instance's current estimate, with
  alpha the misalignment of 8.69 (3 minus the singular values of the estimated
  projection against the nominal one) and ``a = prior_samples``: in the trace
  criterion (8.25: half a unit per squared unit residual, nats when the residuals
  have unit variance) turning a normal by theta costs the pseudo-samples
  ``a sin^2 theta`` and 8.69 gives ``a alpha = 2 a (1 - cos theta)``, the same to
  second order, so one number serves as the estimate's prior weight and as 8.70's
  parameter (our choice; 8.3's 15 deg prior standard deviation is
  ``a = 2/3 / (1 - cos 15 deg) = 19.57``).  With trained noise above one unit the
  estimate's pull toward the nominal frame is weaker than 8.70's maximum would make it.  ``log(a)`` is added at the
  instance's first sample and ``-a alpha`` as its change from sample to sample
  (the sum over a segment is 8.70's term for the segment's latest estimate); the
  free and the fully constrained models have no frame to estimate and no term.

``V`` is used block-diagonally -- ``V_nn`` (motion along the normals) and
``V_ff`` (force along the free directions) -- (our choice: their
cross-covariance is a stiffness effect that the rigid constraint form does not
model, and the block form keeps the predictive update of the offset exact).
The innovation the detectors test (6.11) is the residual standardised by its
predictive covariance: chi-square with ``k`` degrees of freedom; only its increase
(6.14, :attr:`FeatureModel.tests`): a residual below the trained noise is no other
contact.

One compiled step scores a sample for one instance and advances its state
(:func:`constraint_step`, fixed or estimated frame); :meth:`ConstraintFeature.run`
loops it over samples x instances in one compiled pass (numpy's calls cost more
than the arithmetic on the observer's short catch-up runs), and the observer's
compiled core (:mod:`contactlab.observer.engine`) calls the same step, so both
give the same numbers to the bit.  An instance's state is one row: the count of
its samples, then the running sums along the normals (fixed frame) or the sums of
the scaled motion, its outer products and the force's outer products, the latest
8.69 alpha and the latest frame estimate (estimated frame: the next sample's
eigen-solver starts from it).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contactlab.constraints.cartesian import FORCE_SD, POSITION_SD, CartesianConstraint
from contactlab.constraints.scaling import reciprocal_scaling
from contactlab.observer.models.base import LOG_2PI, FeatureModel

__all__ = ["ConstraintFeature", "constraint_normals", "parse_constraint", "constraint_step",
           "CONSTRAINT_MODES", "K"]

#: the Cartesian space of the fingertip (R^3)
K = 3
CONSTRAINT_MODES = ("fixed", "estimated")
_AXES = {"X": 0, "Y": 1, "Z": 2}


def constraint_normals(name: str) -> np.ndarray:
    """Unit normals (3, m) of a named constraint: ``"0"`` (free), axis letters
    (``"Z"``, ``"XZ"``, ``"YZ"``, ...) or ``"3"`` (all three axes).  ValueError otherwise."""
    s = str(name).strip().upper()
    if s == "0":
        return np.zeros((K, 0))
    if s == "3":
        s = "XYZ"
    if not s or any(c not in _AXES for c in s) or len(set(s)) != len(s):
        raise ValueError(f"constraint must be '0', '3' or distinct axis letters from X, Y, Z; "
                         f"got {name!r}")
    return np.eye(K)[:, sorted(_AXES[c] for c in s)]


def parse_constraint(name) -> tuple[int, np.ndarray | None]:
    """``(degree, normals)`` of a graph file's ``constraint``: a degree ``"0"``-``"3"``
    (normals None: the frame is estimated from training data, except 0 and 3 whose
    frames are the whole space) or axis letters (:func:`constraint_normals`)."""
    s = str(name).strip()
    if s in ("0", "1", "2", "3"):
        m = int(s)
        return m, (constraint_normals(s) if m in (0, 3) else None)
    N = constraint_normals(s)
    return N.shape[1], N


def _rotation_deg(angles) -> np.ndarray:
    """Rotation matrix of x-y-z Euler angles in degrees (extrinsic, applied x first)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("xyz", np.asarray(angles, float), degrees=True).as_matrix()


def _complement(N: np.ndarray) -> np.ndarray:
    """The frame ``[N, T]`` (k, k): T an orthonormal complement of the orthonormal N."""
    m = N.shape[1]
    q, _ = np.linalg.qr(np.concatenate([N, np.eye(K)], axis=1))
    T = q[:, m:K]
    return np.concatenate([N, T], axis=1)


class ConstraintFeature(FeatureModel):
    """A Cartesian constraint model of degree ``m`` in a frame (module notes).

    Parameters
    ----------
    normals : (3, m) physical unit normals (columns orthonormal); m = 0 is free space.
    V : (3, 3) innovation covariance in normalised units, frame coordinates
        (normals first); default the identity (measurement noise only).
    mode : ``"fixed"`` or ``"estimated"`` (frame re-estimated per instance).
    position_sd, force_sd : scalar measurement accuracies (m, N) that normalise
        units (8.7-8.9); every model of one graph must use the same.
    offset_sd : prior standard deviation (m) of the surface point along each normal.
    prior_samples : weight of the nominal frame in ``mode="estimated"`` (samples), and
        8.70's prior parameter ``a``.
    frame_penalty : in ``mode="estimated"``, add 8.70's ``log(a) - a alpha`` to the score
        (module notes); False scores the data alone.
    """

    kind = "constraint"
    tests = ("increase",)

    def __init__(self, *, name: str, normals=None, degree: int | None = None, V=None,
                 mode: str = "fixed", position_sd: float = POSITION_SD,
                 force_sd: float = FORCE_SD, offset_sd: float = 0.05,
                 prior_samples: float = 25.0, frame_penalty: bool = True,
                 signal: str = "contact", change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        if mode not in CONSTRAINT_MODES:
            raise ValueError(f"{name}: mode must be one of {list(CONSTRAINT_MODES)}; got {mode!r}")
        for key, v in (("position_sd", position_sd), ("force_sd", force_sd),
                       ("offset_sd", offset_sd)):
            if not (np.ndim(v) == 0 and math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: {key} must be a number > 0; got {v!r}")
        if not (math.isfinite(prior_samples) and prior_samples > 0):
            raise ValueError(f"{name}: prior_samples must be > 0; got {prior_samples!r}")
        self.mode = mode
        self.position_sd, self.force_sd = float(position_sd), float(force_sd)
        self.offset_sd = float(offset_sd)
        self.prior_samples = float(prior_samples)
        self.frame_penalty = bool(frame_penalty)
        self.scaling = reciprocal_scaling(self.position_sd, self.force_sd, K)
        self._beta = float(self.scaling.beta[0])
        self._alpha = float(self.scaling.alpha[0])
        #: the frame is a given of the model (fit estimates only V), not learned
        self.frame_given = normals is not None
        self.normals = self.frame = self.V = None
        if normals is None:
            if degree is None or int(degree) not in range(K + 1):
                raise ValueError(f"{name}: give the normals, or the degree (0-{K}) for fit "
                                 f"to estimate the frame; got degree {degree!r}")
            self.degree = int(degree)
        else:
            self._set(normals, V)
            if degree is not None and int(degree) != self.degree:
                raise ValueError(f"{name}: degree {degree} but {self.degree} normals")

    def _set(self, normals, V) -> None:
        """The frame and the innovation covariance, and what scoring derives from them."""
        name = self.name
        N = np.asarray(normals, dtype=np.float64).reshape(K, -1)
        m = N.shape[1]
        if m and not np.allclose(N.T @ N, np.eye(m), atol=1e-6):
            raise ValueError(f"{name}: normals must be orthonormal columns (3, m)")
        V = np.eye(K) if V is None else np.asarray(V, dtype=np.float64)
        if V.shape != (K, K) or not np.all(np.isfinite(V)):
            raise ValueError(f"{name}: V must be a finite (3, 3) matrix")
        Vs = 0.5 * (V + V.T)
        Vn, Vf = Vs[:m, :m], Vs[m:, m:]
        for part, blk in (("normal", Vn), ("free", Vf)):
            if blk.size and np.linalg.eigvalsh(blk).min() <= 0:
                raise ValueError(f"{name}: the {part} block of V must be positive definite")
        self.degree = m
        self.normals = N
        self.frame = _complement(N)
        self.V = Vs
        self._Vn_inv = np.linalg.inv(Vn) if m else np.zeros((0, 0))
        self._Vf_inv = np.linalg.inv(Vf) if m < K else np.zeros((0, 0))
        self._logdet_n = float(np.linalg.slogdet(Vn)[1]) if m else 0.0
        self._logdet_f = float(np.linalg.slogdet(Vf)[1]) if m < K else 0.0
        # conjugate prior of the surface point: N(0, V_nn / kappa0)
        self.kappa0 = (float(np.mean(np.diag(Vn))) / (self.offset_sd * self._beta) ** 2
                       if m else 0.0)
        self._p = _pack(self)

    # -- construction --------------------------------------------------------------------
    @classmethod
    def named(cls, name: str, constraint: str, *, rotate_deg=None, **kw) -> "ConstraintFeature":
        """A model of a named constraint (:func:`constraint_normals`), its frame
        optionally rotated by x-y-z Euler angles ``rotate_deg`` (degrees)."""
        N = constraint_normals(constraint)
        if rotate_deg is not None:
            N = _rotation_deg(rotate_deg) @ N
        return cls(name=name, normals=N, **kw)

    def fit(self, X, y=None) -> "ConstraintFeature":
        """Train from labelled segments ``X``, each (n_i, 6): position then force.

        The joint information (8.19) is pooled over segments, each centred on
        its own mean motion (a segment's surface point is its own); the frame is
        the chapter-8 constraint-form estimate of the model's degree (log-det
        criterion, :meth:`CartesianConstraint.estimate_information`) unless the
        model was built with its normals (:attr:`frame_given`); ``V`` is ``P^T I P``
        plus the estimator's noise floor (8.20).  Segments shorter than 2 samples
        are left out.
        """
        name = self.name
        segs = [s.reshape(len(s), 2 * K) for s in self._segments(X, name)]
        segs = [s for s in segs if len(s) >= 2]
        if not segs:
            raise ValueError(f"{name}: no labelled segment of at least 2 samples")
        scaling = self.scaling
        n = sum(len(s) for s in segs)
        info = np.zeros((2 * K, 2 * K))
        for s in segs:
            y = np.concatenate([(s[:, :K] - s[:, :K].mean(axis=0)) * scaling.beta,
                                s[:, K:] * scaling.alpha], axis=1)
            info += y.T @ y
        info /= n
        if self.frame_given:
            N = self.normals
        else:
            est = CartesianConstraint(degree=self.degree, position_sd=self.position_sd,
                                      force_sd=self.force_sd)
            f = est.estimate_information(info, max(n, 2 * K + 1), scaling=scaling)
            N = f.normals_
            if not f.determined_ or np.isnan(N).any():
                raise ValueError(f"{name}: the labelled data do not determine a degree-"
                                 f"{self.degree} frame ({f.reason_})")
        # V in the model's own frame [N, T]: the estimator's V_ is in its own free basis,
        # another rotation of the free span than the complement the model scores in
        R = _complement(N)
        m = N.shape[1]
        P = np.zeros((2 * K, K))
        P[:K, :m], P[K:, m:] = R[:, :m], R[:, m:]
        self._set(R[:, :m], P.T @ info @ P + np.eye(K))      # the estimator's noise floor (8.20)
        self._record(segs)
        return self

    def params(self) -> dict:
        """The parameters that define the model (what the models file stores)."""
        self._fitted("normals")
        return {"normals": self.normals, "V": self.V, "mode": self.mode,
                "position_sd": self.position_sd, "force_sd": self.force_sd,
                "offset_sd": self.offset_sd, "prior_samples": self.prior_samples}

    # -- the FeatureModel contract -------------------------------------------------------
    def check_channels(self, channels: int) -> None:
        if channels != 2 * K:
            raise ValueError(f"model {self.name!r} reads position and force ({2 * K} "
                             f"channels); the {self.signal!r} signal has {channels}")

    def dim(self, channels: int) -> int:
        return K

    def init_state(self, starts, channels):
        self._fitted("normals")
        return {"s": np.zeros((len(starts), _state_width(self.degree, self.mode)))}

    def run(self, state, x, *, t0, starts):
        return _run_kernel(np.ascontiguousarray(x, dtype=np.float64), state["s"], self._p)

    def core_spec(self, channels):
        self._fitted("normals")
        if type(self).run is not ConstraintFeature.run:
            return None
        from contactlab.observer.engine import REG_CONSTRAINT

        return {"reg": REG_CONSTRAINT, "channels": 2 * K,
                "prior": np.zeros(_state_width(self.degree, self.mode)), "params": self._p}


# the packed parameter row of :func:`constraint_step`
P_M, P_BETA, P_ALPHA, P_KAPPA0, P_LOGDET_N, P_LOGDET_F, P_A, P_EST, P_PENALTY = range(9)
P_FRAME, P_VN, P_VF, P_PRIOR = 9, 18, 27, 36
N_PARAMS = 45
# count, sums of x, x x^T, w w^T, alpha, the latest frame estimate (row-major)
_W_EST = 1 + K + 2 * K * K + 1 + K * K
_S_ALPHA = 1 + K + 2 * K * K
_S_FRAME = _S_ALPHA + 1


def _state_width(m: int, mode: str) -> int:
    return _W_EST if mode == "estimated" else 1 + m


def _pack(model: "ConstraintFeature") -> np.ndarray:
    """The model as :func:`constraint_step`'s parameter row: degree, unit scalings,
    kappa0, the blocks' log-determinants, 8.70's ``a``, flags (frame estimated, its
    prior term on), the frame ``[N, T]``, the blocks' inverses (padded to 3 x 3) and the
    nominal frame's pseudo-samples ``a (T T^T - N N^T)`` (row-major)."""
    m = model.degree
    p = np.zeros(N_PARAMS)
    est = model.mode == "estimated"
    p[[P_M, P_BETA, P_ALPHA, P_KAPPA0, P_LOGDET_N, P_LOGDET_F, P_A, P_EST, P_PENALTY]] = [
        m, model._beta, model._alpha, model.kappa0, model._logdet_n, model._logdet_f,
        model.prior_samples, float(est), float(est and 0 < m < K and model.frame_penalty)]
    N0, T0 = model.frame[:, :m], model.frame[:, m:]
    vn, vf = np.zeros((K, K)), np.zeros((K, K))
    vn[:m, :m], vf[:K - m, :K - m] = model._Vn_inv, model._Vf_inv
    p[P_FRAME:P_FRAME + 9] = model.frame.ravel()
    p[P_VN:P_VN + 9] = vn.ravel()
    p[P_VF:P_VF + 9] = vf.ravel()
    p[P_PRIOR:P_PRIOR + 9] = (model.prior_samples * (T0 @ T0.T - N0 @ N0.T)).ravel()
    return p


#: length of :func:`constraint_step`'s scratch array
SCRATCH = 40


@numba.njit(cache=True)
def _run_kernel(x, S, p):  # pragma: no cover - compiled
    """:func:`constraint_step` over samples ``x`` (n, 6) for every instance (rows of ``S``):
    the (n, U) log-likelihoods and chi-squares; ``S`` advances in place."""
    n, U = x.shape[0], S.shape[0]
    ll = np.empty((n, U))
    chi2 = np.empty((n, U))
    w = np.empty(SCRATCH)
    for u in range(U):
        s = S[u]
        for t in range(n):
            ll[t, u], chi2[t, u] = constraint_step(p, s, x[t], w)
    return ll, chi2


@numba.njit(cache=True)
def constraint_step(p, s, x, w):  # pragma: no cover - compiled
    """Score one sample ``x`` (position then force, 6) for one instance (state row ``s``)
    and advance it: ``(log-likelihood, chi-square)`` (module notes; ``w``: scratch of
    :data:`SCRATCH` numbers).

    The residuals are taken in the frame ``B`` (3 x 3: normals, then free directions):
    the model's frame, or with the frame estimated, the eigenvectors of the centred
    information of the instance's samples before this one (8.19 with the nominal frame's
    pseudo-samples, ``D = S_xx - S_x S_x^T / max(c, 1) - S_ww + a (T T^T - N N^T)``) by
    ascending eigenvalue (8.25's closed form: the first m are the normals;
    :func:`_eig3`), each span's basis turned onto the nominal one (orthogonal
    Procrustes, :func:`_turn`; the score is then that of the span, whatever basis the
    eigen-solver returned).  The normal block is the motion about the posterior surface
    point, ``beta x - S / (kappa0 + c)`` (S the sum of earlier samples' scaled motion,
    along the normals for a fixed frame), with predictive covariance
    ``V_nn (1 + 1 / (kappa0 + c))``; the free block the scaled force under ``V_ff``.
    With the prior term, 8.70's ``log a - a alpha``: ``log a`` at the instance's first
    sample and ``-a`` times alpha's change (8.69's alpha, 3 minus the singular values of
    the spans against the nominal ones: those of the Procrustes problems)."""
    m = int(p[P_M])
    kf = K - m
    beta, alpha_s, kappa0 = p[P_BETA], p[P_ALPHA], p[P_KAPPA0]
    c = s[0]
    cg = kappa0 + c
    B = w[0:9].reshape((K, K))
    e = w[9:12]
    ll = 0.0
    if p[P_EST] == 0.0:
        for i in range(K):
            for j in range(K):
                B[i, j] = p[P_FRAME + K * i + j]
        for j in range(m):
            z = 0.0
            for r in range(K):
                z += (x[r] * beta) * B[r, j]
            e[j] = z - s[1 + j] / cg
            s[1 + j] += z
    else:
        cc = c if c > 1.0 else 1.0
        D = w[12:21].reshape((K, K))
        R = w[21:30].reshape((K, K))
        for i in range(K):
            for j in range(K):
                D[i, j] = (s[1 + K + K * i + j] - s[1 + i] * (s[1 + j] / cc)
                           - s[1 + K + K * K + K * i + j] + p[P_PRIOR + K * i + j])
        if c == 0.0:
            for i in range(K):
                for j in range(K):
                    R[i, j] = 1.0 if i == j else 0.0
        else:
            for i in range(K * K):
                R[i // K, i % K] = s[_S_FRAME + i]
        _eig3(D, R, w[30:39].reshape((K, K)))
        for i in range(K * K):
            s[_S_FRAME + i] = R[i // K, i % K]
        sv = _turn(R, 0, m, p, B) + _turn(R, m, K, p, B)
        for j in range(m):
            acc = 0.0
            for r in range(K):
                acc += (x[r] * beta - s[1 + r] / cg) * B[r, j]
            e[j] = acc
        if p[P_PENALTY] != 0.0:
            al = K - sv
            ll = ll - p[P_A] * (al - s[_S_ALPHA])
            if c == 0.0:
                ll += math.log(p[P_A])
            s[_S_ALPHA] = al
        for i in range(K):
            xi = x[i] * beta
            wi = x[K + i] * alpha_s
            s[1 + i] += xi
            for j in range(K):
                s[1 + K + K * i + j] += xi * (x[j] * beta)
                s[1 + K + K * K + K * i + j] += wi * (x[K + j] * alpha_s)
    chi = 0.0
    v = 0.0
    if m:
        g = 1.0 + 1.0 / cg
        q = 0.0
        for i in range(m):
            for j in range(m):
                q += e[i] * p[P_VN + K * i + j] * e[j]
        q /= g
        v -= 0.5 * (q + p[P_LOGDET_N] + m * math.log(g) + m * LOG_2PI)
        chi += q
    if kf:
        for j in range(kf):
            acc = 0.0
            for r in range(K):
                acc += (x[K + r] * alpha_s) * B[r, m + j]
            e[j] = acc
        qf = 0.0
        for i in range(kf):
            for j in range(kf):
                qf += e[i] * p[P_VF + K * i + j] * e[j]
        v -= 0.5 * (qf + p[P_LOGDET_F] + kf * LOG_2PI)
        chi += qf
    s[0] = c + 1.0
    return v + ll, chi


@numba.njit(cache=True)
def _eig3(D, R, T):  # pragma: no cover - compiled
    """Eigenvectors of the symmetric 3 x 3 ``D`` (overwritten) into the columns of ``R``,
    by ascending eigenvalue, starting from the orthogonal ``R`` given (the instance's
    previous estimate: one sample changes D little, so ``R^T D R`` is nearly diagonal):
    ``D <- R^T D R``, then cyclic Jacobi rotations (each zeroes one off-diagonal pair,
    ``D <- J^T D J``, ``R <- R J``; Golub and Van Loan 8.5) until the off-diagonal part
    is below rounding, then a sort (``T``: scratch)."""
    for i in range(K):
        for j in range(K):
            acc = 0.0
            for k in range(K):
                acc += D[i, k] * R[k, j]
            T[i, j] = acc
    for i in range(K):
        for j in range(i, K):
            acc = 0.0
            for k in range(K):
                acc += R[k, i] * T[k, j]
            D[i, j] = acc
            D[j, i] = acc
    for _ in range(60):
        off = D[0, 1] * D[0, 1] + D[0, 2] * D[0, 2] + D[1, 2] * D[1, 2]
        diag = D[0, 0] * D[0, 0] + D[1, 1] * D[1, 1] + D[2, 2] * D[2, 2]
        if not off > 1e-34 * diag:
            break
        for pq in range(3):
            a = 0 if pq < 2 else 1
            b = 1 if pq == 0 else 2
            apq = D[a, b]
            if apq == 0.0:
                continue
            theta = (D[b, b] - D[a, a]) / (2.0 * apq)
            t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
            if theta < 0.0:
                t = -t
            cs = 1.0 / math.sqrt(t * t + 1.0)
            sn = t * cs
            for k in range(K):
                dka, dkb = D[k, a], D[k, b]
                D[k, a] = cs * dka - sn * dkb
                D[k, b] = sn * dka + cs * dkb
            for k in range(K):
                dak, dbk = D[a, k], D[b, k]
                D[a, k] = cs * dak - sn * dbk
                D[b, k] = sn * dak + cs * dbk
            D[a, b] = 0.0
            D[b, a] = 0.0
            for k in range(K):
                rka, rkb = R[k, a], R[k, b]
                R[k, a] = cs * rka - sn * rkb
                R[k, b] = sn * rka + cs * rkb
    for i in range(K - 1):                       # selection sort of three
        j = i
        for k in range(i + 1, K):
            if D[k, k] < D[j, j]:
                j = k
        if j != i:
            d = D[i, i]
            D[i, i] = D[j, j]
            D[j, j] = d
            for k in range(K):
                r = R[k, i]
                R[k, i] = R[k, j]
                R[k, j] = r


@numba.njit(cache=True)
def _turn(R, lo, hi, p, B):  # pragma: no cover - compiled
    """Columns ``lo:hi`` of ``B``: those of ``R`` turned onto the nominal frame's (``p``'s
    frame) by the orthogonal polar factor ``Q`` of ``M = R_span^T F_span`` (the orthogonal
    Procrustes solution, the orthogonal matrix nearest to M); returns the sum of M's
    singular values (0 for an empty span).  Closed forms for one column (Q the sign) and
    two (the rotation or reflection maximising ``tr(Q^T M)``: a rotation by the angle of
    ``(a + d, c - b)`` when ``det M >= 0``, else the reflection along ``(a - d, b + c)``,
    whose lengths are then ``s1 + s2``); an SVD for three."""
    j = hi - lo
    if j == 0:
        return 0.0
    if j == 3:
        M = np.empty((3, 3))
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for r in range(K):
                    acc += R[r, a] * p[P_FRAME + K * r + b]
                M[a, b] = acc
        u, sv, vt = np.linalg.svd(M)
        Q = u @ vt
        for r in range(K):
            for b in range(3):
                acc = 0.0
                for a in range(3):
                    acc += R[r, a] * Q[a, b]
                B[r, b] = acc
        return sv.sum()
    m00 = 0.0
    for r in range(K):
        m00 += R[r, lo] * p[P_FRAME + K * r + lo]
    if j == 1:
        q = -1.0 if m00 < 0.0 else 1.0
        for r in range(K):
            B[r, lo] = R[r, lo] * q
        return abs(m00)
    m01 = m10 = m11 = 0.0
    for r in range(K):
        m01 += R[r, lo] * p[P_FRAME + K * r + lo + 1]
        m10 += R[r, lo + 1] * p[P_FRAME + K * r + lo]
        m11 += R[r, lo + 1] * p[P_FRAME + K * r + lo + 1]
    if m00 * m11 - m01 * m10 >= 0.0:
        u, v = m00 + m11, m10 - m01
        n = math.sqrt(u * u + v * v)
        if n == 0.0:                     # M = 0 (not for two 2-D spans of R^3): keep R's
            q00, q01, q10, q11 = 1.0, 0.0, 0.0, 1.0
        else:
            q00, q01, q10, q11 = u / n, -v / n, v / n, u / n
    else:
        u, v = m00 - m11, m01 + m10
        n = math.sqrt(u * u + v * v)
        q00, q01, q10, q11 = u / n, v / n, v / n, -u / n
    for r in range(K):
        ra, rb = R[r, lo], R[r, lo + 1]
        B[r, lo] = ra * q00 + rb * q10
        B[r, lo + 1] = ra * q01 + rb * q11
    return n
