"""Planar contact measurements of damper traces and the maze graph's node likelihoods.

A stand-in for the wrench-and-position signals when following the maze over its generated
graph without the simulator: each step of a damper trajectory
(:func:`contactlab.maze.damper_paths`) is measured as

- the contact normal in the plane (the unit normal of the touched c-space surface, the
  normalised sum at a concave corner, zero in free space: the direction of the constraint
  force that a constraint model of 8.1 estimates), with normal noise ``normal_sd`` per axis;
- the speed as a fraction of the free speed, with normal noise ``speed_sd``.

A node's log-likelihood is its constraint part (normal ~ N(node normal, (normal_sd^2 +
spread^2) I), ``spread`` the range of normals over an arc) plus its velocity part (9.1.1:
fixed ~ N(0, speed_sd^2); moving ~ uniform on [``MOVING_MIN``, 1] measured with the same
noise).  An impact node scores as the moving node of the partition it enters.  The noise
levels are chosen, not the thesis's (its signals are wrenches; see the maze report).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import log_ndtr

from contactlab.maze.partitions import MazePartitions

__all__ = ["contact_normals", "measure", "node_loglik", "NORMAL_SD", "SPEED_SD"]

NORMAL_SD = 0.2        # per axis, unit normal (about 11 deg)
SPEED_SD = 0.05        # fraction of the free speed
ARC_SPREAD = 0.4       # sd of an arc's normal about its middle one (a quarter circle)
MOVING_MIN = 0.05      # slowest "moving" speed, fraction of the free speed (MOVING_FRACTION)


def contact_normals(parts: MazePartitions, c) -> np.ndarray:
    """(N, 2) the planar contact normal at each configuration (0 in free space)."""
    cs = parts.cspace
    c = np.asarray(c, float).reshape(-1, 2)
    bits = cs.contact_bits(c)
    out = np.zeros_like(c)
    for k, s in enumerate(cs.surfaces):
        on = (bits >> k) & 1 == 1
        if not on.any():
            continue
        if s.kind == "segment":
            out[on] += np.asarray(s.normal)
        else:
            d = c[on] - cs.p0[s.index]
            out[on] += d / np.linalg.norm(d, axis=1, keepdims=True)
    nrm = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, nrm, out=np.zeros_like(out), where=nrm > 0)


def measure(parts: MazePartitions, path: np.ndarray, step_m: float, rng, *,
            every: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Noisy ``(normals (T, 2), speeds (T,))`` of one trajectory ``(steps + 1, 2)`` sampled
    every ``every`` steps, and the true partition of each sample."""
    p = path[::every]
    speed = np.concatenate([[0.0], np.linalg.norm(np.diff(p, axis=0), axis=1) / (every * step_m)])
    n = contact_normals(parts, p)
    return (n + rng.normal(0.0, NORMAL_SD, n.shape), speed + rng.normal(0.0, SPEED_SD, len(p)),
            parts.classify(p))


def _node_normals(parts: MazePartitions):
    """Per partition (index = number - 1): mean normal and its spread."""
    cs = parts.cspace
    mean = np.zeros((len(parts), 2))
    spread = np.zeros(len(parts))
    for p in parts.partitions:
        if not p.surfaces:
            continue
        v = sum(np.asarray(cs.surfaces[k].normal) for k in p.surfaces)
        mean[p.number - 1] = v / np.linalg.norm(v)
        spread[p.number - 1] = ARC_SPREAD if cs.surfaces[p.surfaces[0]].kind == "arc" else 0.0
    return mean, spread


def node_loglik(graph, fp_partitions: MazePartitions, normals, speeds) -> np.ndarray:
    """(T, K) log-likelihood of every node of the maze ``graph`` (names: the node numbers of
    :mod:`contactlab.maze.projection`) for one run's measurements."""
    P = len(fp_partitions)
    mean, spread = _node_normals(fp_partitions)
    nums = np.array([int(n) for n in graph.node_names])
    part = np.where(nums <= P, nums, np.where(nums <= 2 * P, nums - P, nums - 2 * P)) - 1
    moving = nums > P
    var = NORMAL_SD**2 + spread[part] ** 2                                   # (K,)
    d2 = np.sum((np.asarray(normals)[:, None, :] - mean[part][None]) ** 2, axis=2)
    ll_c = -d2 / (2 * var) - np.log(2 * math.pi * var)
    v = np.asarray(speeds)[:, None]
    ll_f = -0.5 * (v / SPEED_SD) ** 2 - math.log(math.sqrt(2 * math.pi) * SPEED_SD)
    # uniform on [MOVING_MIN, 1] convolved with N(0, SPEED_SD^2)
    ll_m = np.log(np.maximum(np.exp(log_ndtr((1.0 - v) / SPEED_SD))
                             - np.exp(log_ndtr((MOVING_MIN - v) / SPEED_SD)), 1e-300)) - math.log(1 - MOVING_MIN)
    return ll_c + np.where(moving[None], ll_m, ll_f)
