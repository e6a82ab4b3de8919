"""The robot as a generalized damper with Coulomb friction in the maze's c-space (9.2).

9.2: "A simulation of the robot as a generalized damper with friction could be used to
compute the transition graph."  Under integral force control (9.1.2, a generalized damper,
fig 9.3) the fingertip's velocity is proportional to the net planar force on it,
``b v = F + sum_k lambda_k n_k + f_k`` (5.11 without its disturbance), with contact forces
``lambda_k >= 0`` along the c-space normals ``n_k`` and friction ``|f_k| <= mu lambda_k``
against the sliding direction.  On a flat contact this is the quasi-static law
``v_t = (F_t - mu |F_n|) / b`` when ``|F_t| > mu |F_n|``, else ``v = 0`` (sticking).

It is integrated in position steps: the free step ``h F / |F|`` (``h`` the free-space
distance per step) is projected onto free space (:meth:`MazeCSpace.project`); the overlap
removed along the normal of the wall pushed hardest is the normal force times ``dt / b``,
so the free step's tangential part along that wall shrinks by ``mu`` times it (the friction
impulse; all of it when the step lies inside the friction cone) and the reduced step is
projected again.  For one flat contact the step equals the
quasi-static law above exactly; at a concave corner both walls push.  The loop over
samples and steps is compiled (numba): 24 000 trajectories of 600 steps take seconds.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contactlab.maze.cspace import MazeCSpace

__all__ = ["damper_paths", "LEXAN_MU"]

#: Lexan (polycarbonate) on the steel fingertip shell, kinetic (contactlab.sim.materials "lexan")
LEXAN_MU = 0.27
#: consecutive steps without motion after which a trajectory is at rest for good
REST_STEPS = 3


@numba.njit(cache=True)
def _project_one(cx, cy, p0, dirs, elen, r, iters, push_w, nrm_w):  # pragma: no cover
    """:meth:`MazeCSpace.project` for one configuration, accumulating per-wall pushes."""
    n_e = p0.shape[0]
    for _ in range(iters):
        best, kb, qx_b, qy_b = 0.0, -1, 0.0, 0.0
        for e in range(n_e):
            t = ((cx - p0[e, 0]) * dirs[e, 0] + (cy - p0[e, 1]) * dirs[e, 1]) / elen[e]
            t = min(max(t, 0.0), 1.0)
            qx = p0[e, 0] + t * elen[e] * dirs[e, 0]
            qy = p0[e, 1] + t * elen[e] * dirs[e, 1]
            over = r - math.hypot(cx - qx, cy - qy)
            if over > best:
                best, kb, qx_b, qy_b = over, e, qx, qy
        if kb < 0:
            break
        ax, ay = cx - qx_b, cy - qy_b
        nn = math.hypot(ax, ay)
        if nn > 1e-15:
            ux, uy = ax / nn, ay / nn
        else:
            ux, uy = -dirs[kb, 1], dirs[kb, 0]
        cx += best * ux
        cy += best * uy
        push_w[kb] += best
        nrm_w[kb, 0] = ux
        nrm_w[kb, 1] = uy
    return cx, cy


@numba.njit(cache=True)
def _damper_kernel(starts, angles, steps, step_m, mu, p0, dirs, elen, r, rest_steps, iters):  # pragma: no cover
    n = starts.shape[0]
    n_e = p0.shape[0]
    out = np.empty((steps + 1, n, 2))
    push_w = np.zeros(n_e)
    nrm_w = np.zeros((n_e, 2))
    for s in range(n):
        cx, cy = starts[s, 0], starts[s, 1]
        out[0, s, 0] = cx
        out[0, s, 1] = cy
        sx, sy = step_m * math.cos(angles[s]), step_m * math.sin(angles[s])
        still = 0
        for k in range(steps):
            if still >= rest_steps:
                out[k + 1, s, 0] = cx
                out[k + 1, s, 1] = cy
                continue
            push_w[:] = 0.0
            tx, ty = _project_one(cx + sx, cy + sy, p0, dirs, elen, r, iters, push_w, nrm_w)
            kb = -1
            for e in range(n_e):
                if push_w[e] > 0.0 and (kb < 0 or push_w[e] > push_w[kb]):
                    kb = e
            if kb >= 0:
                # Coulomb friction on the wall pushed hardest: the free step's tangential part
                # shrinks by mu times the normal push (all of it inside the friction cone);
                # the step is then projected again (a second wall stops what remains)
                nx, ny = nrm_w[kb, 0], nrm_w[kb, 1]
                dn = sx * nx + sy * ny
                tgx, tgy = sx - dn * nx, sy - dn * ny
                tl = math.hypot(tgx, tgy)
                keep = 1.0 - mu * push_w[kb] / max(tl, 1e-30)
                keep = min(max(keep, 0.0), 1.0)
                push_w[:] = 0.0
                tx, ty = _project_one(cx + sx - (1.0 - keep) * tgx, cy + sy - (1.0 - keep) * tgy,
                                      p0, dirs, elen, r, iters, push_w, nrm_w)
            if math.hypot(tx - cx, ty - cy) < 1e-9 * step_m:
                still += 1
            else:
                still = 0
            cx, cy = tx, ty
            out[k + 1, s, 0] = cx
            out[k + 1, s, 1] = cy
    return out


def damper_paths(cspace: MazeCSpace, starts, angles, *, steps: int, step_m: float = 2.5e-4,
                 mu: float = LEXAN_MU) -> np.ndarray:
    """Trajectories of the generalized damper from ``starts`` ((N, 2), m) under planar force
    directions ``angles`` ((N,), rad, counter-clockwise from +x): ``(steps + 1, N, 2)``.

    Compiled (numba), one sample after another; a trajectory at rest for ``REST_STEPS``
    steps (stuck in a friction cone or a corner) stays there, as the damper without a
    disturbance would never move it again."""
    c = np.ascontiguousarray(np.asarray(starts, float).reshape(-1, 2))
    ang = np.ascontiguousarray(np.broadcast_to(np.asarray(angles, float), (len(c),)))
    return _damper_kernel(c, ang, int(steps), float(step_m), float(mu),
                          np.ascontiguousarray(cspace.p0), np.ascontiguousarray(cspace.dirs),
                          np.ascontiguousarray(cspace.edge_len), float(cspace.r), REST_STEPS, 4)
