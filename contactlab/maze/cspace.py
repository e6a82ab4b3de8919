"""The gear-shift maze of thesis 9.2 as the configuration space of a planar disc (fig 9.6).

The fingertip sphere resting on the channel floor meets a wall at the wall's top edge,
at the horizontal distance ``r = sqrt(R^2 - (R - depth)^2)`` from its centre: the planar
task is that of a disc of radius ``r`` moving in the channel polygon
(:func:`contactlab.sim.environment.maze_outline`).  Its free configuration space is the
channel eroded by ``r``: every point whose distance to the channel boundary is at least
``r``.  The boundary of that set -- the c-space surfaces -- is

- a straight **segment** for every wall: the wall moved ``r`` into the channel, with the
  wall's normal (touching the wall's interior);
- a circular **arc** of radius ``r`` about every convex corner of the channel (a reflex
  vertex of the outline, interior angle 270 deg), with normal ``(c - v) / r`` (touching
  the corner itself);
- a **concave c-space corner** where two segment surfaces meet (a 90 deg corner of the
  channel: the disc touches both walls).

The contact state of a configuration ``c`` is the set of those surfaces it lies on
(within ``tol``); a partition of c-space (5.1) is a connected set of configurations with
one contact state.  Contact partitions are the segments, arcs and corners; free space is
one contact state and is divided further by :mod:`contactlab.maze.partitions`.

Distances are exact (the distance field of a polygon), so configurations are checked and
projected without sampling the surfaces.  All functions take arrays of configurations
``(N, 2)`` and work on all of them at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from contactlab.sim import constants as C
from contactlab.sim.environment import maze_outline

__all__ = ["Surface", "MazeCSpace", "disc_radius"]

#: configurations closer than this to a c-space surface touch it, m (a contact of the
#: simulator's fingertip compresses the wall by microns: 9.2's constraints are "rigid")
TOUCH_TOL = 1e-5


def disc_radius(depth: float, radius: float = C.FINGERTIP_RADIUS) -> float:
    """Radius of the disc cut from the fingertip sphere by the channel's top plane (9.2, fig 9.6)."""
    if not 0.0 < depth < radius:
        raise ValueError(f"depth must be in (0, {radius}) m; got {depth}")
    return math.sqrt(radius**2 - (radius - depth) ** 2)


@dataclass(frozen=True)
class Surface:
    """One c-space surface.

    ``kind`` is ``"segment"`` (the offset of wall ``index``) or ``"arc"`` (about the convex
    corner ``index`` of the outline).  ``a``/``b`` are the surface's end points (CCW along
    the c-space boundary), ``normal`` the unit normal into free space at its middle.
    """

    name: str
    kind: str
    index: int
    a: tuple[float, float]
    b: tuple[float, float]
    normal: tuple[float, float]

    @property
    def length(self) -> float:
        if self.kind == "segment":
            return float(math.dist(self.a, self.b))
        return 0.0   # set by MazeCSpace (an arc's length is r * its angle)


class MazeCSpace:
    """The c-space of a disc of radius ``r`` in the maze channel (see the module docstring).

    ``outline`` defaults to :func:`maze_outline` (its dimensions are those of the simulated
    maze); ``depth`` gives ``r`` by :func:`disc_radius`.
    """

    def __init__(self, *, depth: float = 0.003, outline=None, tol: float = TOUCH_TOL):
        pts = np.asarray(outline if outline is not None else maze_outline(), float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise ValueError("outline must be a list of (x, y) corners")
        area = 0.5 * np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
        if area <= 0:
            raise ValueError("outline must be counter-clockwise")
        self.outline = pts
        self.r = disc_radius(depth)
        self.depth = depth
        self.tol = tol
        self.p0 = pts
        self.p1 = np.roll(pts, -1, axis=0)
        d = self.p1 - self.p0
        self.edge_len = np.linalg.norm(d, axis=1)
        self.dirs = d / self.edge_len[:, None]
        self.inward = np.stack([-self.dirs[:, 1], self.dirs[:, 0]], axis=1)   # into the channel
        d_in = np.roll(self.dirs, 1, axis=0)          # edge arriving at vertex k
        turn = d_in[:, 0] * self.dirs[:, 1] - d_in[:, 1] * self.dirs[:, 0]
        #: reflex vertices of the outline (a right turn of a CCW polygon): the channel's convex corners
        self.reflex = turn < 0

    # -- surfaces ---------------------------------------------------------------------
    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        """Segments (one per wall, in outline order) then arcs (one per convex corner)."""
        r, n = self.r, len(self.p0)
        out = []
        for k in range(n):
            m = self.inward[k]
            a = self.p0[k] + r * m
            b = self.p1[k] + r * m
            # a segment is trimmed by r at a concave channel corner (where the next wall stops it)
            if not self.reflex[k]:
                a = a + r * self.dirs[k]
            if not self.reflex[(k + 1) % n]:
                b = b - r * self.dirs[k]
            out.append(Surface(f"wall_{k:02d}", "segment", k, tuple(a), tuple(b), tuple(m)))
        for v in np.flatnonzero(self.reflex):
            m_in, m_out = self.inward[v - 1], self.inward[v]
            mid = (m_in + m_out) / np.linalg.norm(m_in + m_out)
            out.append(Surface(f"arc_{v:02d}", "arc", int(v), tuple(self.p0[v] + r * m_in),
                               tuple(self.p0[v] + r * m_out), tuple(mid)))
        return tuple(out)

    @property
    def n_segments(self) -> int:
        return len(self.p0)

    def surface_index(self, name: str) -> int:
        return [s.name for s in self.surfaces].index(name)

    @cached_property
    def concave_corners(self) -> np.ndarray:
        """(M, 2) c-space corners where two segment surfaces meet (a 90 deg channel corner)."""
        k = np.flatnonzero(~self.reflex)
        return self.p0[k] + self.r * (self.inward[k - 1] + self.inward[k])

    # -- distance field ---------------------------------------------------------------------
    def _edge_terms(self, c):
        """Per configuration and wall: the unclamped edge parameter t and the distance to the wall segment."""
        c = np.asarray(c, float).reshape(-1, 2)
        rel = c[:, None, :] - self.p0[None, :, :]                      # (N, E, 2)
        t = np.einsum("nek,ek->ne", rel, self.dirs) / self.edge_len    # (N, E)
        tc = np.clip(t, 0.0, 1.0)
        q = self.p0[None] + tc[..., None] * (self.p1 - self.p0)[None]
        dist = np.linalg.norm(c[:, None, :] - q, axis=2)
        return c, t, q, dist

    def inside(self, c) -> np.ndarray:
        """(N,) whether each point lies inside the channel polygon (even-odd rule)."""
        c = np.asarray(c, float).reshape(-1, 2)
        x, y = c[:, 0:1], c[:, 1:2]
        x0, y0, x1, y1 = self.p0[:, 0], self.p0[:, 1], self.p1[:, 0], self.p1[:, 1]
        crosses = ((y0 > y) != (y1 > y)) & (x < x0 + (y - y0) * (x1 - x0) / np.where(y1 != y0, y1 - y0, 1.0))
        return (np.count_nonzero(crosses, axis=1) % 2) == 1

    def clearance(self, c) -> np.ndarray:
        """(N,) signed distance from each configuration to the c-space boundary, m: the distance
        from the disc's centre to the channel boundary minus ``r`` (negative outside the channel
        or overlapping a wall)."""
        c, _, _, dist = self._edge_terms(c)
        d = dist.min(axis=1)
        return np.where(self.inside(c), d, -d) - self.r

    def is_free(self, c) -> np.ndarray:
        """(N,) whether the disc at ``c`` lies in the channel without overlapping a wall (within ``tol``)."""
        return self.clearance(c) >= -self.tol

    def contacts(self, c) -> np.ndarray:
        """(N, S) boolean: which c-space surfaces (:attr:`surfaces` order) each configuration touches.

        A wall's segment is touched when the disc is within ``tol`` of the wall's interior; a
        convex corner's arc when it is within ``tol`` of the corner and beyond both adjacent
        walls' ends."""
        c, t, _, dist = self._edge_terms(c)
        near = dist <= self.r + self.tol
        seg = near & (t > 0.0) & (t < 1.0)
        rv = np.flatnonzero(self.reflex)
        dv = np.linalg.norm(c[:, None, :] - self.p0[None, rv, :], axis=2)
        arc = (dv <= self.r + self.tol) & (t[:, rv - 1] >= 1.0) & (t[:, rv] <= 0.0)
        return np.concatenate([seg, arc], axis=1)

    def contact_bits(self, c) -> np.ndarray:
        """(N,) int64: :meth:`contacts` as bit masks (bit k = surface k), compiled, for long traces."""
        c = np.ascontiguousarray(np.asarray(c, float).reshape(-1, 2))
        return _contact_bits(c, np.ascontiguousarray(self.p0), np.ascontiguousarray(self.dirs),
                             np.ascontiguousarray(self.edge_len), np.flatnonzero(self.reflex),
                             float(self.r), float(self.tol))

    def project(self, c, *, iterations: int = 4):
        """Push configurations that overlap the walls back onto the c-space boundary.

        Returns ``(c', normals, depth)``: the projected configurations, and per wall the unit
        push direction and the overlap removed (0 where none), each ``(N, E, 2)`` / ``(N, E)``
        summed over the iterations (a concave corner needs two pushes)."""
        c = np.array(c, float).reshape(-1, 2)
        n_e = self.n_segments
        pushed = np.zeros((len(c), n_e))
        normals = np.zeros((len(c), n_e, 2))
        for _ in range(iterations):
            c, _, q, dist = self._edge_terms(c)
            over = self.r - dist
            hit = over > 0
            if not hit.any():
                break
            k = np.argmax(np.where(hit, over, -np.inf), axis=1)
            rows = np.flatnonzero(hit.any(axis=1))
            kk = k[rows]
            away = c[rows] - q[rows, kk]
            nrm = np.linalg.norm(away, axis=1)
            u = np.where(nrm[:, None] > 1e-15, away / np.maximum(nrm, 1e-15)[:, None], self.inward[kk])
            c[rows] += over[rows, kk][:, None] * u
            pushed[rows, kk] += over[rows, kk]
            normals[rows, kk] = u
        return c, normals, pushed


@numba.njit(cache=True)
def _contact_bits(c, p0, dirs, elen, reflex_idx, r, tol):  # pragma: no cover
    n, n_e = c.shape[0], p0.shape[0]
    out = np.zeros(n, np.int64)
    t = np.empty(n_e)
    for i in range(n):
        bits = 0
        for e in range(n_e):
            te = ((c[i, 0] - p0[e, 0]) * dirs[e, 0] + (c[i, 1] - p0[e, 1]) * dirs[e, 1]) / elen[e]
            t[e] = te
            tc = min(max(te, 0.0), 1.0)
            qx = p0[e, 0] + tc * elen[e] * dirs[e, 0]
            qy = p0[e, 1] + tc * elen[e] * dirs[e, 1]
            if 0.0 < te < 1.0 and math.hypot(c[i, 0] - qx, c[i, 1] - qy) <= r + tol:
                bits |= 1 << e
        for j in range(reflex_idx.shape[0]):
            v = reflex_idx[j]
            if (math.hypot(c[i, 0] - p0[v, 0], c[i, 1] - p0[v, 1]) <= r + tol
                    and t[(v - 1) % n_e] >= 1.0 and t[v] <= 0.0):
                bits |= 1 << (n_e + j)
        out[i] = bits
    return out
