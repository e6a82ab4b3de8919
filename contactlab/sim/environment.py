"""Geometry of the world the fingertip touches.

Every environment is a set of fixed, possibly bounded, planes.  A plane has an
outward unit normal ``n`` (pointing into free space), an offset ``d`` (points p
of the plane satisfy n.p = d), an in-plane texture axis ``u`` (s1 = u.p, s2 =
(n x u).p are the texture coordinates), a material on each side of a split
line s1 = ``split`` (two-texture samples), and an axis-aligned box that the
contact point must lie in (a block's face, a sample's extent).  Leaving the box
while pressed is an abrupt loss of contact (thesis 4.52).

Builders (all distances in m, the fingertip centre starts near the origin):

- :func:`free_space`
- :func:`plane`           horizontal plane z = height
- :func:`wall`            plane + one vertical wall (a line contact, XZ or YZ)
- :func:`corner`          plane + two walls at configurable angles (fig 9.2)
- :func:`block`           plane + a block with a vertical face, for impacts
- :func:`sample_a`, :func:`sample_b`  the two-texture samples of 7.2
- :func:`maze`            the gear-shift H maze with a tail of 9.2 (fig 9.6)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from contactlab.sim import constants as C
from contactlab.sim.materials import Material, evaluate_texture, get_material, texture_modes

INCH = 0.0254
_BIG = 1e9
_WALL_BAND = 1e-3   # maze walls: half-width of the contact-point band about the wall line, m


# the columns of a plane's row in ``Environment.pack()["geo"]`` (a (3,) vector starts at its
# constant) and of a material's row in ``props``: what the compiled integrator reads
GEO_NORMAL = 0        # unit normal (3,)
GEO_OFFSET = 3        # normal . x of the plane
GEO_U = 4             # first in-plane axis (3,): surface coordinate s1
GEO_V = 7             # second in-plane axis normal x u (3,): s2
GEO_LOWER = 10        # lower corner of the plane's extent (3,)
GEO_UPPER = 13        # upper corner (3,)
GEO_SPLIT = 16        # s1 where the second material starts
GEO_EDGE = 17         # width of the texture-boundary blend
GEO_COLUMNS = 19
PROP_HERTZ = 0        # Hertz constant k_h of the fingertip on the material
PROP_ALPHA = 1        # Hunt-Crossley damping alpha
PROP_MU_STATIC = 2
PROP_MU_KINETIC = 3


@dataclass(frozen=True)
class Plane:
    """A fixed plane surface.  See the module docstring for the fields."""

    name: str
    normal: tuple[float, float, float]
    offset: float
    u_axis: tuple[float, float, float]
    material: str | Material
    material_b: str | Material | None = None
    split: float = _BIG
    lower: tuple[float, float, float] = (-_BIG, -_BIG, -_BIG)
    upper: tuple[float, float, float] = (_BIG, _BIG, _BIG)

    def __post_init__(self):
        n = np.asarray(self.normal, float)
        u = np.asarray(self.u_axis, float)
        if abs(np.linalg.norm(n) - 1.0) > 1e-9 or abs(np.linalg.norm(u) - 1.0) > 1e-9 or abs(n @ u) > 1e-9:
            raise ValueError(f"plane {self.name!r}: normal and u_axis must be orthonormal")


@dataclass(frozen=True)
class Environment:
    """A named set of planes plus the seed of their textures.

    ``texture_seed`` fixes the surface microgeometry: the same seed is the same
    physical sample, so repeated trials stroke the same texture.
    """

    name: str
    planes: tuple[Plane, ...] = ()
    texture_seed: int = 0
    start: tuple[float, float, float] = (0.0, 0.0, 0.02)
    _cache: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def surface_names(self) -> list[str]:
        return [p.name for p in self.planes]

    @property
    def materials(self) -> list[Material]:
        """Distinct materials, in the order of their integer ids in the packed arrays."""
        mats: list[Material] = []
        for p in self.planes:
            for m in (p.material, p.material_b if p.material_b is not None else p.material):
                m = get_material(m)
                if m.name not in [x.name for x in mats]:
                    mats.append(m)
        return mats

    def material_id(self, m) -> int:
        return [x.name for x in self.materials].index(get_material(m).name)

    def pack(self, radius: float = C.FINGERTIP_RADIUS) -> dict[str, np.ndarray]:
        """Plane and material tables as flat arrays for the compiled integrator."""
        key = ("pack", radius)
        if key in self._cache:
            return self._cache[key]
        n_p = len(self.planes)
        geo = np.zeros((max(n_p, 1), GEO_COLUMNS))
        mat_ids = np.zeros((max(n_p, 1), 2), np.int64)
        for i, p in enumerate(self.planes):
            n = np.asarray(p.normal, float)
            u = np.asarray(p.u_axis, float)
            geo[i, GEO_NORMAL:GEO_NORMAL + 3] = n
            geo[i, GEO_OFFSET] = p.offset
            geo[i, GEO_U:GEO_U + 3] = u
            geo[i, GEO_V:GEO_V + 3] = np.cross(n, u)
            geo[i, GEO_LOWER:GEO_LOWER + 3] = p.lower
            geo[i, GEO_UPPER:GEO_UPPER + 3] = p.upper
            geo[i, GEO_SPLIT] = p.split
            mat_ids[i, 0] = self.material_id(p.material)
            mat_ids[i, 1] = self.material_id(p.material_b if p.material_b is not None else p.material)
        mats = self.materials or [get_material("polished_aluminium")]
        props = np.array([[m.hertz_constant(radius), m.hunt_crossley_alpha, m.mu_static, m.mu_kinetic]
                          for m in mats])
        modes = [texture_modes(m, seed=self.texture_seed, radius=radius) for m in mats]
        tex = {k: np.stack([md[k] for md in modes]) for k in modes[0]}
        for i in range(n_p):
            # texture-boundary blend width (constants.TEXTURE_EDGE_MIN_WIDTH)
            step = sum(float(np.sum(np.abs(tex["h_amp"][mat_ids[i, side]])))
                       + float(np.max(np.abs(tex["e_tab"][mat_ids[i, side]]))) for side in (0, 1))
            geo[i, GEO_EDGE] = max(math.sqrt(18.0 * radius * step), C.TEXTURE_EDGE_MIN_WIDTH)
        out = dict(geo=geo, mat_ids=mat_ids, n_planes=n_p, props=props, **tex)
        self._cache[key] = out
        return out

    # ---- python-side geometry helpers (used by tests and ground truth) ----
    def signed_distances(self, center, radius: float = C.FINGERTIP_RADIUS) -> np.ndarray:
        """Gap between the fingertip sphere and each (unbounded) plane, m (negative = penetrating)."""
        c = np.asarray(center, float)
        return np.array([np.asarray(p.normal) @ c - p.offset - radius for p in self.planes])

    def normals(self) -> np.ndarray:
        return np.array([p.normal for p in self.planes], float).reshape(-1, 3)

    def texture_under(self, center, radius: float = C.FINGERTIP_RADIUS) -> list[str | None]:
        """Material name under the fingertip for each plane (None where the contact point is off the plane)."""
        c = np.asarray(center, float)
        out: list[str | None] = []
        for p in self.planes:
            pc = c - radius * np.asarray(p.normal)
            if np.any(pc < np.asarray(p.lower)) or np.any(pc > np.asarray(p.upper)):
                out.append(None)
                continue
            s1 = np.asarray(p.u_axis) @ pc
            m = p.material if (s1 < p.split or p.material_b is None) else p.material_b
            out.append(get_material(m).name)
        return out

    def surface_height(self, plane_index: int, s1, s2, radius: float = C.FINGERTIP_RADIUS):
        """Followed texture height (m, the envelope the fingertip rides on) and relative friction
        variation on plane ``plane_index`` at (s1, s2)."""
        p = self.planes[plane_index]
        pk = self.pack(radius)
        s1 = np.asarray(s1, float)
        out_h = np.zeros(np.broadcast(s1, s2).shape)
        out_m = np.zeros_like(out_h)
        for side in (0, 1):
            mid = pk["mat_ids"][plane_index, side]
            modes = {k: pk[k][mid] for k in ("h_k1", "h_k2", "h_amp", "h_bamp", "h_phase", "m_k1", "m_k2", "m_amp", "m_phase",
                                             "e_tab", "e_par")}
            h, m = evaluate_texture(modes, s1, s2)
            sel = (s1 < p.split) if side == 0 else (s1 >= p.split)
            out_h = np.where(sel, h, out_h)
            out_m = np.where(sel, m, out_m)
            if side == 0:
                h_first = h
            else:
                h_second = h
        if p.material_b is not None:
            # blended across the boundary as in the integrator (constants.TEXTURE_EDGE_MIN_WIDTH)
            width = pk["geo"][plane_index, 17]
            t = np.clip((s1 - p.split) / width + 0.5, 0.0, 1.0)
            lam = t * t * (3.0 - 2.0 * t)
            edge = np.abs(s1 - p.split) < 0.5 * width
            out_h = np.where(edge, (1.0 - lam) * h_first + lam * h_second, out_h)
        return out_h, out_m


# --------------------------------------------------------------------------
# Builders
# --------------------------------------------------------------------------
def _rot_z(v, angle_deg):
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1])


def _floor(material, height=0.0, **kw) -> Plane:
    return Plane(name="floor", normal=(0.0, 0.0, 1.0), offset=height, u_axis=(1.0, 0.0, 0.0),
                 material=material, **kw)


def _vertical_wall(name, normal_xy, through, material) -> Plane:
    n = np.array([normal_xy[0], normal_xy[1], 0.0])
    n /= np.linalg.norm(n)
    u = np.cross([0.0, 0.0, 1.0], n)
    return Plane(name=name, normal=tuple(n), offset=float(n @ np.asarray(through, float)),
                 u_axis=tuple(u / np.linalg.norm(u)), material=material)


def free_space(*, texture_seed: int = 0) -> Environment:
    """No surfaces at all."""
    return Environment(name="free_space", planes=(), texture_seed=texture_seed)


def plane(*, material: str | Material = "polished_aluminium", height: float = 0.0,
          texture_seed: int = 0, tilt_deg: float = 0.0, tilt_azimuth_deg: float = 0.0) -> Environment:
    """A plane through (0, 0, ``height``) (constraint Z); the finger starts 10 mm above it.

    ``tilt_deg`` tilts it about the horizontal axis at ``tilt_azimuth_deg`` + 90 deg from x, so
    it rises toward the azimuth: a block set down out of level (8.1.1.2: "the wood surface was
    not flat. For some data sets an 11 deg slope can be observed")."""
    floor = _floor(material, height)
    if tilt_deg:
        t, a = math.radians(tilt_deg), math.radians(tilt_azimuth_deg)
        n = np.array([-math.sin(t) * math.cos(a), -math.sin(t) * math.sin(a), math.cos(t)])
        u = np.array([math.cos(t), 0.0, math.sin(t) * math.cos(a)])
        u -= (u @ n) * n
        floor = Plane(name="floor", normal=tuple(float(x) for x in n), offset=float(n[2] * height),
                      u_axis=tuple(float(x) for x in u / np.linalg.norm(u)), material=material)
    return Environment(name="plane", planes=(floor,), texture_seed=texture_seed,
                       start=(0.0, 0.0, height + C.FINGERTIP_RADIUS + 0.010))


def wall(*, material: str | Material = "rough_wood", wall_material: str | Material = "polished_aluminium",
         wall_y: float = 0.020, angle_deg: float = 0.0, texture_seed: int = 0) -> Environment:
    """Plane z = 0 plus a vertical wall facing -y through (0, wall_y, 0), rotated ``angle_deg`` about z (YZ line)."""
    w = _vertical_wall("wall_y", _rot_z((0.0, -1.0), angle_deg), (0.0, wall_y, 0.0), wall_material)
    return Environment(name="wall", planes=(_floor(material), w), texture_seed=texture_seed,
                       start=(0.0, 0.0, C.FINGERTIP_RADIUS + 0.010))


def corner(*, material: str | Material = "rough_wood", wall_material: str | Material = "polished_aluminium",
           wall_y: float = 0.020, wall_x: float = 0.020, angle_y_deg: float = 0.0, angle_x_deg: float = 0.0,
           texture_seed: int = 0) -> Environment:
    """Plane z = 0 plus two vertical walls (fig 9.2): one facing -y through y = ``wall_y`` (YZ)
    and one facing -x through x = ``wall_x`` (XZ), each rotated about z by its angle."""
    wy = _vertical_wall("wall_y", _rot_z((0.0, -1.0), angle_y_deg), (0.0, wall_y, 0.0), wall_material)
    wx = _vertical_wall("wall_x", _rot_z((-1.0, 0.0), angle_x_deg), (wall_x, 0.0, 0.0), wall_material)
    return Environment(name="corner", planes=(_floor(material), wy, wx), texture_seed=texture_seed,
                       start=(0.0, 0.0, C.FINGERTIP_RADIUS + 0.010))


def block(*, material: str | Material = "polished_aluminium", block_material: str | Material = "polished_aluminium",
          face_y: float = 0.015, block_height: float = 0.040, texture_seed: int = 0,
          floor: bool = True) -> Environment:
    """A block whose vertical face (normal -y) is at y = ``face_y``, standing on plane z = 0,
    plus its top face; used for impacts (7.3: moves that end against a block)."""
    face = Plane(name="block_face", normal=(0.0, -1.0, 0.0), offset=-face_y, u_axis=(1.0, 0.0, 0.0),
                 material=block_material, lower=(-_BIG, -_BIG, -_BIG), upper=(_BIG, _BIG, block_height))
    top = Plane(name="block_top", normal=(0.0, 0.0, 1.0), offset=block_height, u_axis=(1.0, 0.0, 0.0),
                material=block_material, lower=(-_BIG, face_y, -_BIG))
    planes = ((_floor(material),) if floor else ()) + (face, top)
    return Environment(name="block", planes=planes, texture_seed=texture_seed,
                       start=(0.0, 0.0, C.FINGERTIP_RADIUS + 0.015))


def _two_texture(name, first, second, texture_seed) -> Environment:
    # Two one-inch halves along x, starting at x = 0: the stroke goes first -> second.
    p = _floor(first, material_b=second, split=1.0 * INCH,
               lower=(0.0, -_BIG, -_BIG), upper=(2.0 * INCH, _BIG, _BIG))
    return Environment(name=name, planes=(p,), texture_seed=texture_seed,
                       start=(0.1 * INCH, 0.0, C.FINGERTIP_RADIUS + 20e-6))


def sample_a(*, texture_seed: int = 0) -> Environment:
    """Sample A (7.2): two inches of aluminium, the first inch sanded crosswise with 80 grit,
    the second polished.  The sample spans x in [0, 2 in]; the split is at x = 1 in."""
    return _two_texture("sample_a", "sanded_aluminium_80", "polished_aluminium", texture_seed)


def sample_b(*, texture_seed: int = 0) -> Environment:
    """Sample B (7.2): polished aluminium inlaid in rough cross-cut wood: wood for x < 1 in,
    aluminium after."""
    return _two_texture("sample_b", "rough_wood", "polished_aluminium", texture_seed)


def maze_outline(*, half_width: float = 0.010, leg_x: float = 0.025, leg_length: float = 0.040,
                 tail_length: float = 0.040) -> list[tuple[float, float]]:
    """Corners (x, y), m, counter-clockwise, of the channel of :func:`maze` (see there)."""
    w, a, L, T = half_width, leg_x, leg_length, tail_length
    return [(-a - w, -L), (-a + w, -L), (-a + w, -w), (-w, -w), (-w, -T), (w, -T), (w, -w), (a - w, -w),
            (a - w, -L), (a + w, -L), (a + w, L), (a - w, L), (a - w, w), (-a + w, w), (-a + w, L),
            (-a - w, L)]


def maze(*, depth: float = 0.003, half_width: float = 0.010, leg_x: float = 0.025, leg_length: float = 0.040,
         tail_length: float = 0.040, material: str | Material = "lexan", texture_seed: int = 0) -> Environment:
    """The gear-shift maze of 9.2 (fig 9.6): an H-shaped channel with one extra tail, milled
    ``depth`` deep into Lexan (less than the fingertip radius).

    Layout (m, channel floor at z = 0; the thesis gives the shape, not the dimensions, so
    these are assumptions: a channel ``2 half_width`` = 20 mm wide, which the 14.3 mm disc
    below passes with clearance, and legs a few disc diameters long):

    - crossbar along x: x in [-leg_x - w, leg_x + w], y in [-w, w]   (w = ``half_width``)
    - left and right legs along y at x = -leg_x and x = +leg_x, y in [-leg_length, leg_length]
    - the tail: a fifth leg down from the middle of the crossbar, x in [-w, w], y in [-tail_length, 0]

    :func:`maze_outline` lists the 16 corners of the channel boundary; every edge is one wall.

    Contact geometry.  The sphere resting on the channel floor meets a wall at the wall's
    top edge (z = ``depth``), at the horizontal distance r = sqrt(R^2 - (R - depth)^2) from
    its centre: the planar task is that of a disc of radius r (7.1 mm for 3 mm), as in fig
    9.6.  Each wall is therefore the plane through its top edge with normal
    (r m + (R - depth) z) / R, m the wall's horizontal normal into the channel: the plane
    the sphere touches exactly where it touches the edge, so the configuration space of the
    disc and the direction of the edge force (inclined, lifting the finger) are both right.
    The contact point is bounded to the wall's length and to a 1 mm band about its line
    (``Plane.lower``/``upper``), so walls are segments seen only from their channel side.  Not modelled: contact with a convex corner itself (the circular arcs of
    the configuration space in fig 9.6); near one the disc meets neither wall.  The thesis
    likewise approximated those arcs by the two linear constraints.
    """
    r = C.FINGERTIP_RADIUS
    if not 0.0 < depth < r:
        raise ValueError("depth must be in (0, fingertip radius)")
    r_disc = math.sqrt(r**2 - (r - depth) ** 2)
    if half_width <= r_disc:
        raise ValueError(f"half_width must exceed the disc radius {r_disc:.4f} m at this depth")
    pts = maze_outline(half_width=half_width, leg_x=leg_x, leg_length=leg_length, tail_length=tail_length)
    walls = []
    for i, (p0, p1) in enumerate(zip(pts, pts[1:] + pts[:1])):
        d = np.array([p1[0] - p0[0], p1[1] - p0[1], 0.0])
        d /= np.linalg.norm(d)
        m = np.array([-d[1], d[0], 0.0])                    # into the channel (left of a CCW edge)
        n = (r_disc * m + (r - depth) * np.array([0.0, 0.0, 1.0])) / r
        edge = np.array([p0[0], p0[1], depth])
        lo = [min(p0[0], p1[0]), min(p0[1], p1[1]), -_BIG]
        hi = [max(p0[0], p1[0]), max(p0[1], p1[1]), _BIG]
        for k in range(2):
            if abs(d[k]) < 0.5:
                # across the wall: the contact point of a sphere touching the edge lies on the
                # edge line (to within its micron-size penetration); a sphere in a channel on
                # the far side of this wall is a disc radius or more away and must not see it
                lo[k], hi[k] = p0[k] - _WALL_BAND, p0[k] + _WALL_BAND
        walls.append(Plane(name=f"wall_{i:02d}", normal=tuple(n), offset=float(n @ edge), u_axis=tuple(d),
                           material=material, lower=tuple(lo), upper=tuple(hi)))
    return Environment(name="maze", planes=(_floor(material),) + tuple(walls), texture_seed=texture_seed,
                       start=(0.0, 0.0, r + 0.0005))


ENVIRONMENTS = {"free_space": free_space, "plane": plane, "wall": wall, "corner": corner,
                "block": block, "sample_a": sample_a, "sample_b": sample_b, "maze": maze}
