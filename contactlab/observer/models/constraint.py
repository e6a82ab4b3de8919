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
  form (8.25, :func:`contactlab.constraints.frames.trace_closed_form`), with
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

All instances advance together over a chunk: a fixed frame in one compiled pass
over samples x instances (:func:`_fixed_kernel`; numpy's calls cost more than the
arithmetic on the observer's short catch-up runs), an estimated frame with numpy
(batched 3x3 eigen-decompositions over samples x instances): no per-sample Python
loop.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contactlab.constraints.cartesian import FORCE_SD, POSITION_SD, CartesianConstraint
from contactlab.constraints.scaling import reciprocal_scaling
from contactlab.observer.models.base import LOG_2PI, FeatureModel

__all__ = ["ConstraintFeature", "constraint_normals", "parse_constraint", "misalignment",
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

    def __init__(self, *, name: str, normals, V=None, mode: str = "fixed",
                 position_sd: float = POSITION_SD, force_sd: float = FORCE_SD,
                 offset_sd: float = 0.05, prior_samples: float = 25.0,
                 frame_penalty: bool = True,
                 signal: str = "contact", change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        N = np.asarray(normals, dtype=np.float64).reshape(K, -1)
        m = N.shape[1]
        if m and not np.allclose(N.T @ N, np.eye(m), atol=1e-6):
            raise ValueError(f"{name}: normals must be orthonormal columns (3, m)")
        if mode not in CONSTRAINT_MODES:
            raise ValueError(f"{name}: mode must be one of {list(CONSTRAINT_MODES)}; got {mode!r}")
        for key, v in (("position_sd", position_sd), ("force_sd", force_sd),
                       ("offset_sd", offset_sd)):
            if not (np.ndim(v) == 0 and math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: {key} must be a number > 0; got {v!r}")
        if not (math.isfinite(prior_samples) and prior_samples > 0):
            raise ValueError(f"{name}: prior_samples must be > 0; got {prior_samples!r}")
        V = np.eye(K) if V is None else np.asarray(V, dtype=np.float64)
        if V.shape != (K, K) or not np.all(np.isfinite(V)):
            raise ValueError(f"{name}: V must be a finite (3, 3) matrix")
        self.degree = m
        self.normals = N
        self.frame = _complement(N)
        self.V = 0.5 * (V + V.T)
        self.mode = mode
        self.position_sd, self.force_sd = float(position_sd), float(force_sd)
        self.offset_sd = float(offset_sd)
        self.prior_samples = float(prior_samples)
        self.frame_penalty = bool(frame_penalty)
        self.scaling = reciprocal_scaling(self.position_sd, self.force_sd, K)
        self._beta = float(self.scaling.beta[0])
        self._alpha = float(self.scaling.alpha[0])
        Vn, Vf = self.V[:m, :m], self.V[m:, m:]
        for part, blk in (("normal", Vn), ("free", Vf)):
            if blk.size and np.linalg.eigvalsh(blk).min() <= 0:
                raise ValueError(f"{name}: the {part} block of V must be positive definite")
        self._Vn_inv = np.linalg.inv(Vn) if m else np.zeros((0, 0))
        self._Vf_inv = np.linalg.inv(Vf) if m < K else np.zeros((0, 0))
        self._logdet_n = float(np.linalg.slogdet(Vn)[1]) if m else 0.0
        self._logdet_f = float(np.linalg.slogdet(Vf)[1]) if m < K else 0.0
        # conjugate prior of the surface point: N(0, V_nn / kappa0)
        self.kappa0 = (float(np.mean(np.diag(Vn))) / (self.offset_sd * self._beta) ** 2
                       if m else 0.0)

    # -- construction --------------------------------------------------------------------
    @classmethod
    def named(cls, name: str, constraint: str, *, rotate_deg=None, **kw) -> "ConstraintFeature":
        """A model of a named constraint (:func:`constraint_normals`), its frame
        optionally rotated by x-y-z Euler angles ``rotate_deg`` (degrees)."""
        N = constraint_normals(constraint)
        if rotate_deg is not None:
            N = _rotation_deg(rotate_deg) @ N
        return cls(name=name, normals=N, **kw)

    @classmethod
    def from_segments(cls, segments, *, name: str, degree: int | None = None, normals=None,
            mode: str = "fixed", position_sd: float = POSITION_SD, force_sd: float = FORCE_SD,
            **kw) -> "ConstraintFeature":
        """Train from labelled segments, each (n_i, 6): position then force.

        The joint information (8.19) is pooled over segments, each centred on
        its own mean motion (a segment's surface point is its own); the frame is
        the chapter-8 constraint-form estimate of ``degree`` (log-det criterion,
        :meth:`CartesianConstraint.estimate_information`) unless ``normals`` fix it;
        ``V`` is ``P^T I P`` plus the estimator's noise floor (8.20).
        """
        segs = [np.asarray(s, dtype=np.float64).reshape(len(s), 2 * K) for s in segments]
        segs = [s for s in segs if len(s) >= 2]
        if not segs:
            raise ValueError(f"{name}: no labelled segment of at least 2 samples")
        scaling = reciprocal_scaling(position_sd, force_sd, K)
        n = sum(len(s) for s in segs)
        info = np.zeros((2 * K, 2 * K))
        for s in segs:
            y = np.concatenate([(s[:, :K] - s[:, :K].mean(axis=0)) * scaling.beta,
                                s[:, K:] * scaling.alpha], axis=1)
            info += y.T @ y
        info /= n
        if normals is None:
            if degree is None:
                raise ValueError(f"{name}: give the degree or the normals")
            est = CartesianConstraint(degree=int(degree), position_sd=position_sd,
                                      force_sd=force_sd)
            f = est.estimate_information(info, max(n, 2 * K + 1), scaling=scaling)
            N = f.normals_
            if not f.determined_ or np.isnan(N).any():
                raise ValueError(f"{name}: the labelled data do not determine a degree-"
                                 f"{degree} frame ({f.reason_})")
            R = _complement(N)
            V = f.V_
        else:
            N = np.asarray(normals, dtype=np.float64).reshape(K, -1)
            R = _complement(N)
            m = N.shape[1]
            P = np.zeros((2 * K, K))
            P[:K, :m], P[K:, m:] = R[:, :m], R[:, m:]
            V = P.T @ info @ P + np.eye(K)      # the estimator's noise floor (8.20)
        model = cls(name=name, normals=R[:, :N.shape[1]], V=V, mode=mode,
                    position_sd=position_sd, force_sd=force_sd, **kw)
        model.n_samples_ = n
        model.n_segments_ = len(segs)
        return model

    def params(self) -> dict:
        """The parameters that define the model (what the models file stores)."""
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
        U = len(starts)
        state = {"count": np.zeros(U)}
        if self.mode == "fixed":
            state["sum"] = np.zeros((U, self.degree))
        else:
            state["sx"] = np.zeros((U, K))
            state["sxx"] = np.zeros((U, K, K))
            state["sww"] = np.zeros((U, K, K))
            state["alpha"] = np.zeros(U)
        return state

    def run(self, state, x, *, t0, starts):
        N, U = x.shape[0], len(starts)
        xs = x[:, :K] * self._beta                       # (N, 3) scaled motion
        ws = x[:, K:] * self._alpha                      # (N, 3) scaled force
        c = state["count"][None, :] + np.arange(N, dtype=np.float64)[:, None]   # before t
        if self.mode == "fixed":
            ll, chi2 = self._run_fixed(state, xs, ws, c)
        else:
            ll, chi2 = self._run_estimated(state, xs, ws, c)
        state["count"] += N
        return ll, chi2

    def _score(self, e, f, c):
        """(N, U) log-likelihood and chi-square of normal residuals ``e`` (N, U, m)
        about the running offset after ``c`` samples and free residuals ``f`` (N, U, k-m)."""
        m = self.degree
        ll = np.zeros(c.shape)
        chi2 = np.zeros(c.shape)
        if m:
            g = 1.0 + 1.0 / (self.kappa0 + c)
            q = np.einsum("nui,ij,nuj->nu", e, self._Vn_inv, e) / g
            ll -= 0.5 * (q + self._logdet_n + m * np.log(g) + m * LOG_2PI)
            chi2 += q
        if m < K:
            qf = np.einsum("nui,ij,nuj->nu", f, self._Vf_inv, f)
            ll -= 0.5 * (qf + self._logdet_f + (K - m) * LOG_2PI)
            chi2 += qf
        return ll, chi2

    def _run_fixed(self, state, xs, ws, c):
        m = self.degree
        ll, chi2 = _fixed_kernel(np.ascontiguousarray(xs), np.ascontiguousarray(ws),
                                 np.ascontiguousarray(self.frame[:, :m]),
                                 np.ascontiguousarray(self.frame[:, m:]), state["sum"],
                                 np.ascontiguousarray(c[0]), self.kappa0, self._Vn_inv,
                                 self._Vf_inv, self._logdet_n, self._logdet_f)
        return ll, chi2

    def _run_estimated(self, state, xs, ws, c):
        m = self.degree
        N0, T0 = self.frame[:, :m], self.frame[:, m:]
        prior = self.prior_samples * (T0 @ T0.T - N0 @ N0.T)
        return _estimated_kernel(np.ascontiguousarray(xs), np.ascontiguousarray(ws),
                                 state["sx"], state["sxx"], state["sww"], state["alpha"],
                                 np.ascontiguousarray(c[0]), prior, np.ascontiguousarray(N0),
                                 np.ascontiguousarray(T0), self.kappa0, self._Vn_inv,
                                 self._Vf_inv, self._logdet_n, self._logdet_f,
                                 self.prior_samples, bool(0 < m < K and self.frame_penalty))


@numba.njit(cache=True)
def _fixed_kernel(xs, ws, Nf, Tf, sums, c0, kappa0, Vn_inv, Vf_inv, logdet_n,
                  logdet_f):  # pragma: no cover - compiled
    """:meth:`ConstraintFeature._score` of a fixed frame over samples x instances in one
    compiled pass: per sample t the motion along the normals ``z_t = N^T xs_t`` and the
    force along the free directions ``f_t = T^T ws_t``; per instance u the residual
    ``e = z_t - (sums_u + z_0 + .. + z_{t-1}) / (kappa0 + c)`` with ``c = c0_u + t``
    samples before t.  ``sums`` (U, m) is advanced in place by the chunk's total."""
    n, k = xs.shape
    U, m = sums.shape[0], Nf.shape[1]
    ll = np.empty((n, U))
    chi2 = np.empty((n, U))
    z = np.zeros(m)
    f = np.zeros(k - m)
    e = np.zeros(m)
    cz = np.zeros(m)                                     # z_0 + .. + z_{t-1}
    for t in range(n):
        for i in range(m):
            acc = 0.0
            for j in range(k):
                acc += xs[t, j] * Nf[j, i]
            z[i] = acc
        qf = 0.0
        if m < k:
            for i in range(k - m):
                acc = 0.0
                for j in range(k):
                    acc += ws[t, j] * Tf[j, i]
                f[i] = acc
            for i in range(k - m):
                for j in range(k - m):
                    qf += f[i] * Vf_inv[i, j] * f[j]
        for u in range(U):
            v = 0.0
            q = 0.0
            if m:
                cc = kappa0 + c0[u] + t
                g = 1.0 + 1.0 / cc
                for i in range(m):
                    e[i] = z[i] - (sums[u, i] + cz[i]) / cc
                for i in range(m):
                    for j in range(m):
                        q += e[i] * Vn_inv[i, j] * e[j]
                q /= g
                v -= 0.5 * (q + logdet_n + m * math.log(g) + m * LOG_2PI)
            if m < k:
                v -= 0.5 * (qf + logdet_f + (k - m) * LOG_2PI)
            ll[t, u] = v
            chi2[t, u] = q + qf
        for i in range(m):
            cz[i] += z[i]
    for u in range(U):
        for i in range(m):
            sums[u, i] += cz[i]
    return ll, chi2


@numba.njit(cache=True)
def _polar(M, Q):  # pragma: no cover - compiled
    """The orthogonal polar factor ``Q = U V^T`` of the square ``M = U S V^T`` (the orthogonal
    matrix nearest to M: the orthogonal Procrustes solution), written into ``Q``; returns
    the sum of M's singular values.  Closed forms for 1 x 1 (the sign) and 2 x 2 (the
    rotation or reflection maximising ``tr(Q^T M)``: a rotation by the angle of
    ``(a + d, c - b)`` when ``det M >= 0``, else the reflection along ``(a - d, b + c)``,
    whose lengths are then ``s1 + s2``); an SVD otherwise."""
    j = M.shape[0]
    if j == 1:
        Q[0, 0] = -1.0 if M[0, 0] < 0.0 else 1.0
        return abs(M[0, 0])
    if j == 2:
        a, b, c, d = M[0, 0], M[0, 1], M[1, 0], M[1, 1]
        if a * d - b * c >= 0.0:
            p, q = a + d, c - b
            r = math.sqrt(p * p + q * q)
            if r == 0.0:
                p, q, r = 1.0, 0.0, 1.0
            Q[0, 0], Q[0, 1], Q[1, 0], Q[1, 1] = p / r, -q / r, q / r, p / r
        else:
            p, q = a - d, b + c
            r = math.sqrt(p * p + q * q)
            Q[0, 0], Q[0, 1], Q[1, 0], Q[1, 1] = p / r, q / r, q / r, -p / r
        return r
    u, sv, vt = np.linalg.svd(M)
    Q[:, :] = u @ vt
    return sv.sum()


@numba.njit(cache=True)
def _estimated_kernel(xs, ws, sx, sxx, sww, alpha, c0, prior, N0, T0, kappa0, Vn_inv, Vf_inv,
                      logdet_n, logdet_f, a, penalty):  # pragma: no cover - compiled
    """The estimated-frame model over samples ``xs``, ``ws`` (n, 3: scaled motion and force)
    for U instances in one compiled pass.  Per instance u and sample t, from the sums of
    the instance's samples before t (``c = c0_u + t`` of them): the centred information
    ``D = S_xx - S_x S_x^T / max(c, 1) - S_ww + prior`` (8.19 with the nominal frame's
    pseudo-samples), its eigenvectors by ascending eigenvalue (8.25's closed form: the
    first m the normals), each span's basis turned onto the nominal one (orthogonal
    Procrustes, :func:`_polar`), the residuals and :meth:`ConstraintFeature._score`'s
    terms, and with ``penalty`` 8.70's term from 8.69's alpha (3 minus the singular values
    of the spans against the nominal ones: those of the Procrustes problems).  The running
    sums ``sx`` (U, 3), ``sxx``, ``sww`` (U, 3, 3) and ``alpha`` (U) advance in place."""
    n = xs.shape[0]
    U = sx.shape[0]
    m = N0.shape[1]
    kf = K - m
    ll = np.empty((n, U))
    chi2 = np.empty((n, U))
    D = np.empty((K, K))
    Mn = np.empty((m, m))
    Mt = np.empty((kf, kf))
    Qn = np.empty((m, m))
    Qt = np.empty((kf, kf))
    e = np.empty(m)
    f = np.empty(kf)
    ax = np.empty(K)
    axx = np.empty((K, K))
    aww = np.empty((K, K))
    log_a = math.log(a) if a > 0.0 else 0.0
    for u in range(U):
        for i in range(K):
            ax[i] = sx[u, i]
            for j in range(K):
                axx[i, j] = sxx[u, i, j]
                aww[i, j] = sww[u, i, j]
        prev = alpha[u]
        for t in range(n):
            c = c0[u] + t
            cc = c if c > 1.0 else 1.0
            for i in range(K):
                for j in range(K):
                    D[i, j] = axx[i, j] - ax[i] * (ax[j] / cc) - aww[i, j] + prior[i, j]
            _, R = np.linalg.eigh(D)
            sv = 0.0
            if m:
                for i in range(m):
                    for j in range(m):
                        acc = 0.0
                        for r in range(K):
                            acc += R[r, i] * N0[r, j]
                        Mn[i, j] = acc
                sv += _polar(Mn, Qn)
            if kf:
                for i in range(kf):
                    for j in range(kf):
                        acc = 0.0
                        for r in range(K):
                            acc += R[r, m + i] * T0[r, j]
                        Mt[i, j] = acc
                sv += _polar(Mt, Qt)
            v = 0.0
            ch = 0.0
            if m:
                cg = kappa0 + c
                for j in range(m):
                    acc = 0.0
                    for r in range(K):
                        nr = 0.0
                        for i in range(m):
                            nr += R[r, i] * Qn[i, j]
                        acc += (xs[t, r] - ax[r] / cg) * nr
                    e[j] = acc
                g = 1.0 + 1.0 / cg
                q = 0.0
                for i in range(m):
                    for j in range(m):
                        q += e[i] * Vn_inv[i, j] * e[j]
                q /= g
                v -= 0.5 * (q + logdet_n + m * math.log(g) + m * LOG_2PI)
                ch += q
            if kf:
                for j in range(kf):
                    acc = 0.0
                    for r in range(K):
                        tr = 0.0
                        for i in range(kf):
                            tr += R[r, m + i] * Qt[i, j]
                        acc += ws[t, r] * tr
                    f[j] = acc
                qf = 0.0
                for i in range(kf):
                    for j in range(kf):
                        qf += f[i] * Vf_inv[i, j] * f[j]
                v -= 0.5 * (qf + logdet_f + kf * LOG_2PI)
                ch += qf
            if penalty:
                al = K - sv
                v = v - a * (al - prev)
                if c == 0.0:
                    v += log_a
                prev = al
            ll[t, u] = v
            chi2[t, u] = ch
            for i in range(K):
                ax[i] += xs[t, i]
                for j in range(K):
                    axx[i, j] += xs[t, i] * xs[t, j]
                    aww[i, j] += ws[t, i] * ws[t, j]
        for i in range(K):
            sx[u, i] = ax[i]
            for j in range(K):
                sxx[u, i, j] = axx[i, j]
                sww[u, i, j] = aww[i, j]
        if penalty:
            alpha[u] = prev
    return ll, chi2
