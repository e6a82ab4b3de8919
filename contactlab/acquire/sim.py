"""The simulator as an acquisition source: a dataset spec -> simulated trials.

Trial ``k`` of a run with seed ``s`` is fully determined by ``(s, k)``: its
seed is drawn from ``numpy.random.SeedSequence([s, k])``, and that seed both
draws the trial's variation (start jitter, speed, environment parameters,
hand-motion waypoints, the turn of commanded forces) and drives the simulator's
noise. So ``--trials 3`` gives exactly the first three trials of ``--trials 8``, and ``--append``
continues the numbering.

Label functions (``labels = ...`` in a spec) turn the simulator's per-sample
truth into the feature labels of an experiment; see :data:`LABEL_FUNCTIONS`.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from contactlab.acquire.base import TrialInfo
from contactlab.acquire.spec import DatasetSpec, Group
from contactlab.errors import UsageError

INCH = 0.0254
#: Rows per chunk handed to the writer (one second at 1000 Hz).
CHUNK_ROWS = 1000


def trial_seed(seed: int, k: int) -> int:
    """The seed of trial ``k`` of a run seeded ``seed`` (a 31-bit integer)."""
    state = np.random.SeedSequence([int(seed) & 0xFFFFFFFF, int(k)]).generate_state(1)[0]
    return int(state) & 0x7FFFFFFF


# ---------------------------------------------------------------------------
# building one trial from a group
# ---------------------------------------------------------------------------
@dataclass
class TrialPlan:
    """Everything :func:`contactlab.sim.simulate` needs for one trial."""

    environment: object
    controller: object
    duration_s: float
    start: np.ndarray
    seed: int
    actions: np.ndarray | None      # (n_forces,) action codes of the force steps, if any
    action_times: np.ndarray | None
    description: str


def plan_trial(spec: DatasetSpec, k: int, seed: int) -> TrialPlan:
    """Draw trial ``k``'s setup from ``trial_seed(seed, k)``."""
    from contactlab import sim

    group, j = spec.group_of(k)
    tseed = trial_seed(seed, k)
    rng = np.random.default_rng(tseed)
    vary = group.vary
    env_kw = {key: v for key, v in group.environment.items() if key != "kind"}
    for key, (lo, hi) in vary.get("environment_uniform", {}).items():
        env_kw[key] = float(rng.uniform(lo, hi))
    ts = vary.get("texture_seed", 0)
    env_kw["texture_seed"] = int(rng.integers(0, 2**31 - 1)) if ts == "trial" else int(ts)
    env = sim.ENVIRONMENTS[group.environment["kind"]](**env_kw)
    start = np.asarray(group.start_m if group.start_m is not None else env.start, float)
    jitter = np.asarray(vary.get("start_jitter_m", (0.0, 0.0, 0.0)), float)
    start = start + rng.uniform(-1.0, 1.0, 3) * jitter
    lo, hi = vary.get("duration_scale", (1.0, 1.0))
    scale = float(rng.uniform(lo, hi))
    move_duration = group.move_duration_s[j % len(group.move_duration_s)] \
        if group.move_duration_s else None
    controller, actions, action_times = _controller(group, rng, scale, move_duration,
                                                    group.duration_s)
    turn = ""
    if "force_angle_deg" in vary and hasattr(controller, "forces") and controller.forces:
        f = controller.forces[-1][1]
        turn = f"; last force ({f[0]:.3f}, {f[1]:.3f}, {f[2]:.3f}) N"
    desc = (f"{spec.title}; group {group.name!r} trial {j + 1}/{group.trials}"
            + (f"; {group.description}" if group.description else "")
            + "; " + ", ".join(f"{key}={v:.4g}" if isinstance(v, float) else f"{key}={v}"
                               for key, v in env_kw.items())
            + (f"; move {move_duration:g} s" if move_duration else "")
            + (f"; speed scale {scale:.3f}" if (lo, hi) != (1.0, 1.0) else "") + turn)
    return TrialPlan(env, controller, group.duration_s, start, tseed, actions, action_times, desc)


def _controller(group: Group, rng, scale: float, move_duration: float | None, duration_s: float):
    from contactlab import sim

    c = group.controller
    kind = c["kind"]
    stiff = c.get("stiffness_n_per_m")
    if kind == "stroke":
        kw = {"normal_force": c.get("normal_force_n"), "stroke_length": c.get("stroke_length_m"),
              "command_start_s": c.get("command_start_s"), "command_s": c.get("command_s"),
              "stiffness": stiff, "shape": c.get("shape")}
        kw = {key: v for key, v in kw.items() if v is not None}
        if "command_s" in kw:
            kw["command_s"] = kw["command_s"] / scale
        return sim.StrokeController(**kw), None, None
    exploration = None
    if c.get("exploration_m"):
        hz = tuple(c.get("exploration_hz", (1.0, 1.4, 1.8)))
        exploration = sim.Exploration(amplitude=float(c["exploration_m"]), frequencies_hz=hz)
    if kind == "position":
        moves = []
        for m in c["moves"]:
            d = np.asarray(m.get("displacement_m") or np.asarray(m["displacement_in"]) * INCH, float)
            dur = (move_duration or m["duration_s"]) / scale
            moves.append(sim.Move(tuple(d), dur, float(m.get("start_s", 0.0))))
        kw = {"moves": tuple(moves), "exploration": exploration}
        if stiff:
            kw["stiffness"] = (stiff, stiff, stiff)
        return sim.PositionController(**kw), None, None
    if kind == "integral_force":
        forces = tuple((float(f["start_s"]), tuple(float(x) for x in f["force_n"]))
                       for f in c["forces"])
        if "force_angle_deg" in group.vary:
            # one small turn about z of every commanded force's horizontal part per trial
            forces = _turn_forces(forces, float(rng.uniform(-1.0, 1.0))
                                  * float(group.vary["force_angle_deg"]))
        kw = {"forces": forces, "exploration": exploration}
        if c.get("integral_gain"):
            kw["integral_gain"] = float(c["integral_gain"])
        if stiff:
            kw["stiffness"] = stiff
        actions = times = None
        if any("action" in f for f in c["forces"]):
            actions = np.array([int(f.get("action", 0)) for f in c["forces"]])
            times = np.array([float(f["start_s"]) for f in c["forces"]])
        return sim.IntegralForceController(**kw), actions, times
    if kind == "hand":
        return _hand(c, rng, duration_s), None, None
    raise UsageError(f"unknown controller kind {kind!r}")


def _turn_forces(forces, angle_deg: float):
    """``forces`` ((start_s, (fx, fy, fz)), ...) with (fx, fy) turned by ``angle_deg`` about z."""
    a = math.radians(angle_deg)
    ca, sa = math.cos(a), math.sin(a)
    return tuple((t0, (ca * f[0] - sa * f[1], sa * f[0] + ca * f[1], f[2])) for t0, f in forces)


def reached_goal(group: Group, fingertip_position) -> bool | None:
    """Whether the last fingertip centre (x, y) lies in ``group.goal_region_m``
    (None when the group declares no goal)."""
    if group.goal_region_m is None:
        return None
    (xl, yl), (xh, yh) = group.goal_region_m
    x, y = np.asarray(fingertip_position, float)[-1, :2]
    return bool(xl <= x <= xh and yl <= y <= yh)


def _hand(c: dict, rng, duration_s: float):
    """"Moved by hand" (8.1.1.2): smooth random exploratory motion.

    A chain of moves with the sinusoidal acceleration profile of 7.3 between
    random waypoints drawn uniformly within +-``amplitude_m`` of the start
    (plus the constant ``press_m`` offset that a hand uses to keep a contact);
    each leg lasts ``segment_s``, so the motion is band-limited to roughly
    1/``segment_s`` Hz and velocity and acceleration stay continuous.
    """
    from contactlab import sim

    amp = np.asarray(c["amplitude_m"], float)
    press = np.asarray(c.get("press_m", (0.0, 0.0, 0.0)), float)
    seg = float(c["segment_s"])
    n = int(math.ceil(duration_s / seg)) + 1
    points = [np.zeros(3)] + [press + rng.uniform(-1.0, 1.0, 3) * amp for _ in range(n)]
    moves = tuple(sim.Move(tuple(b - a), seg, i * seg)
                  for i, (a, b) in enumerate(zip(points[:-1], points[1:])))
    stiff = c.get("stiffness_n_per_m")
    kw = {"moves": moves, "name": "hand"}
    if stiff:
        kw["stiffness"] = (stiff, stiff, stiff)
    return sim.PositionController(**kw)


def simulate_trial(spec: DatasetSpec, k: int, seed: int, *, duration_s: float | None = None):
    """Simulate trial ``k`` of ``spec`` for run seed ``seed``: (plan, SimResult)."""
    from contactlab import sim

    if not spec.ready:
        raise UsageError(f"dataset spec {spec.name!r} cannot be simulated yet: {spec.status}")
    plan = plan_trial(spec, k, seed)
    result = sim.simulate(environment=plan.environment, controller=plan.controller,
                          duration_s=duration_s or plan.duration_s, seed=plan.seed,
                          rate_hz=spec.rate_hz, start=plan.start, **hardware(spec))
    return plan, result


def hardware(spec: DatasetSpec) -> dict:
    """``apparatus``, ``sensor``, ``encoders`` keyword arguments of :func:`contactlab.sim.simulate`
    for the spec's ``[apparatus]`` table."""
    from contactlab.sim.hardware import build_hardware

    app, sen, enc = build_hardware(spec.apparatus)
    return {"apparatus": app, "sensor": sen, "encoders": enc}


def sensor_zero(sensor) -> np.ndarray:
    """The wrench (6,) ``sensor`` reports at rest in free space: the shell's weight
    (4.44's G) through the sensor's calibration, what zeroing (taring) the sensor at rest
    subtracts from every later reading (8.1.1: "a calibrated and zeroed force ... sensor";
    the noise averages out of a tare)."""
    from contactlab.sim import constants as C

    w = np.zeros(6)
    w[2] = -C.SHELL_MASS * C.GRAVITY
    return sensor.inverse_calibration @ (sensor.true_calibration @ w)


# ---------------------------------------------------------------------------
# label functions: simulator truth -> an experiment's feature labels
# ---------------------------------------------------------------------------
def labels_texture(r) -> tuple[np.ndarray, list[str]]:
    """Stroking (7.2): rest / free motion / impact / the texture being stroked.

    "rest" when the finger does not move, "impact" inside an impact interval,
    else the material under the moving finger ("free-motion" off the sample).
    """
    names = ["rest", "impact", "free-motion"] + list(r.materials)
    codes = np.where(r.texture >= 0, 3 + r.texture, 2)
    codes = np.where(r.moving, codes, 0)
    codes = np.where(r.impact, 1, codes)
    return codes.astype(np.int16), names


def labels_hf(r) -> tuple[np.ndarray, list[str]]:
    """The four high-frequency hypotheses of 7.3.

    H0 stationary, not touching; H1 moving, not touching; H2 touching, not
    moving; H3 inside an impact interval (the falling edge of an impact).
    Sliding while touching fits none of the four and is left unlabelled (-1).
    """
    touching = r.contact.any(axis=1) if r.contact.size else np.zeros(len(r.time), bool)
    codes = np.full(len(r.time), -1, np.int16)
    codes[~touching & ~r.moving] = 0
    codes[~touching & r.moving] = 1
    codes[touching & ~r.moving] = 2
    codes[r.impact] = 3
    return codes, ["H0", "H1", "H2", "H3"]


def labels_constraint(r) -> tuple[np.ndarray, list[str]]:
    """Degree of constraint (8.2): the number of surfaces touched, 0..3."""
    n = r.contact.sum(axis=1) if r.contact.size else np.zeros(len(r.time), int)
    return np.minimum(n, 3).astype(np.int16), ["0", "1", "2", "3"]


def labels_contacts(r) -> tuple[np.ndarray, list[str]]:
    """Contact features of chapter 9: impact, free space fixed or moving, and
    each set of touched surfaces (``floor+wall_y``), fixed or moving."""
    s = len(r.surfaces)
    names = ["impact", "free-fixed", "free-moving"]
    for mask in range(1, 2 ** s):
        combo = "+".join(r.surfaces[j] for j in range(s) if mask >> j & 1)
        names += [f"{combo}-fixed", f"{combo}-moving"]
    mask = np.asarray(r.contact_mask, np.int64)
    codes = np.where(mask == 0, 1 + r.moving, 3 + 2 * (mask - 1) + r.moving)
    codes = np.where(r.impact, 0, codes)
    return codes.astype(np.int16), names


#: The walls of :func:`contactlab.sim.environment.maze` by edge of ``maze_outline()``
#: (surface ``wall_NN`` is edge NN, counter-clockwise from the left leg's lower end;
#: fig 9.6 with the tail pointing to -y).
MAZE_WALLS = ("left-leg-bottom", "left-leg-inner-low", "crossbar-low-left", "tail-left",
              "tail-end", "tail-right", "crossbar-low-right", "right-leg-inner-low",
              "right-leg-bottom", "right-leg-outer", "right-leg-top", "right-leg-inner-high",
              "crossbar-high", "left-leg-inner-high", "left-leg-top", "left-leg-outer")


def maze_corners() -> list[tuple[int, int]]:
    """The channel's inside corners as pairs (i, i + 1 mod n) of outline edges: where the
    disc can touch two walls at once (a left turn of the counter-clockwise outline).  The
    other vertices are convex corners, the circular arcs of fig 9.6, touching one wall."""
    from contactlab.sim.environment import maze_outline

    pts = np.asarray(maze_outline(), float)
    d = np.roll(pts, -1, axis=0) - pts                  # edge i: pts[i] -> pts[i + 1]
    nxt = np.roll(d, -1, axis=0)
    turn = d[:, 0] * nxt[:, 1] - d[:, 1] * nxt[:, 0]
    return [(i, (i + 1) % len(pts)) for i in np.flatnonzero(turn > 0)]


def labels_maze(r) -> tuple[np.ndarray, list[str]]:
    """Contact features of the maze (9.2, fig 9.8), each fixed or moving: the disc in the
    channel touching no wall ("channel": on the floor alone; "lifted": off the floor too),
    one wall, or the two walls of an inside corner, named by :data:`MAZE_WALLS`.  The floor
    is implied, as in the thesis's planar configuration space.  "impact" inside an impact
    interval; "other" for any other set of walls (none in a working maze)."""
    surfaces = list(r.surfaces)
    walls = [j for j, name in enumerate(surfaces) if name.startswith("wall_")]
    edge = [int(surfaces[j][5:]) for j in walls]
    wall_names = [MAZE_WALLS[e] if e < len(MAZE_WALLS) else surfaces[j]
                  for j, e in zip(walls, edge)]
    corners = [(edge.index(a), edge.index(b)) for a, b in maze_corners()
               if a in edge and b in edge]
    features = (["lifted", "channel"] + wall_names
                + [f"{wall_names[a]}+{wall_names[b]}" for a, b in corners] + ["other"])
    names = ["impact"] + [f"{f}-{m}" for f in features for m in ("fixed", "moving")]
    n = len(r.time)
    contact = np.asarray(r.contact, bool).reshape(n, -1)
    touched = contact[:, walls]
    count = touched.sum(axis=1)
    on_floor = contact[:, surfaces.index("floor")] if "floor" in surfaces else np.zeros(n, bool)
    feature = np.full(n, len(features) - 1)                          # "other"
    feature[count == 0] = np.where(on_floor[count == 0], 1, 0)
    one = count == 1
    feature[one] = 2 + np.argmax(touched[one], axis=1)
    pair = {frozenset(c): 2 + len(walls) + i for i, c in enumerate(corners)}
    for row in np.flatnonzero(count == 2):
        feature[row] = pair.get(frozenset(np.flatnonzero(touched[row]).tolist()), feature[row])
    codes = 1 + 2 * feature + np.asarray(r.moving, bool)
    codes = np.where(np.asarray(r.impact, bool), 0, codes)
    return codes.astype(np.int16), names


LABEL_FUNCTIONS = {"texture": labels_texture, "hf": labels_hf, "constraint": labels_constraint,
                   "contacts": labels_contacts, "maze": labels_maze}


def segments_from_labels(codes: np.ndarray, time: np.ndarray, rate_hz: float) -> list[tuple]:
    """Runs of equal code -> (start_s, end_s, code) rows."""
    if len(codes) == 0:
        return []
    edges = np.flatnonzero(np.diff(codes)) + 1
    starts = np.r_[0, edges]
    ends = np.r_[edges, len(codes)]
    end_t = np.r_[time[edges], time[-1] + 1.0 / rate_hz]
    return [(float(time[a]), float(e), int(codes[a])) for a, b, e in zip(starts, ends, end_t)]


# ---------------------------------------------------------------------------
# the Source
# ---------------------------------------------------------------------------
class SimTrial:
    """One simulated trial as a :class:`~contactlab.acquire.base.TrialStream`."""

    def __init__(self, spec: DatasetSpec, k: int, seed: int, trial_id: str):
        from contactlab import sim

        self.spec = spec
        self.k = k
        self.run_seed = seed
        self.plan = plan_trial(spec, k, seed)
        group, _ = spec.group_of(k)
        self.group = group
        force = isinstance(self.plan.controller, sim.IntegralForceController)
        self.info = TrialInfo(
            trial_id=trial_id, rate_hz=spec.rate_hz,
            controller=getattr(self.plan.controller, "name", group.controller["kind"]),
            environment=self.plan.environment.name, seed=self.plan.seed, source="simulator",
            description=self.plan.description, strain_units="V",
            calibration=hardware(spec)["sensor"].inverse_calibration,
            command_columns=["fx", "fy", "fz"] if force else ["x", "y", "z"],
            command_units="N" if force else "m",
            action_names=list(spec.action_names) if spec.action_names else None,
            attrs={"spec": spec.name, "group": group.name, "run_seed": int(seed), "trial_index": k,
                   "force_zeroed": bool(spec.force_zeroed)})
        self._result = None

    def chunks(self) -> Iterator[dict[str, np.ndarray]]:
        from contactlab import sim

        r = sim.simulate(environment=self.plan.environment, controller=self.plan.controller,
                         duration_s=self.plan.duration_s, seed=self.plan.seed,
                         rate_hz=self.spec.rate_hz, start=self.plan.start, **hardware(self.spec))
        self._result = r
        wrench = r.wrench - sensor_zero(hardware(self.spec)["sensor"]) if self.spec.force_zeroed \
            else r.wrench
        action = None
        if self.plan.actions is not None:
            idx = np.searchsorted(self.plan.action_times, r.time, side="right") - 1
            action = np.where(idx >= 0, self.plan.actions[np.clip(idx, 0, None)], 0)
        for a in range(0, len(r.time), CHUNK_ROWS):
            b = min(a + CHUNK_ROWS, len(r.time))
            row = {"time": r.time[a:b], "strain": r.strain[a:b], "wrench": wrench[a:b],
                   "position": r.position[a:b], "velocity": r.velocity[a:b],
                   "command": r.command[a:b]}
            if action is not None:
                row["action"] = action[a:b].astype(np.int16)
            yield row

    @property
    def result(self):
        """The :class:`~contactlab.sim.SimResult` (after :meth:`chunks`)."""
        return self._result

    def ground_truth(self) -> dict:
        r = self._result
        codes, names = LABEL_FUNCTIONS[self.spec.labels](r)
        return {
            "labels": codes, "names": names,
            "segments": segments_from_labels(codes, r.time, r.rate_hz),
            "truth": {
                "contact": r.contact, "surfaces": list(r.surfaces),
                "contact_normals": r.contact_normals, "moving": r.moving, "impact": r.impact,
                "impact_intervals": np.asarray(r.impact_intervals, float).reshape(-1, 2)
                / r.rate_hz,
                "texture": r.texture, "texture_names": list(r.materials),
            },
        }

    def final_attrs(self) -> dict:
        # a group with a goal region (the maze) records whether the finger ended in it
        reached = reached_goal(self.group, self._result.fingertip_position) \
            if self._result is not None else None
        return {} if reached is None else {"goal_reached": reached}


class SimSource:
    """Simulated trials of one dataset spec (``contactlab acquire --source sim``).

    ``first`` is the index of the first trial (``--append`` continues the
    numbering); trial ids are ``<spec>-<index:03d>``.
    """

    name = "sim"

    def __init__(self, spec: DatasetSpec, *, first: int = 0):
        if not spec.ready:
            raise UsageError(f"dataset spec {spec.name!r} cannot be simulated yet: {spec.status}")
        self.spec = spec
        self.first = first

    def trial_id(self, k: int) -> str:
        return f"{self.spec.name}-{k:03d}"

    def trials(self, *, n_trials: int, seed: int) -> Iterator[SimTrial]:
        for k in range(self.first, self.first + n_trials):
            yield SimTrial(self.spec, k, seed, self.trial_id(k))
