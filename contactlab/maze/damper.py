"""The robot as a generalized damper with Coulomb friction in the maze's c-space (9.2).

9.2: "A simulation of the robot as a generalized damper with friction could be used to
compute the transition graph."  Under integral force control (9.1.2, a generalized damper,
fig 9.3) the fingertip's velocity is proportional to the net planar force on it,
``b v = F + sum_k lambda_k n_k + f_k`` (5.11 without its disturbance), with contact forces
``lambda_k >= 0`` along the c-space normals ``n_k`` and friction ``|f_k| <= mu lambda_k``
against the sliding direction.  On a flat contact this is the quasi-static law
``v_t = (F_t - mu |F_n|) / b`` when ``|F_t| > mu |F_n|``, else ``v = 0`` (sticking).

It is integrated in position steps: the free step ``h F / |F|`` (``h`` the free-space
distance per step), the overlap with the walls removed along their normals
(:meth:`MazeCSpace.project` -- the normal force times ``dt / b``), then the tangential
part of the step reduced by ``mu`` times that overlap (the friction impulse; all of it when
the step lies inside the friction cone).  For one flat contact the step equals the
quasi-static law above exactly; at a concave corner both walls push.  Every sample runs at
once (arrays over samples), so thousands of trajectories cost one loop over time steps.
"""

from __future__ import annotations

import numpy as np

from contactlab.maze.cspace import MazeCSpace

__all__ = ["damper_paths", "LEXAN_MU"]

#: Lexan (polycarbonate) on the steel fingertip shell, kinetic (contactlab.sim.materials "lexan")
LEXAN_MU = 0.27


def damper_paths(cspace: MazeCSpace, starts, angles, *, steps: int, step_m: float = 2.5e-4,
                 mu: float = LEXAN_MU, angle_noise=None, rng=None) -> np.ndarray:
    """Trajectories of the generalized damper from ``starts`` ((N, 2), m) under planar force
    directions ``angles`` ((N,), rad, counter-clockwise from +x): ``(steps + 1, N, 2)``.

    ``angle_noise`` (rad, optional) adds an independent normal turn of the force at every step
    (the control disturbance dv of 5.11); ``rng`` draws it."""
    c = np.array(starts, float).reshape(-1, 2)
    ang = np.broadcast_to(np.asarray(angles, float), (len(c),))
    out = np.empty((steps + 1, len(c), 2))
    out[0] = c
    rng = rng if rng is not None else np.random.default_rng(0)
    for k in range(steps):
        a = ang if not angle_noise else ang + rng.normal(0.0, angle_noise, len(c))
        step = step_m * np.stack([np.cos(a), np.sin(a)], axis=1)
        trial, normals, pushed = cspace.project(c + step)
        moved = trial - c
        if pushed.any():
            # friction: the tangential part of the step, per touched wall, shrinks by mu * overlap
            for_wall = pushed > 0
            n_w = np.where(for_wall[..., None], normals, 0.0)
            # the contact normal of the deepest push governs (one wall, or a corner's two in turn)
            k_w = np.argmax(pushed, axis=1)
            rows = np.flatnonzero(for_wall.any(axis=1))
            n = n_w[rows, k_w[rows]]
            lam = mu * pushed[rows].sum(axis=1)
            mv = moved[rows]
            tang = mv - np.sum(mv * n, axis=1, keepdims=True) * n
            tl = np.linalg.norm(tang, axis=1)
            keep = np.clip(1.0 - lam / np.maximum(tl, 1e-30), 0.0, 1.0)
            trial[rows] = c[rows] + mv - (1.0 - keep)[:, None] * tang
            trial = cspace.project(trial)[0]
        c = trial
        out[k + 1] = c
    return out
