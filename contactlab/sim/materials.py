"""Surface materials: Coulomb friction and texture.

A :class:`Material` holds handbook-level mechanical values (elastic modulus,
friction coefficients against the steel fingertip shell, impact damping) and a
description of its texture.  The texture is a pair of stationary random fields
on the surface, in the surface's own coordinates (s1 along the plane's ``u``
axis, s2 across it):

- the surface height h(s1, s2), m;
- the relative variation m(s1, s2) of the friction coefficient, so that
  mu(s) = mu * (1 + m(s)).

Both are synthesised as sums of random sinusoids (spectral synthesis) with
wavelengths log-spaced between ``wavelength_min`` and ``wavelength_max``, a
self-affine spectrum (band amplitude proportional to wavelength**hurst) and a
total rms of ``roughness_rms`` / ``mu_variation``.  Lay: with probability
``anisotropy`` a component's wavevector points along ``lay_angle`` (the
direction in which the height varies; for a surface sanded crosswise that is
across the scratches), otherwise in a uniform direction.  A sliding fingertip
therefore sees a vibration whose frequencies are speed x wavenumber and whose
power depends on the direction of travel (thesis 4.40).

The fingertip touches the surface over a Hertz contact patch of radius a
(about 30-80 um at the 0.2 N of the stroking experiment), which averages the
surface over the patch: components are attenuated by exp(-(k a)^2 / 8), the
Gaussian-patch average, with a evaluated at a nominal 0.2 N load
(:func:`texture_modes`).  The friction variation is averaged the same way: the
friction force sums the patch's micro-junctions (Bowden and Tabor), so variations
of the coefficient shorter than the patch cancel inside it.

What the sphere rides on (the envelope).  A rigid sphere of radius R pressed
on a rough surface does not follow the height field: it rests on the asperity
tops and bridges every valley narrower than about sqrt(8 R depth) (0.6 mm for
a 5 um scratch under the 10 mm fingertip).  Its centre follows the upper
envelope max_q [h(q) - |q - p|^2 / 2R], the morphological closing of h by the
sphere, whose concave curvature is at most 1/R.  Computing that max over the
footprint every integration step is too slow, so the envelope is
approximated spectrally.  The height components are split, longest
wavelength first, into

- the *followed* part: the longest components whose summed rms curvature
  sqrt(sum (A k^2)^2 / 2) stays below 1/(ENVELOPE_CURVATURE_SIGMAS R) (the
  component at the boundary is scaled to meet that budget exactly).  A
  Gaussian field with that rms curvature has valleys tighter than the sphere
  at only ~0.1 % of its points, so the sphere follows it everywhere; this is
  the geometry in the contact (``h_amp``).  Polished aluminium, plastic and
  Lexan are followed entirely (rms curvature 5-30 1/m against 1/3R = 33 1/m);
  80-grit aluminium and rough wood (1400-2400 1/m) are bridged almost
  entirely;
- the *bridged* part (``h_bamp``): the sphere slides over the tops of these
  asperities.  Their geometry changes the centre height only by sagittas
  lambda^2 / 8R (well under a micron for lambda < 0.3 mm) and is left out;
  what they do change is the force: the patch's micro-contacts sit on
  asperity flanks of local slope tan(theta) along the sliding direction, and
  Coulomb friction mu on a flank inclined by theta gives an apparent
  macroscopic coefficient (mu + tan theta) / (1 - mu tan theta) (the
  "ratchet" roughness term of Bowden and Tabor).  So bridged roughness makes
  sliding friction fluctuate with the patch-averaged slope: a vibration whose
  frequencies are speed x wavenumber and whose size depends on the direction
  of travel relative to the lay (4.40), without geometric lift-off.

The lay as ridges: the exact envelope and its micro-impacts.  The spectral
split above smooths away what makes a rough lay vibrate.  A surface sanded
crosswise is a set of straight ridges (scratch flanks) across the sliding
direction, and the sphere rests on the highest crests under its footprint; with
crest heights varying by microns it bridges all but every few ridges (the
supporting crests of the 80-grit profile here are ~0.37 mm apart, where
L^2 / 8R ~ the ~2 um spread of crest heights).  Between hand-overs the centre
follows a circular arc over one crest; at a hand-over the centre height has a
cusp where its slope jumps by about L / R (~0.04), i.e. the finger's normal
velocity jumps by v L / R (~0.5 mm/s at 13 mm/s): a micro-impact.  Through the
sensor spring each jump rings the ~250 Hz mode of the robot mass on the sensor
with a force amplitude of about v (L/R) sqrt(K m_r) (~0.06 N), well above the
sensor noise, and the normal-force swing modulates friction.  So when the lay
carries most of the relief (anisotropy >= constants.LAY_RIDGE_MIN_ANISOTROPY),
its components (taken as exact ridges along the lay, i.e. their wavevectors
projected on the lay direction) are removed from the spectral sum and replaced
by the exact 1-D envelope E(u) = max_q f(q) - (u - q)^2 / 2R of their profile f
along the lay (:func:`sphere_dilation`), tabulated every 1 um and rounded at
the hand-overs by the load sharing of the two crests at the nominal 0.2 N
(:func:`shared_load_envelope`; the rounding is only a few microns wide).  The
contact normal tilts with the followed slope (envelope included) and Coulomb
friction on a tilted contact gives the same ratchet (mu + tan theta) /
(1 - mu tan theta) as the bridged flanks.  Not modelled: the hand-overs between
isolated 2-D peaks of an isotropic relief (rough wood keeps the spectral
model), and the reduction of the ridges to exact straight lines (their +-5 deg
scatter is dropped).

The field is deterministic given its seed: the same physical sample is
stroked in every trial.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from contactlab.sim import constants as C


@dataclass(frozen=True)
class Material:
    """One surface material.

    Parameters
    ----------
    name : key in :data:`MATERIALS`
    youngs_modulus : Pa
    poisson_ratio : dimensionless
    mu_static, mu_kinetic : Coulomb coefficients against the steel shell,
        ``mu_static >= mu_kinetic``
    mu_variation : rms of the relative friction variation along the surface
    roughness_rms : rms surface height, m
    wavelength_min, wavelength_max : band of the texture, m
    hurst : self-affine exponent (band amplitude ~ wavelength**hurst)
    anisotropy : fraction of texture components along ``lay_angle`` (0..1)
    lay_angle : direction (rad, from the plane's u axis) along which the height
        of the anisotropic part varies
    restitution : coefficient of restitution of the shell on this material at
        0.1 m/s; sets the Hunt-Crossley damping (``hunt_crossley_alpha``)
    """

    name: str
    youngs_modulus: float
    poisson_ratio: float
    mu_static: float
    mu_kinetic: float
    mu_variation: float
    roughness_rms: float
    wavelength_min: float
    wavelength_max: float
    hurst: float = 0.8
    anisotropy: float = 0.0
    lay_angle: float = 0.0
    restitution: float = 0.9

    def __post_init__(self):
        if not self.mu_static >= self.mu_kinetic >= 0.0:
            raise ValueError(f"material {self.name!r}: need mu_static >= mu_kinetic >= 0")
        if not 0.0 < self.restitution <= 1.0:
            raise ValueError(f"material {self.name!r}: restitution must be in (0, 1]")
        if not 0.0 <= self.anisotropy <= 1.0:
            raise ValueError(f"material {self.name!r}: anisotropy must be in [0, 1]")
        if not 0.0 < self.wavelength_min <= self.wavelength_max:
            raise ValueError(f"material {self.name!r}: need 0 < wavelength_min <= wavelength_max")

    @property
    def effective_modulus(self) -> float:
        """Hertz E* of the steel shell against this material, Pa."""
        inv = ((1.0 - C.SHELL_POISSON_RATIO**2) / C.SHELL_YOUNGS_MODULUS
               + (1.0 - self.poisson_ratio**2) / self.youngs_modulus)
        return 1.0 / inv

    def hertz_constant(self, radius: float = C.FINGERTIP_RADIUS) -> float:
        """k_h in F = k_h delta^(3/2) for a sphere of ``radius`` on this flat, N/m^1.5."""
        return 4.0 / 3.0 * self.effective_modulus * math.sqrt(radius)

    @property
    def hunt_crossley_alpha(self) -> float:
        """Hunt-Crossley damping alpha (s/m): e = 1 - alpha v at low speed, taken at 0.1 m/s."""
        return (1.0 - self.restitution) / 0.1


# Handbook values.  Friction: dry, clean, against mild steel (engineering
# tables; static/kinetic).  Roughness: typical Ra/rms of the finish named.
# Restitution: typical low-speed values for a steel ball on the material.
MATERIALS: dict[str, Material] = {
    # Polished aluminium: Al-steel mu_s 0.61 / mu_k 0.47; polished Ra ~ 0.05 um.
    "polished_aluminium": Material(
        name="polished_aluminium", youngs_modulus=69e9, poisson_ratio=0.33,
        mu_static=0.61, mu_kinetic=0.47, mu_variation=0.03,
        roughness_rms=0.05e-6, wavelength_min=20e-6, wavelength_max=2e-3,
        restitution=0.9),
    # 80 grit (~190 um grit) sanded crosswise: scratches run along y, the height
    # varies along x (lay_angle 0 = plane u axis = x); Ra ~ 1.5-2.5 um.
    "sanded_aluminium_80": Material(
        name="sanded_aluminium_80", youngs_modulus=69e9, poisson_ratio=0.33,
        mu_static=0.61, mu_kinetic=0.47, mu_variation=0.10,
        roughness_rms=2.5e-6, wavelength_min=50e-6, wavelength_max=1e-3,
        anisotropy=0.9, lay_angle=0.0, restitution=0.9),
    # Rough cross-cut (end-grain) wood: E along the grain ~ 10 GPa; wood-metal
    # mu_s 0.2-0.6 (take 0.4) / mu_k ~ 0.3; fibre/pore relief ~ 10-20 um rms at
    # 0.1-2 mm; wood is lossy on impact.
    "rough_wood": Material(
        name="rough_wood", youngs_modulus=10e9, poisson_ratio=0.30,
        mu_static=0.40, mu_kinetic=0.30, mu_variation=0.15,
        roughness_rms=15e-6, wavelength_min=100e-6, wavelength_max=2e-3,
        anisotropy=0.3, lay_angle=0.0, restitution=0.6),
    # The wooden table of the corner (9.1.2-9.1.3: "catching on the wood", "the grain in
    # the wood surface making up the Z constraint"): rough_wood's elasticity and relief (not
    # measured), its friction identified from 9.1.2-9.1.3's statements about the table
    # (apparatus facts stick-slip-position, no-stick-slip-force, corner-integral-force,
    # corner-window, corner-stick-below, written before): the handbook's low end for wood
    # on metal, mu_s 0.20 (0.2-0.6), mu_k in rough_wood's ratio.  At 0.25 and 0.30 the
    # thesis's integral-force command stays on the YZ wall (seed 1, 30 s); at 0.20 every
    # statement holds on seeds 1-10.
    "table_wood": Material(
        name="table_wood", youngs_modulus=10e9, poisson_ratio=0.30,
        mu_static=0.20, mu_kinetic=0.15, mu_variation=0.15,
        roughness_rms=15e-6, wavelength_min=100e-6, wavelength_max=2e-3,
        anisotropy=0.3, lay_angle=0.0, restitution=0.6),
    # Hard plastic (ABS-like): E 2.3 GPa; plastic-steel mu_s 0.35 / mu_k 0.30;
    # moulded Ra ~ 0.3 um.
    "hard_plastic": Material(
        name="hard_plastic", youngs_modulus=2.3e9, poisson_ratio=0.35,
        mu_static=0.35, mu_kinetic=0.30, mu_variation=0.05,
        roughness_rms=0.3e-6, wavelength_min=30e-6, wavelength_max=2e-3,
        restitution=0.8),
    # Lexan (polycarbonate): E 2.4 GPa; PC-steel mu_s 0.31 / mu_k 0.27;
    # optically smooth sheet, Ra ~ 0.05 um.
    "lexan": Material(
        name="lexan", youngs_modulus=2.4e9, poisson_ratio=0.37,
        mu_static=0.31, mu_kinetic=0.27, mu_variation=0.03,
        roughness_rms=0.05e-6, wavelength_min=20e-6, wavelength_max=2e-3,
        restitution=0.8),
}


def scaled_friction(material: str | Material, factor: float) -> Material:
    """``material`` with both Coulomb coefficients times ``factor`` (>= 0; their relative
    variation along the surface kept), named ``"<name>-friction-x<factor>"``: for
    experiments that vary the friction and nothing else."""
    m = get_material(material)
    if not factor >= 0.0:
        raise ValueError(f"friction factor must be >= 0, not {factor!r}")
    return replace(m, name=f"{m.name}-friction-x{factor:g}", mu_static=factor * m.mu_static,
                   mu_kinetic=factor * m.mu_kinetic)


def get_material(name: str | Material) -> Material:
    """Return the :class:`Material` called ``name`` (or ``name`` itself if it is one)."""
    if isinstance(name, Material):
        return name
    try:
        return MATERIALS[name]
    except KeyError:
        raise ValueError(f"unknown material {name!r}; choose one of {sorted(MATERIALS)}") from None


def _mode_directions(rng: np.random.Generator, n: int, anisotropy: float, lay_angle: float):
    along = rng.random(n) < anisotropy
    angle = np.where(along, lay_angle + rng.normal(0.0, math.radians(5.0), n),
                     rng.uniform(0.0, math.pi, n))
    return angle, along


@numba.njit(cache=True)
def sphere_dilation(f, du, radius):
    """Height of the lowest point of a sphere of ``radius`` resting on the 1-D profile ``f``
    (sampled every ``du``) above each sample: E(p) = max_q f(q) - (p - q)^2 / (2 radius).

    The exact upper envelope of the parabolas hung from every profile point, in O(n)
    (the lower-envelope-of-parabolas algorithm of Felzenszwalb and Huttenlocher's
    distance transform, on g = -2 radius f)."""
    n = f.shape[0]
    g = -2.0 * radius * f
    v = np.zeros(n, np.int64)
    z = np.zeros(n + 1)
    k = 0
    z[0] = -1e300
    z[1] = 1e300
    for q in range(1, n):
        while True:
            s = ((g[q] + (q * du) ** 2) - (g[v[k]] + (v[k] * du) ** 2)) / (2.0 * du * (q - v[k]))
            if s <= z[k] and k > 0:
                k -= 1
            else:
                break
        if s <= z[k]:
            # k == 0 and the new parabola dominates everywhere so far
            v[0] = q
            z[0] = -1e300
            z[1] = 1e300
            continue
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = 1e300
    out = np.empty(n)
    k = 0
    for p in range(n):
        while z[k + 1] < p * du:
            k += 1
        d = (p - v[k]) * du
        out[p] = -(d * d + g[v[k]]) / (2.0 * radius)
    return out


@numba.njit(cache=True)
def shared_load_envelope(f, rigid, du, radius, k_h, load):
    """The envelope of :func:`sphere_dilation` with the load shared between ridges.

    Near a hand-over from one supporting ridge crest to the next both carry load: at the
    sphere-centre offset z every crest q (a local maximum of the profile ``f``) is pressed
    by its Hertz deflection d_q - z, d_q = f(q) - (p - q)^2 / 2R, and the centre sits where
    sum_q k_h (d_q - z)^1.5 equals ``load``.  Returned as the equivalent single-contact
    height z + (load / k_h)^(2/3): equal to the rigid envelope ``rigid`` where one crest
    carries the load, rounded over the hand-over, where the rigid envelope has a cusp."""
    n = f.shape[0]
    d0 = (load / k_h) ** (2.0 / 3.0)
    crest = np.zeros(n, np.int64)
    nc = 0
    for i in range(1, n - 1):
        if f[i] >= f[i - 1] and f[i] > f[i + 1]:
            crest[nc] = i
            nc += 1
    out = rigid.copy()
    if nc == 0:
        return out
    lo = 0
    span = np.max(f) - np.min(f)
    reach = math.sqrt(2.0 * radius * (span + d0)) / du + 2.0
    dq = np.zeros(nc)
    for p in range(n):
        while lo < nc - 1 and crest[lo] < p - reach:
            lo += 1
        # crests close enough to the rigid envelope to carry part of the load
        m = 0
        c = lo
        while c < nc and crest[c] <= p + reach:
            x = (p - crest[c]) * du
            d = f[crest[c]] - x * x / (2.0 * radius)
            if d > rigid[p] - d0:
                dq[m] = d
                m += 1
            c += 1
        if m <= 1:
            continue
        # bisection for z in [rigid - d0, rigid]: the summed Hertz force is decreasing in z
        a = rigid[p] - d0
        b = rigid[p]
        for _ in range(50):
            z = 0.5 * (a + b)
            tot = 0.0
            for q in range(m):
                if dq[q] > z:
                    tot += k_h * (dq[q] - z) ** 1.5
            if tot > load:
                a = z
            else:
                b = z
        out[p] = 0.5 * (a + b) + d0
    return out


def lay_envelope(amp: np.ndarray, k: np.ndarray, angle: np.ndarray, phase: np.ndarray, lay_angle: float,
                 radius: float = C.FINGERTIP_RADIUS, half_length: float = C.LAY_ENVELOPE_HALF_LENGTH,
                 step: float = C.LAY_ENVELOPE_STEP, k_h: float = 0.0, load: float = C.NOMINAL_NORMAL_LOAD) -> np.ndarray:
    """The sphere's envelope over the lay (scratch) part of the height (module docstring).

    The lay components are straight ridges across the lay direction; the profile along it,
    u in [-half_length, half_length] every ``step``, is dilated by the sphere's section
    (:func:`sphere_dilation`) and, if a Hertz constant ``k_h`` is given, the hand-overs
    between supporting crests are rounded by load sharing at ``load``
    (:func:`shared_load_envelope`).  Returns the table of E(u), m."""
    u = np.arange(-half_length, half_length + 0.5 * step, step)
    prof = np.zeros_like(u)
    kk = k * np.cos(angle - lay_angle)
    for j in range(len(amp)):
        if amp[j] != 0.0:
            prof += amp[j] * np.sin(kk[j] * u + phase[j])
    rigid = sphere_dilation(prof, step, radius)
    if k_h > 0.0:
        return shared_load_envelope(prof, rigid, step, radius, k_h, load)
    return rigid


def texture_modes(material: Material, *, seed: int, n_height: int = 32, n_friction: int = 16,
                  radius: float = C.FINGERTIP_RADIUS) -> dict[str, np.ndarray]:
    """Spectral synthesis of the two texture fields of ``material``.

    Returns arrays ``h_k1, h_k2, h_amp, h_phase`` (height) and ``m_k1, m_k2,
    m_amp, m_phase`` (relative friction) such that
    h(s) = sum amp_j sin(k1_j s1 + k2_j s2 + phase_j), and the same for m.
    Height amplitudes are averaged over the Hertz contact patch and split into
    the part the sphere follows (``h_amp``) and the bridged part (``h_bamp``,
    same wavevectors and phases) that acts through friction (module docstring).
    The lay components of a lay-dominated texture are zeroed in both and carried
    instead by ``e_tab``, the sphere's envelope over them tabulated along the lay,
    with ``e_par`` = (cos lay, sin lay, first abscissa, step) (zeros if none).
    Results are cached per (material, seed, sizes, radius); copies are returned.
    """
    modes = _cached_modes(material, int(seed), int(n_height), int(n_friction), float(radius))
    return {k: v.copy() for k, v in modes.items()}


@functools.lru_cache(maxsize=32)
def _cached_modes(material, seed, n_height, n_friction, radius):
    # the lay envelope table takes ~0.1 s to build; trials that share a sample reuse it
    return _texture_modes(material, seed=seed, n_height=n_height, n_friction=n_friction, radius=radius)


def _texture_modes(material, *, seed, n_height, n_friction, radius):
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _name_key(material.name)]))
    out = {}
    for prefix, n, rms in (("h", n_height, material.roughness_rms), ("m", n_friction, material.mu_variation)):
        lam = np.exp(np.linspace(math.log(material.wavelength_max), math.log(material.wavelength_min), n))
        lam = lam * np.exp(rng.uniform(-0.5, 0.5, n) * math.log(material.wavelength_max / material.wavelength_min) / max(n - 1, 1))
        k = 2.0 * math.pi / lam
        amp = lam ** material.hurst
        amp = amp * rms / math.sqrt(0.5 * np.sum(amp**2)) if rms > 0 else np.zeros(n)
        # the patch averages friction as it averages height: the friction force is the sum
        # over the patch's micro-contacts, so coefficient variations shorter than the patch
        # (wavelengths under ~0.1 mm) cancel within it (Bowden-Tabor: friction is
        # proportional to the real contact area summed over the junctions)
        amp = amp * np.exp(-(k * contact_radius(material, radius)) ** 2 / 8.0)
        if prefix == "h":
            followed = followed_fraction(amp, k, radius)
            bamp = amp * (1.0 - followed)
            full = amp
            amp = amp * followed
        ang, along = _mode_directions(rng, n, material.anisotropy, material.lay_angle)
        if prefix == "h":
            phase = rng.uniform(0.0, 2.0 * math.pi, n)
            # the lay (scratch) components: ridden over by the sphere's exact envelope
            lay = along & (material.anisotropy >= C.LAY_RIDGE_MIN_ANISOTROPY)
            if np.any(lay):
                out["e_tab"] = lay_envelope(np.where(lay, full, 0.0), k, ang, phase, material.lay_angle, radius,
                                             k_h=material.hertz_constant(radius))
            else:
                out["e_tab"] = np.zeros(int(round(2.0 * C.LAY_ENVELOPE_HALF_LENGTH / C.LAY_ENVELOPE_STEP)) + 1)
            out["e_par"] = np.array([math.cos(material.lay_angle), math.sin(material.lay_angle),
                                     -C.LAY_ENVELOPE_HALF_LENGTH, C.LAY_ENVELOPE_STEP])
            out["h_bamp"] = np.where(lay, 0.0, bamp)
            amp = np.where(lay, 0.0, amp)
        else:
            phase = rng.uniform(0.0, 2.0 * math.pi, n)
        out[f"{prefix}_k1"] = k * np.cos(ang)
        out[f"{prefix}_k2"] = k * np.sin(ang)
        out[f"{prefix}_amp"] = amp
        out[f"{prefix}_phase"] = phase
    return out


def followed_fraction(amp: np.ndarray, k: np.ndarray, radius: float = C.FINGERTIP_RADIUS,
                      sigmas: float = C.ENVELOPE_CURVATURE_SIGMAS) -> np.ndarray:
    """Fraction (0..1) of each height component's amplitude that a sphere of ``radius`` follows.

    Longest wavelengths first, components are kept whole while the rms curvature of the
    kept set stays below 1 / (sigmas radius); the first one that would exceed it is
    scaled to meet the budget exactly and all shorter ones are bridged (module docstring).
    """
    budget2 = 2.0 * (1.0 / (sigmas * radius)) ** 2      # sum (A k^2)^2 allowed
    frac = np.zeros(len(amp))
    used = 0.0
    for j in np.argsort(k):
        c2 = (amp[j] * k[j] ** 2) ** 2
        if used + c2 <= budget2:
            frac[j] = 1.0
            used += c2
        else:
            frac[j] = math.sqrt(max(budget2 - used, 0.0) / c2) if c2 > 0 else 1.0
            break
    return frac


def contact_radius(material: Material, radius: float = C.FINGERTIP_RADIUS, load: float = C.NOMINAL_NORMAL_LOAD) -> float:
    """Hertz contact-patch radius a = (3 F R / (4 E*))^(1/3) at ``load`` N, m."""
    return (3.0 * load * radius / (4.0 * material.effective_modulus)) ** (1.0 / 3.0)


def _name_key(name: str) -> int:
    # A stable small integer from the name (Python's hash() is salted per process).
    return int.from_bytes(name.encode()[:8].ljust(8, b"\0"), "little") % (2**31)


def evaluate_texture(modes: dict[str, np.ndarray], s1, s2) -> tuple[np.ndarray, np.ndarray]:
    """Followed height (m, the envelope the sphere centre rides on) and relative friction
    variation at surface coordinates (s1, s2); vectorised."""
    s1 = np.asarray(s1, dtype=float)[..., None]
    s2 = np.asarray(s2, dtype=float)[..., None]
    h = np.sum(modes["h_amp"] * np.sin(modes["h_k1"] * s1 + modes["h_k2"] * s2 + modes["h_phase"]), axis=-1)
    m = np.sum(modes["m_amp"] * np.sin(modes["m_k1"] * s1 + modes["m_k2"] * s2 + modes["m_phase"]), axis=-1)
    if "e_tab" in modes:
        h = h + lay_height(modes["e_tab"], modes["e_par"], s1[..., 0], s2[..., 0])[0]
    return h, m


def lay_height(e_tab, e_par, s1, s2):
    """The tabulated lay envelope and its derivative along the lay direction at (s1, s2),
    linearly interpolated as in the integrator; vectorised."""
    u = (e_par[0] * np.asarray(s1, float) + e_par[1] * np.asarray(s2, float) - e_par[2]) / e_par[3]
    i = np.clip(np.floor(u).astype(np.int64), 0, len(e_tab) - 2)
    f = np.clip(u - i, 0.0, 1.0)
    d = np.where((u >= 0) & (u < len(e_tab) - 1), e_tab[i + 1] - e_tab[i], 0.0)
    return e_tab[i] + f * (e_tab[i + 1] - e_tab[i]), d / e_par[3]


def bridged_slope(modes: dict[str, np.ndarray], s1, s2) -> tuple[np.ndarray, np.ndarray]:
    """Gradient (d/ds1, d/ds2) of the bridged height part at (s1, s2); vectorised."""
    s1 = np.asarray(s1, dtype=float)[..., None]
    s2 = np.asarray(s2, dtype=float)[..., None]
    c = modes["h_bamp"] * np.cos(modes["h_k1"] * s1 + modes["h_k2"] * s2 + modes["h_phase"])
    return np.sum(c * modes["h_k1"], axis=-1), np.sum(c * modes["h_k2"], axis=-1)
