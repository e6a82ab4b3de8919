"""Dataset specs: ``datasets_spec/<name>.toml`` -> :class:`DatasetSpec`.

A spec says how to simulate one dataset of the thesis's experiments: how
many trials, how long, at what rate, which environment and controller, how
trials vary, and which label function turns the simulator's ground truth into
the experiment's feature labels. Layout (every value is commented with its
thesis section in the files themselves)::

    name = "stroke-a"                # the name `contactlab acquire --spec` takes
    title = "..."
    thesis = "7.2"
    experiments = ["stroke-segmentation"]
    status = "ready"                 # or e.g. "needs maze geometry": acquire refuses
    thesis_trials = 8                # the thesis's count, for the report's table
    rate_hz = 1000.0
    duration_s = 7.0
    labels = "texture"               # a key of LABEL_FUNCTIONS (contactlab.acquire.sim)
    action_names = [...]             # optional: names of the action codes
    force_zeroed = true              # optional: the recorded wrench is zeroed at rest in
                                     # free space (8.1.1's "calibrated and zeroed" sensor)
    variation = "..."                # prose: what varies from trial to trial

    [environment]                    # defaults for every group
    kind = "sample_a"                # a builder of contactlab.sim.environment
    ...                              # its keyword arguments
    [controller]
    kind = "stroke"                  # stroke | position | integral_force | hand
    ...
    [vary]                           # trial-to-trial variation, drawn from the trial seed
    start_jitter_m = [0.001, 0.001, 0.0]
    force_angle_deg = 3.0            # integral_force: every force's horizontal part turned
                                     # about z by one angle drawn in +-3 deg per trial

    [apparatus]                      # optional: other hardware (contactlab.sim.hardware)
    adc_bits = 12                    # e.g. a 12-bit board instead of the default 16 bits

    [[group]]                        # consecutive blocks of trials
    name = "..."
    trials = 8
    # optional overrides: duration_s, start_m, move_duration_s (list, cycled
    # over the group's trials), [group.environment], [group.controller], [group.vary]
    # optional: goal_region_m = [[x_lo, y_lo], [x_hi, y_hi]], where the fingertip centre
    # should end (horizontal box, m); checked by contactlab.acquire.sim.reached_goal

A group's tables are merged key by key over the top-level ones. Any problem is
a :class:`~contactlab.errors.DataError` naming the file and the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path

from contactlab.errors import DataError, UsageError

#: Controller kinds and the keys each accepts (besides ``kind``).
CONTROLLER_KEYS = {
    "stroke": {"normal_force_n", "stroke_length_m", "command_start_s", "command_s",
               "stiffness_n_per_m", "shape"},
    "position": {"moves", "stiffness_n_per_m", "exploration_m", "exploration_hz"},
    "integral_force": {"forces", "integral_gain", "stiffness_n_per_m", "exploration_m"},
    "hand": {"amplitude_m", "press_m", "segment_s", "stiffness_n_per_m"},
}
MOVE_KEYS = {"displacement_m", "displacement_in", "duration_s", "start_s"}
FORCE_KEYS = {"start_s", "force_n", "action"}
VARY_KEYS = {"start_jitter_m", "duration_scale", "texture_seed", "environment_uniform",
             "force_angle_deg"}
TOP_KEYS = {"name", "title", "thesis", "experiments", "status", "thesis_trials", "rate_hz",
            "duration_s", "labels", "action_names", "variation", "environment", "controller",
            "vary", "group", "notes", "apparatus", "force_zeroed"}
GROUP_KEYS = {"name", "trials", "duration_s", "start_m", "move_duration_s", "environment",
              "controller", "vary", "description", "goal_region_m"}
LABELS = ("texture", "hf", "constraint", "contacts", "maze")

READY = "ready"


@dataclass(frozen=True)
class Group:
    """A block of consecutive trials sharing one setup (tables already merged)."""

    name: str
    trials: int
    duration_s: float
    environment: dict
    controller: dict
    vary: dict
    start_m: tuple[float, float, float] | None = None
    move_duration_s: tuple[float, ...] = ()
    description: str = ""
    #: ((x_lo, y_lo), (x_hi, y_hi)): where the fingertip centre should end, m (optional)
    goal_region_m: tuple[tuple[float, float], tuple[float, float]] | None = None


@dataclass(frozen=True)
class DatasetSpec:
    """One dataset of the thesis, as loaded from its TOML file."""

    name: str
    title: str
    thesis: str
    path: Path
    status: str
    rate_hz: float
    labels: str
    groups: tuple[Group, ...]
    thesis_trials: int | None = None
    experiments: tuple[str, ...] = ()
    action_names: tuple[str, ...] | None = None
    variation: str = ""
    notes: str = ""
    #: the ``[apparatus]`` table: simulated hardware other than the default
    #: (:mod:`contactlab.sim.hardware`)
    apparatus: dict = field(default_factory=dict)
    #: the recorded wrench is zeroed (tared) at rest in free space (8.1.1)
    force_zeroed: bool = False
    raw: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def ready(self) -> bool:
        return self.status == READY

    @property
    def n_trials(self) -> int:
        """The dataset's full trial count (the sum over its groups)."""
        return sum(g.trials for g in self.groups)

    def group_of(self, k: int) -> tuple[Group, int]:
        """The group of trial ``k`` (0-based, over the whole dataset) and its index in it.

        Trials past the spec's count continue cycling through the groups, so
        ``--trials`` may ask for more than the thesis recorded.
        """
        if k < 0:
            raise UsageError(f"trial index {k} is negative")
        k = k % self.n_trials
        for g in self.groups:
            if k < g.trials:
                return g, k
            k -= g.trials
        raise AssertionError("unreachable")


def spec_dir() -> Path:
    """The directory of the bundled specs (``datasets_spec/``)."""
    return Path(str(files("contactlab.datasets_spec")))


def list_specs() -> list[str]:
    """Names of the bundled specs, sorted."""
    return sorted(p.stem for p in spec_dir().glob("*.toml"))


def resolve_spec(name_or_path: str | Path) -> Path:
    """A spec name (``stroke-a``) or a path to a ``.toml`` file -> the file."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.parent != Path("."):
        if not p.is_file():
            raise DataError("no such spec file", file=str(p))
        return p
    candidate = spec_dir() / f"{p.name}.toml"
    if not candidate.is_file():
        raise UsageError(f"unknown dataset spec {str(name_or_path)!r}; known: "
                         f"{', '.join(list_specs())} (or give a path to a .toml file)")
    return candidate


def load_spec(name_or_path: str | Path) -> DatasetSpec:
    """Load and validate a spec; every problem is a one-line DataError (file: key: what)."""
    path = resolve_spec(name_or_path)
    try:
        raw = tomllib.loads(path.read_text("utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise DataError(f"not valid TOML ({err})", file=str(path)) from None
    except (OSError, UnicodeDecodeError) as err:
        raise DataError(f"cannot read ({err})", file=str(path)) from None
    return _Checker(path).spec(raw)


def load_all() -> list[DatasetSpec]:
    """Every bundled spec."""
    return [load_spec(name) for name in list_specs()]


class _Checker:
    def __init__(self, path: Path):
        self.path = path

    def error(self, key: str, message: str) -> DataError:
        return DataError(message, file=str(self.path), field=key)

    def unknown(self, table: dict, allowed: set, where: str) -> None:
        extra = sorted(set(table) - allowed)
        if extra:
            key = f"{where}.{extra[0]}" if where else extra[0]
            raise self.error(key, f"unknown key (allowed: {', '.join(sorted(allowed))})")

    def get(self, table: dict, key: str, kind, where: str, *, required=True, default=None,
            positive=False):
        full = f"{where}.{key}" if where else key
        if key not in table:
            if required:
                raise self.error(full, "missing required key")
            return default
        value = table[key]
        if kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                    not math.isfinite(value):
                raise self.error(full, f"must be a number, not {value!r}")
            value = float(value)
            if positive and value <= 0:
                raise self.error(full, f"must be positive, not {value!r}")
        elif kind is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise self.error(full, f"must be an integer, not {value!r}")
            if positive and value <= 0:
                raise self.error(full, f"must be positive, not {value!r}")
        elif kind is str:
            if not isinstance(value, str):
                raise self.error(full, f"must be a string, not {value!r}")
        elif kind is dict:
            if not isinstance(value, dict):
                raise self.error(full, "must be a table")
        elif kind is list:
            if not isinstance(value, list):
                raise self.error(full, f"must be a list, not {value!r}")
        return value

    def vector(self, value, key: str, n: int = 3) -> tuple[float, ...]:
        if not (isinstance(value, list) and len(value) == n and
                all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in value)):
            raise self.error(key, f"must be a list of {n} numbers, not {value!r}")
        return tuple(float(v) for v in value)

    def spec(self, raw: dict) -> DatasetSpec:
        self.unknown(raw, TOP_KEYS, "")
        name = self.get(raw, "name", str, "")
        if name != self.path.stem and self.path.parent == spec_dir():
            raise self.error("name", f"must match the file name ({self.path.stem!r})")
        status = self.get(raw, "status", str, "", required=False, default=READY)
        rate = self.get(raw, "rate_hz", float, "", positive=True)
        labels = self.get(raw, "labels", str, "")
        if labels not in LABELS:
            raise self.error("labels", f"unknown label function {labels!r} "
                                       f"(known: {', '.join(LABELS)})")
        duration = self.get(raw, "duration_s", float, "", required=False, positive=True)
        action_names = self.get(raw, "action_names", list, "", required=False)
        if action_names is not None and not all(isinstance(a, str) for a in action_names):
            raise self.error("action_names", "must be a list of strings")
        env = self.get(raw, "environment", dict, "", required=False, default={})
        ctrl = self.get(raw, "controller", dict, "", required=False, default={})
        vary = self.get(raw, "vary", dict, "", required=False, default={})
        groups_raw = self.get(raw, "group", list, "")
        if not groups_raw:
            raise self.error("group", "needs at least one [[group]]")
        groups = []
        for i, g in enumerate(groups_raw):
            where = f"group[{i}]"
            if not isinstance(g, dict):
                raise self.error(where, "must be a table")
            groups.append(self.group(g, where, env, ctrl, vary, duration, status, action_names))
        thesis_trials = self.get(raw, "thesis_trials", int, "", required=False, positive=True)
        experiments = self.get(raw, "experiments", list, "", required=False, default=[])
        return DatasetSpec(
            name=name, title=self.get(raw, "title", str, ""), thesis=self.get(raw, "thesis", str, ""),
            path=self.path, status=status, rate_hz=rate, labels=labels, groups=tuple(groups),
            thesis_trials=thesis_trials, experiments=tuple(str(e) for e in experiments),
            action_names=None if action_names is None else tuple(action_names),
            variation=self.get(raw, "variation", str, "", required=False, default=""),
            notes=self.get(raw, "notes", str, "", required=False, default=""),
            apparatus=self.apparatus(raw), force_zeroed=self.flag(raw, "force_zeroed"), raw=raw)

    def flag(self, raw: dict, key: str) -> bool:
        value = raw.get(key, False)
        if not isinstance(value, bool):
            raise self.error(key, f"must be true or false, not {value!r}")
        return value

    def apparatus(self, raw: dict) -> dict:
        from contactlab.sim.hardware import check_apparatus
        table = self.get(raw, "apparatus", dict, "", required=False, default={})
        bad = check_apparatus(table)
        if bad is not None:
            raise self.error(f"apparatus.{bad[0]}", bad[1])
        return dict(table)

    def group(self, g: dict, where: str, env: dict, ctrl: dict, vary: dict, duration,
              status: str, action_names) -> Group:
        self.unknown(g, GROUP_KEYS, where)
        genv = {**env, **self.get(g, "environment", dict, where, required=False, default={})}
        gctrl = {**ctrl, **self.get(g, "controller", dict, where, required=False, default={})}
        gvary = {**vary, **self.get(g, "vary", dict, where, required=False, default={})}
        dur = self.get(g, "duration_s", float, where, required=False, default=duration,
                       positive=True)
        if dur is None:
            raise self.error(f"{where}.duration_s", "missing (give duration_s at the top or "
                                                    "in the group)")
        start = g.get("start_m")
        start = None if start is None else self.vector(start, f"{where}.start_m")
        mds = self.get(g, "move_duration_s", list, where, required=False, default=[])
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 for v in mds):
            raise self.error(f"{where}.move_duration_s", "must be a list of positive numbers")
        goal = g.get("goal_region_m")
        if goal is not None:
            key = f"{where}.goal_region_m"
            if not (isinstance(goal, list) and len(goal) == 2):
                raise self.error(key, "must be [[x_lo, y_lo], [x_hi, y_hi]]")
            goal = (self.vector(goal[0], key, 2), self.vector(goal[1], key, 2))
            if not all(lo < hi for lo, hi in zip(*goal)):
                raise self.error(key, "needs x_lo < x_hi and y_lo < y_hi")
        self.environment(genv, f"{where}.environment", strict=status == READY)
        self.controller(gctrl, f"{where}.controller", action_names)
        self.vary(gvary, f"{where}.vary")
        return Group(name=self.get(g, "name", str, where),
                     trials=self.get(g, "trials", int, where, positive=True), duration_s=dur,
                     environment=genv, controller=gctrl, vary=gvary, start_m=start,
                     move_duration_s=tuple(float(v) for v in mds),
                     description=self.get(g, "description", str, where, required=False,
                                          default=""),
                     goal_region_m=goal)

    def environment(self, env: dict, where: str, *, strict: bool) -> None:
        from contactlab.sim.environment import ENVIRONMENTS
        kind = self.get(env, "kind", str, where)
        if not strict:
            return
        if kind not in ENVIRONMENTS:
            raise self.error(f"{where}.kind", f"unknown environment {kind!r} "
                                              f"(known: {', '.join(ENVIRONMENTS)})")
        import inspect
        params = set(inspect.signature(ENVIRONMENTS[kind]).parameters)
        self.unknown({k: v for k, v in env.items() if k != "kind"}, params, where)

    def controller(self, ctrl: dict, where: str, action_names) -> None:
        kind = self.get(ctrl, "kind", str, where)
        if kind not in CONTROLLER_KEYS:
            raise self.error(f"{where}.kind", f"unknown controller {kind!r} "
                                              f"(known: {', '.join(CONTROLLER_KEYS)})")
        self.unknown(ctrl, CONTROLLER_KEYS[kind] | {"kind"}, where)
        for key in ("normal_force_n", "stroke_length_m", "command_start_s", "command_s",
                    "stiffness_n_per_m", "integral_gain", "exploration_m", "segment_s"):
            if key in ctrl:
                self.get(ctrl, key, float, where, positive=key != "command_start_s")
        if "shape" in ctrl:
            from contactlab.sim.controllers import PROFILES
            if ctrl["shape"] not in PROFILES:
                raise self.error(f"{where}.shape", f"must be one of {', '.join(PROFILES)}, "
                                                   f"not {ctrl['shape']!r}")
        for key in ("amplitude_m", "press_m", "exploration_hz"):
            if key in ctrl:
                self.vector(ctrl[key], f"{where}.{key}")
        if kind == "position":
            for i, m in enumerate(self.get(ctrl, "moves", list, where)):
                w = f"{where}.moves[{i}]"
                if not isinstance(m, dict):
                    raise self.error(w, "must be a table")
                self.unknown(m, MOVE_KEYS, w)
                if ("displacement_m" in m) == ("displacement_in" in m):
                    raise self.error(w, "give exactly one of displacement_m, displacement_in")
                key = "displacement_m" if "displacement_m" in m else "displacement_in"
                self.vector(m[key], f"{w}.{key}")
                self.get(m, "duration_s", float, w, positive=True)
                self.get(m, "start_s", float, w, required=False)
        if kind == "integral_force":
            for i, f in enumerate(self.get(ctrl, "forces", list, where)):
                w = f"{where}.forces[{i}]"
                if not isinstance(f, dict):
                    raise self.error(w, "must be a table")
                self.unknown(f, FORCE_KEYS, w)
                self.get(f, "start_s", float, w)
                self.vector(self.get(f, "force_n", list, w), f"{w}.force_n")
                action = self.get(f, "action", int, w, required=False)
                if action is not None and (action_names is None or
                                           not 0 <= action < len(action_names)):
                    raise self.error(f"{w}.action", "must index action_names")
        if kind == "hand":
            for key in ("amplitude_m", "segment_s"):
                if key not in ctrl:
                    raise self.error(f"{where}.{key}", "missing required key")

    def vary(self, vary: dict, where: str) -> None:
        self.unknown(vary, VARY_KEYS, where)
        if "start_jitter_m" in vary:
            self.vector(vary["start_jitter_m"], f"{where}.start_jitter_m")
        if "duration_scale" in vary:
            lo, hi = self.vector(vary["duration_scale"], f"{where}.duration_scale", 2)
            if not 0 < lo <= hi:
                raise self.error(f"{where}.duration_scale", "must be [low, high] with 0 < low <= high")
        if "force_angle_deg" in vary:
            self.get(vary, "force_angle_deg", float, where)
            if not 0.0 <= vary["force_angle_deg"] < 90.0:
                raise self.error(f"{where}.force_angle_deg", "must be in [0, 90) degrees")
        ts = vary.get("texture_seed")
        if ts is not None and ts != "trial" and (isinstance(ts, bool) or not isinstance(ts, int)):
            raise self.error(f"{where}.texture_seed", "must be an integer or \"trial\"")
        eu = vary.get("environment_uniform", {})
        if not isinstance(eu, dict):
            raise self.error(f"{where}.environment_uniform", "must be a table")
        for k, v in eu.items():
            self.vector(v, f"{where}.environment_uniform.{k}", 2)
