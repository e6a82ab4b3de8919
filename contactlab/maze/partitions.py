"""Partitions of the maze's c-space (thesis 5.1, 5.3.3, 9.2, fig 9.7).

Contact partitions are the sets of configurations with one contact state
(:meth:`MazeCSpace.contacts`): each wall's segment surface, each convex corner's arc and
each concave c-space corner (two walls at once).  Free space -- one contact state -- is
divided by back-projection as 5.3.3 prescribes: two free configurations are *equivalent
under an action* when they reach the same contact partitions.  For the damper of
:mod:`contactlab.maze.damper` free motion is a straight line along the command, so the
partition a free configuration reaches under action ``a`` is where the ray from it along
``a`` first meets the c-space boundary; the index set of 5.3.3 for the eight commands is the
8-tuple of those first contacts.  Free partitions are the connected sets of grid cells with
one 8-tuple; sets smaller than ``min_area`` (9 mm^2, the 3 mm square in which a trial's
start is placed -- datasets_spec/maze.toml -- so smaller sets cannot be aimed at; slivers along the boundaries between
back-projections, where a shift of a fraction of a millimetre changes the wall reached)
join the neighbour they share the longest border with -- our counterpart of 9.2's
"the back-projections were computed and then heuristically unified into a fixed set of
partitions".

Numbering: contact partitions first (segments in outline order, then arcs, then concave
corners), then free partitions by decreasing area; numbers start at 1 like fig 9.7's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from contactlab.maze.cspace import MazeCSpace

__all__ = ["ACTION_ANGLES_DEG", "Partition", "MazePartitions", "build_partitions"]

#: the eight force commands (9.2, fig 9.7): action k points k x 45 deg counter-clockwise from
#: +x (datasets_spec/maze.toml: action 1 = +x+y, action 5 = -x-y)
ACTION_ANGLES_DEG = {k: 45.0 * k for k in range(1, 9)}


@dataclass(frozen=True)
class Partition:
    """One c-space partition: its number, kind (``free``, ``segment``, ``arc``, ``corner``),
    the surfaces it touches (indices into ``MazeCSpace.surfaces``) and a representative point."""

    number: int
    kind: str
    surfaces: tuple[int, ...]
    point: tuple[float, float]
    area_m2: float = 0.0

    @property
    def name(self) -> str:
        return str(self.number)


@dataclass
class MazePartitions:
    """All partitions plus the free-space label grid (``labels[iy, ix]``: partition number,
    0 outside free space) on the grid ``x0 + ix * cell``, ``y0 + iy * cell``."""

    cspace: MazeCSpace
    partitions: list[Partition]
    labels: np.ndarray
    x0: float
    y0: float
    cell: float
    _by_surfaces: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        self._by_surfaces = {p.surfaces: p.number for p in self.partitions if p.kind != "free"}
        # every grid cell, also outside free space, maps to its nearest free partition
        free = self.labels > 0
        _, idx = ndimage.distance_transform_edt(~free, return_indices=True)
        self._nearest = self.labels[idx[0], idx[1]]

    def _from_bits(self, bits: np.ndarray) -> np.ndarray:
        """Partition numbers of contact bit masks (0: no contact); a combination no partition
        has (not produced by the channel's geometry) takes its lowest surface's partition."""
        keys, inv = np.unique(bits, return_inverse=True)
        nums = np.zeros(len(keys), np.int64)
        for k, b in enumerate(keys.tolist()):
            if b:
                key = tuple(i for i in range(b.bit_length()) if b >> i & 1)
                nums[k] = self._by_surfaces.get(key, self._by_surfaces.get(key[:1], 0))
        return nums[inv.ravel()]

    def __len__(self) -> int:
        return len(self.partitions)

    def by_number(self, number: int) -> Partition:
        return self.partitions[number - 1]

    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for p in self.partitions:
            out[p.kind] = out.get(p.kind, 0) + 1
        return out

    def classify(self, c) -> np.ndarray:
        """(N,) partition number of each configuration ((N, 2), m)."""
        c = np.asarray(c, float).reshape(-1, 2)
        bits = self.cspace.contact_bits(c)
        out = self._from_bits(bits)
        any_touch = bits != 0
        free = ~any_touch
        ix = np.clip(np.rint((c[free, 0] - self.x0) / self.cell).astype(np.int64), 0, self.labels.shape[1] - 1)
        iy = np.clip(np.rint((c[free, 1] - self.y0) / self.cell).astype(np.int64), 0, self.labels.shape[0] - 1)
        out[free] = self._nearest[iy, ix]
        return out

    def sample(self, number: int, n: int, rng) -> np.ndarray:
        """``n`` configurations drawn uniformly from partition ``number`` ((n, 2), m)."""
        p = self.by_number(number)
        cs = self.cspace
        if p.kind == "free":
            iy, ix = np.nonzero(self.labels == number)
            k = rng.integers(0, len(ix), n)
            jitter = rng.uniform(-0.5, 0.5, (n, 2)) * self.cell
            pts = np.stack([self.x0 + ix[k] * self.cell, self.y0 + iy[k] * self.cell], axis=1) + jitter
            # keep samples strictly inside free space (a jittered cell near a wall may overlap it)
            return cs.project(pts)[0]
        if p.kind == "corner":
            return np.repeat(np.asarray(p.point, float)[None], n, axis=0)
        s = cs.surfaces[p.surfaces[0]]
        if s.kind == "segment":
            u = rng.uniform(0.02, 0.98, n)[:, None]
            return np.asarray(s.a)[None] + u * (np.asarray(s.b) - np.asarray(s.a))[None]
        v = cs.p0[s.index]
        a0 = math.atan2(*(np.asarray(s.a) - v)[::-1])
        a1 = math.atan2(*(np.asarray(s.b) - v)[::-1])
        da = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
        ang = a0 + rng.uniform(0.02, 0.98, n) * da
        return v[None] + cs.r * np.stack([np.cos(ang), np.sin(ang)], axis=1)


def first_contacts(cspace: MazeCSpace, starts, angle_rad: float, *, min_step: float = 2.5e-4,
                   max_iter: int = 2000) -> np.ndarray:
    """Where rays from free ``starts`` along ``angle_rad`` first meet the c-space boundary
    ((N, 2), m): sphere tracing on the exact clearance, finished by a projection."""
    c = np.array(starts, float).reshape(-1, 2)
    d = np.array([math.cos(angle_rad), math.sin(angle_rad)])
    active = np.ones(len(c), bool)
    for _ in range(max_iter):
        if not active.any():
            break
        rows = np.flatnonzero(active)
        gap = cspace.clearance(c[rows])
        done = gap <= cspace.tol
        active[rows[done]] = False
        rows = rows[~done]
        c[rows] += np.maximum(gap[~done], min_step)[:, None] * d
        c[rows] = cspace.project(c[rows])[0]
    return c


def _lookup(touch: np.ndarray, table: dict) -> np.ndarray:
    """Partition number of each row of a contact matrix (0: no contact).  A combination no
    partition has (not produced by the channel's geometry) takes its first surface's partition."""
    keys, inv = np.unique(touch, axis=0, return_inverse=True)
    nums = np.zeros(len(keys), np.int64)
    for k, row in enumerate(keys):
        key = tuple(np.flatnonzero(row).tolist())
        if key:
            nums[k] = table.get(key, table.get(key[:1], 0))
    return nums[inv.ravel()]


def _contact_partitions(cspace: MazeCSpace) -> list[Partition]:
    parts = []
    for k, s in enumerate(cspace.surfaces):
        mid = 0.5 * (np.asarray(s.a) + np.asarray(s.b))
        if s.kind == "arc":
            v = cspace.p0[s.index]
            mid = v + cspace.r * np.asarray(s.normal)
        parts.append(Partition(len(parts) + 1, s.kind, (k,), tuple(float(x) for x in mid)))
    n_e = cspace.n_segments
    for v in np.flatnonzero(~cspace.reflex):
        pair = tuple(sorted(((v - 1) % n_e, v)))
        pt = cspace.p0[v] + cspace.r * (cspace.inward[v - 1] + cspace.inward[v])
        parts.append(Partition(len(parts) + 1, "corner", pair, tuple(float(x) for x in pt)))
    return parts


def build_partitions(cspace: MazeCSpace | None = None, *, cell: float = 5e-4,
                     min_area: float = 9e-6) -> MazePartitions:
    """The partitions of the maze's c-space (see the module docstring); ``cell`` is the grid
    spacing of free space (m), ``min_area`` (m^2) the smallest free partition kept apart."""
    cs = cspace if cspace is not None else MazeCSpace()
    contact = _contact_partitions(cs)
    lookup = {p.surfaces: p.number for p in contact}
    lo = cs.outline.min(axis=0)
    hi = cs.outline.max(axis=0)
    xs = np.arange(lo[0], hi[0] + cell / 2, cell)
    ys = np.arange(lo[1], hi[1] + cell / 2, cell)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    free = cs.clearance(pts) > cs.tol
    fp = pts[free]
    sig = np.zeros((len(fp), len(ACTION_ANGLES_DEG)), np.int64)
    for j, (_, deg) in enumerate(sorted(ACTION_ANGLES_DEG.items())):
        hit = first_contacts(cs, fp, math.radians(deg))
        sig[:, j] = _lookup(cs.contacts(hit), lookup)
    _, code = np.unique(sig, axis=0, return_inverse=True)
    codes = np.full(gx.shape, -1, np.int64)
    codes.ravel()[np.flatnonzero(free)] = code.ravel()
    # connected sets of one index set
    comp = np.zeros(gx.shape, np.int64)
    n_comp = 0
    for k in np.unique(code):
        lab, n = ndimage.label(codes == k)
        comp[lab > 0] = lab[lab > 0] + n_comp
        n_comp += n
    comp = _merge_small(comp, int(math.ceil(min_area / cell**2)))
    ids, sizes = np.unique(comp[comp > 0], return_counts=True)
    order = ids[np.argsort(-sizes, kind="stable")]
    labels = np.zeros_like(comp)
    parts = list(contact)
    for k in order:
        num = len(parts) + 1
        mask = comp == k
        labels[mask] = num
        iy, ix = np.nonzero(mask)
        # representative point: the cell nearest the centroid
        cx, cy = ix.mean(), iy.mean()
        j = int(np.argmin((ix - cx) ** 2 + (iy - cy) ** 2))
        parts.append(Partition(num, "free", (), (float(xs[ix[j]]), float(ys[iy[j]])),
                               float(mask.sum() * cell**2)))
    return MazePartitions(cs, parts, labels, float(xs[0]), float(ys[0]), cell)


def _merge_small(comp: np.ndarray, min_cells: int) -> np.ndarray:
    """Join components smaller than ``min_cells`` to the neighbour sharing the longest border
    (a small component with no free neighbour stays)."""
    comp = comp.copy()
    kept: set[int] = set()
    while True:
        ids, sizes = np.unique(comp[comp > 0], return_counts=True)
        sel = (sizes < min_cells) & ~np.isin(ids, list(kept))
        if not sel.any():
            return comp
        k = ids[sel][np.argmin(sizes[sel])]
        mask = comp == k
        ring = ndimage.binary_dilation(mask) & ~mask & (comp > 0)
        if not ring.any():
            kept.add(int(k))
            continue
        nb, cnt = np.unique(comp[ring], return_counts=True)
        comp[mask] = nb[np.argmax(cnt)]
