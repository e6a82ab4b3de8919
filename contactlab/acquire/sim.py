"""The simulator as an acquisition source: a dataset spec -> simulated trials.

Trial ``k`` of a run with seed ``s`` is fully determined by ``(s, k)``: its
seed is drawn from ``numpy.random.SeedSequence([s, k])``, and that seed both
draws the trial's variation (start jitter, speed, environment parameters,
hand-motion waypoints) and drives the simulator's noise. So ``--trials 3``
gives exactly the first three trials of ``--trials 8``, and ``--append``
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
    desc = (f"{spec.title}; group {group.name!r} trial {j + 1}/{group.trials}"
            + (f"; {group.description}" if group.description else "")
            + "; " + ", ".join(f"{key}={v:.4g}" if isinstance(v, float) else f"{key}={v}"
                               for key, v in env_kw.items())
            + (f"; move {move_duration:g} s" if move_duration else "")
            + (f"; speed scale {scale:.3f}" if (lo, hi) != (1.0, 1.0) else ""))
    return TrialPlan(env, controller, group.duration_s, start, tseed, actions, action_times, desc)


def _controller(group: Group, rng, scale: float, move_duration: float | None, duration_s: float):
    from contactlab import sim

    c = group.controller
    kind = c["kind"]
    stiff = c.get("stiffness_n_per_m")
    if kind == "stroke":
        kw = {"normal_force": c.get("normal_force_n"), "stroke_length": c.get("stroke_length_m"),
              "command_start_s": c.get("command_start_s"), "command_s": c.get("command_s"),
              "stiffness": stiff}
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
                          rate_hz=spec.rate_hz, start=plan.start)
    return plan, result


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


LABEL_FUNCTIONS = {"texture": labels_texture, "hf": labels_hf, "constraint": labels_constraint,
                   "contacts": labels_contacts}


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
            calibration=np.linalg.pinv(sim.StrainGaugeSensor().calibration),
            command_columns=["fx", "fy", "fz"] if force else ["x", "y", "z"],
            command_units="N" if force else "m",
            action_names=list(spec.action_names) if spec.action_names else None,
            attrs={"spec": spec.name, "group": group.name, "run_seed": int(seed), "trial_index": k})
        self._result = None

    def chunks(self) -> Iterator[dict[str, np.ndarray]]:
        from contactlab import sim

        r = sim.simulate(environment=self.plan.environment, controller=self.plan.controller,
                         duration_s=self.plan.duration_s, seed=self.plan.seed,
                         rate_hz=self.spec.rate_hz, start=self.plan.start)
        self._result = r
        action = None
        if self.plan.actions is not None:
            idx = np.searchsorted(self.plan.action_times, r.time, side="right") - 1
            action = np.where(idx >= 0, self.plan.actions[np.clip(idx, 0, None)], 0)
        for a in range(0, len(r.time), CHUNK_ROWS):
            b = min(a + CHUNK_ROWS, len(r.time))
            row = {"time": r.time[a:b], "strain": r.strain[a:b], "wrench": r.wrench[a:b],
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
        return {}


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
