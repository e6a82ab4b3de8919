"""cartesian-estimation: Cartesian constraint estimation against sample size
(thesis 8.1.1.2, tables 8.1-8.5, figs 8.1-8.2).

Data: the four hand-moved groups of ``datasets_spec/cartesian.toml`` (free
space, one plane, a line, a fixed corner; four runs of 1.6 s each), simulated
with :func:`contactlab.acquire.simulate_trial`, force and position lowpassed
and decimated to 250 Hz as in 7.1, each group's four runs lumped into one block
of 1600 samples (8.1.1.2).  For every sample size, ten examples are drawn at
random (without replacement) from the block, the estimator of each
configuration is fitted with the known number of constraints, and its joint
projection P_hat is compared with the true P (the simulator's surface normals)
by the SVD of ``P_hat^T P`` (:mod:`contactlab.constraints.alignment`).

Configurations (the five tables): stiffness form with / without the friction
filter 8.29, constraint form (log-det criterion) with / without, constraint
form on velocity with the filter; plus the thesis's own solver (Powell over
Euler angles from the Gram-Schmidt start, 8.28) beside the library's default
(batched Newton from the better of the trace and ratio starts) on the same draws.

Choices (also on the page):
- Sensor zeroing.  The thesis's sensor is "calibrated and zeroed" (8.1.1); the
  simulated sensor reports the fingertip's weight (~0.1 N along -z).  We tare
  every group by the mean force of the free-space group (the reading with
  nothing touched), as zeroing the sensor before the runs would.
- Velocity for the friction filter comes from the measured (differenced,
  lowpassed) velocity of each sample *before* the random draw: a random draw
  has no time order to difference.
- The tables pool all draws of all sample sizes >= 25 (the thesis gives one
  table per case without saying which sizes); per-size errors are in the figures.
  The thesis's "sigma sqrt(n)" does not say which n: we give sigma.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.constraints import (CartesianConstraint, CartesianStiffness,  # noqa: E402
                                    alignment_deviation, angular_error_deg, joint_projection,
                                    lognormal_summary)
from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.progress import progress  # noqa: E402
from contactlab.acquire.cartesian_groups import (  # noqa: E402
    GROUPS, SPEC, GroupData, load_groups)
from contactlab.report.page import ReportPage  # noqa: E402

SAMPLE_SIZES = (8, 12, 25, 50, 100, 200, 400, 800, 1600)
TABLE_MIN_SIZE = 25
N_DRAWS = 10                     # 8.1.1.2: "Ten examples were drawn for each sample size"

#: Tables 8.1-8.5: (mu, sigma sqrt(n), equivalent mean angular error deg) per degree 0..3
THESIS_TABLES = {
    "stiffness-friction": ("8.1", [(-10.9, 1.3, 0.34), (-5.09, 11.0, 6.34), (-4.00, 23.2, 11.0),
                                   (-10.0, 2.2, 0.53)]),
    "stiffness": ("8.2", [(-10.6, 1.54, 0.40), (-0.228, 6.37, 78.2), (-1.78, 5.89, 33.7),
                          (-10.0, 1.9, 0.55)]),
    "constraint-friction": ("8.3", [(None, None, 0.0), (-8.5, 7.3, 1.2), (-10.2, 0.38, 0.5),
                                    (None, None, 0.0)]),
    "constraint": ("8.4", [(None, None, 0.0), (-8.19, 7.2, 1.34), (-10.2, 0.36, 0.5),
                           (None, None, 0.0)]),
    "velocity-friction": ("8.5", [(None, None, 0.0), (-10.5, 10.6, 0.43), (-9.9, 8.7, 0.59),
                                  (None, None, 0.0)]),
}
THESIS_POWELL_STEPS = "2-3"


@dataclass(frozen=True)
class Config:
    """One estimator configuration of tables 8.1-8.5."""

    key: str
    label: str
    form: str                    # "stiffness" | "constraint"
    friction: bool
    motion: str = "position"
    solver: str = "newton"

    def estimator(self, degree: int):
        if self.form == "stiffness":
            return CartesianStiffness(degree=degree, friction=self.friction, motion=self.motion)
        if self.solver == "powell":     # the thesis's search from its Gram-Schmidt start
            return CartesianConstraint(degree=degree, friction=self.friction,
                                       motion=self.motion, solver="powell",
                                       start="gram-schmidt")
        return CartesianConstraint(degree=degree, friction=self.friction, motion=self.motion)


CONFIGS = (
    Config("stiffness-friction", "stiffness, friction compensated", "stiffness", True),
    Config("stiffness", "stiffness, no compensation", "stiffness", False),
    Config("constraint-friction", "constraint, friction compensated", "constraint", True),
    Config("constraint", "constraint, no compensation", "constraint", False),
    Config("velocity-friction", "constraint on velocity, compensated", "constraint", True,
           motion="velocity"),
    Config("powell-friction", "constraint, compensated, Powell (8.28)", "constraint", True,
           solver="powell"),
)


# -- data ------------------------------------------------------------------------------------
def true_projection(normals: np.ndarray, scaling) -> np.ndarray:
    """The true joint projection (6, 3) of 8.21 in the normalised units of ``scaling``."""
    if normals.shape[1] == 0:
        return joint_projection(normals)
    return joint_projection(scaling.normals_to_scaled(normals))


def draw_reported_normals(gd: GroupData, s: np.ndarray) -> np.ndarray:
    """The true normals (3, m) of a draw in the frame of the reported positions: the
    orthonormalised mean of its samples' :attr:`GroupData.reported_normals` (each run
    and place has its own, through the PHANToM's kinematic error)."""
    q, _ = np.linalg.qr(gd.reported_normals[s].mean(axis=0))
    return q


# -- draws -----------------------------------------------------------------------------------
def draw_errors(groups: dict[str, GroupData], *, seed: int, sizes=SAMPLE_SIZES,
                draws: int = N_DRAWS, configs=CONFIGS, quiet: bool = True) -> dict:
    """Fit every configuration on ``draws`` random examples per sample size and group.

    Returns ``{config: {group: {"deviation", "angle_deg", "loglik", "iterations",
    "determined"}}}``, each an array (len(sizes), draws), plus ``"seconds"``
    per configuration.  The same draws serve every configuration.
    """
    rng = np.random.default_rng(seed)
    idx = {g: [[rng.choice(len(gd), size=min(n, len(gd)), replace=False) for _ in range(draws)]
               for n in sizes] for g, gd in groups.items()}
    out: dict = {c.key: {} for c in configs}
    seconds = {c.key: 0.0 for c in configs}
    jobs = [(c, g) for c in configs for g in groups]
    for c, g in progress(jobs, total=len(jobs), desc="cartesian-estimation fits", quiet=quiet):
        gd = groups[g]
        est = c.estimator(gd.degree)
        shape = (len(sizes), draws)
        res = {key: np.full(shape, np.nan) for key in ("deviation", "angle_deg", "loglik",
                                                        "loglik_true", "iterations",
                                                        "normal_reported_deg")}
        res["determined"] = np.zeros(shape, dtype=bool)
        t0 = time.perf_counter()
        for i in range(len(sizes)):
            for j in range(draws):
                s = idx[g][i][j]
                fit = est.estimate(gd.position[s], gd.force[s], gd.velocity[s])
                P = true_projection(gd.normals, fit.scaling)
                res["deviation"][i, j] = float(alignment_deviation(fit.P_, P))
                res["angle_deg"][i, j] = float(angular_error_deg(fit.P_, P))
                res["loglik"][i, j] = fit.loglik_
                res["iterations"][i, j] = getattr(fit, "iterations_", np.nan)
                if c.form == "constraint":
                    res["loglik_true"][i, j] = fit.loglik_at(gd.normals)
                res["determined"][i, j] = fit.determined_
                if 0 < gd.degree < 3 and gd.reported_normals is not None and fit.determined_:
                    res["normal_reported_deg"][i, j] = float(angular_error_deg(
                        fit.normals_, draw_reported_normals(gd, s)))
        seconds[c.key] += time.perf_counter() - t0
        out[c.key][g] = res
    out["seconds"] = seconds
    return out


# -- summary ---------------------------------------------------------------------------------
def _table_stats(res: dict, sizes) -> dict:
    sel = np.asarray(sizes) >= TABLE_MIN_SIZE
    dev = res["deviation"][sel]
    s = lognormal_summary(dev)
    s["mean_angle_deg"] = float(np.mean(res["angle_deg"][sel]))
    s["median_angle_deg"] = float(np.median(res["angle_deg"][sel]))
    s["undetermined"] = int((~res["determined"][sel]).sum())
    rep = res["normal_reported_deg"][sel]
    s["mean_normal_reported_deg"] = float(np.nanmean(rep)) if np.isfinite(rep).any() else None
    # the optimiser missed: the true frame scores higher under the criterion than the estimate
    missed = res["loglik_true"][sel] > res["loglik"][sel] + 1e-6 * np.abs(res["loglik"][sel])
    s["optimum_missed"] = int(missed.sum())
    s["draws"] = int(dev.size)
    return s


def summarize(groups: dict[str, GroupData], errs: dict, *, seed: int, sizes=SAMPLE_SIZES,
              configs=CONFIGS) -> dict:
    """The JSON summary: per configuration and group the log-normal table entries,
    the mean angle per sample size, and Powell-vs-Newton comparisons."""
    tables = {}
    for c in configs:
        tables[c.key] = {}
        for g in groups:
            r = errs[c.key][g]
            tables[c.key][g] = {
                "degree": groups[g].degree, **_table_stats(r, sizes),
                "mean_angle_by_size": {int(n): float(np.mean(r["angle_deg"][i]))
                                       for i, n in enumerate(sizes)},
                "mean_normal_reported_by_size": (
                    {int(n): float(np.nanmean(r["normal_reported_deg"][i]))
                     for i, n in enumerate(sizes)}
                    if np.isfinite(r["normal_reported_deg"]).any() else None)}
    powell = {}
    if "powell-friction" in errs and "constraint-friction" in errs:
        for g in groups:
            p, nw = errs["powell-friction"][g], errs["constraint-friction"][g]
            if groups[g].degree in (0, 3):
                continue
            worse = p["loglik"] < nw["loglik"] - 1e-6 * np.abs(nw["loglik"])
            powell[g] = {"iterations_median": float(np.median(p["iterations"])),
                         "iterations_min": int(np.min(p["iterations"])),
                         "iterations_max": int(np.max(p["iterations"])),
                         "local_minimum_fraction": float(worse.mean()),
                         "mean_angle_deg_powell": float(np.mean(p["angle_deg"])),
                         "mean_angle_deg_newton": float(np.mean(nw["angle_deg"])),
                         "newton_iterations_median": float(np.median(nw["iterations"]))}
    return {
        "experiment": "cartesian-estimation", "seed": seed,
        "sample_sizes": list(map(int, sizes)), "draws": int(errs[configs[0].key][
            next(iter(groups))]["angle_deg"].shape[1]),
        "table_sizes": f">= {TABLE_MIN_SIZE}",
        "groups": {g: {"samples": len(gd), "degree": gd.degree,
                       "normals": gd.normals.T.round(6).tolist(),
                       **({"reported_vs_physical_deg": float(angular_error_deg(
                           draw_reported_normals(gd, np.arange(len(gd))), gd.normals))}
                          if 0 < gd.degree < 3 and gd.reported_normals is not None else {}),
                       "fraction_with_all_contacts": float(np.mean(gd.contact == gd.degree))}
                   for g, gd in groups.items()},
        "tables": tables, "powell": powell,
        "seconds": {k: round(v, 3) for k, v in errs["seconds"].items()},
        "thesis": {k: {"table": t, "rows": v} for k, (t, v) in THESIS_TABLES.items()},
        "thesis_powell_steps": THESIS_POWELL_STEPS,
    }


# -- figures ---------------------------------------------------------------------------------
FLOOR_DEG = 1e-4


def _fig_vs_size(errs, sizes, keys, labels, *, groups=("plane", "line"), title: str):
    fig, axes = plt.subplots(1, len(groups), figsize=(5 * len(groups), 4), sharey=True)
    axes = np.atleast_1d(axes)
    x = np.asarray(sizes, dtype=float)
    for ax, g in zip(axes, groups, strict=True):
        for i, (key, lab) in enumerate(zip(keys, labels, strict=True)):
            a = np.maximum(errs[key][g]["angle_deg"], FLOOR_DEG)
            jitter = x[:, None] * (1 + 0.04 * (i - (len(keys) - 1) / 2))
            ax.plot(np.broadcast_to(jitter, a.shape).ravel(), a.ravel(), ".", ms=3,
                    color=f"C{i}", alpha=0.5)
            ax.plot(x, a.mean(axis=1), "-o", ms=3, color=f"C{i}", label=lab)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("sample size")
        ax.set_title(f"{g} ({'1 contact' if g == 'plane' else '2 contacts'})", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel(f"angular error (deg, floor {FLOOR_DEG:g})")
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


# -- report ----------------------------------------------------------------------------------
def _fmt(v, nd=2):
    return "NA" if v is None else (f"{v:.{nd}f}" if isinstance(v, float) else str(v))


def write_report(groups, errs, summary: dict, out_dir: Path) -> None:
    sizes = summary["sample_sizes"]
    page = ReportPage(title="cartesian-estimation: Cartesian constraint estimation "
                            "(thesis 8.1.1.2, tables 8.1-8.5, figs 8.1-8.2)", out_dir=out_dir)
    page.paragraph(
        "Data: the four hand-moved groups of datasets_spec/cartesian.toml (free space, one wood "
        "plane, a line = wood plane + aluminium block, a fixed corner), four simulated runs of "
        "1.6 s each, force and position lowpassed and decimated to 250 Hz (7.1) and lumped into "
        f"one block of {len(groups['free'])} samples per group. For each sample size in "
        f"{sizes} we draw {summary['draws']} random examples (without replacement) and fit each "
        "estimator with the known number of constraints; the error is the largest principal "
        "angle between the estimated and the true joint projection (SVD of P_hat^T P). "
        "Units are normalised by the measurement accuracies (8.7-8.9): position 8.7 um "
        "(encoder step / sqrt 12), force 10 mN, velocity 1 mm/s.")
    page.note(
        "Choices: the sensor is zeroed by subtracting the free-space group's mean force (the "
        "fingertip's weight, ~0.1 N) -- the thesis's sensor is 'calibrated and zeroed'. The "
        "friction filter 8.29 uses each sample's measured velocity (differenced, lowpassed) "
        "taken before the random draw, and passes samples slower than 3 mm/s unchanged. Tables "
        f"pool the draws of all sample sizes >= {TABLE_MIN_SIZE}; the thesis does not say "
        "which sizes its tables pool, nor which n its 'sigma sqrt(n)' uses, so we give sigma. "
        "The equivalent mean angular error is arccos(1 - exp(mu)) (checked against table 8.1).")
    rows = []
    for c in CONFIGS:
        thesis = THESIS_TABLES.get(c.key)
        ours = summary["tables"][c.key]
        if thesis:
            rows.append([f"table {thesis[0]} (thesis)", c.label]
                        + [_fmt(t[2]) for t in thesis[1]] + ["mu " + ", ".join(
                            _fmt(t[0]) for t in thesis[1])])
        rows.append(["ours", c.label]
                    + [_fmt(ours[g]["angle_deg"], 3) for g in GROUPS]
                    + ["mu " + ", ".join(_fmt(ours[g]["mu"]) for g in GROUPS)
                       + "; sigma " + ", ".join(_fmt(ours[g]["sigma"]) for g in GROUPS)])
    page.table(rows, columns=["source", "configuration", "0 (free)", "1 (plane)", "2 (line)",
                              "3 (corner)", "log-normal mu / sigma of 1 - min sv"],
               caption="Tables 8.1-8.5 beside ours: equivalent mean angular error (deg) "
                       "arccos(1 - exp(mu)) for 0/1/2/3 constraints. NA/0 = nothing to "
                       "estimate (the frame is exact).")
    rows = []
    for c in CONFIGS:
        for g in ("plane", "line"):
            by = summary["tables"][c.key][g]["mean_angle_by_size"]
            rows.append([c.label, g, "physical (strict)"] + [_fmt(by[n], 3) for n in sizes])
            rb = summary["tables"][c.key][g].get("mean_normal_reported_by_size")
            if rb:
                rows.append([c.label, g, "reported frame (generous)"]
                            + [_fmt(rb.get(n, rb.get(str(n))), 3) for n in sizes])
    page.table(rows, columns=["configuration", "group", "truth"] + [f"n={n}" for n in sizes],
               caption="Mean angular error (deg, plain mean of the angles) by sample size. "
                       "Physical: the joint projection against the surfaces' physical "
                       "normals (as tables 8.1-8.5). Reported frame: the estimated normals "
                       "against each draw's normals in the frame of the reported positions "
                       "(J^-T n through the PHANToM's kinematic error).")
    page.figure(_fig_vs_size(errs, sizes, ["stiffness-friction", "stiffness"],
                             ["friction compensated (fig 8.1)", "no compensation"],
                             title="Figure 8.1: stiffness estimation, angular error against "
                                   "sample size"),
                name="fig-8-1", caption="Figure 8.1 reproduced (left: 1 contact, as the "
                "thesis; right: 2 contacts). Dots: the draws; line: their mean.")
    page.figure(_fig_vs_size(errs, sizes, ["constraint-friction", "constraint",
                                           "velocity-friction", "powell-friction"],
                             ["compensated (fig 8.2)", "no compensation",
                              "velocity, compensated", "Powell from Gram-Schmidt"],
                             title="Figure 8.2: constraint estimation, angular error against "
                                   "sample size"),
                name="fig-8-2", caption="Figure 8.2 reproduced with the other constraint-form "
                "configurations on the same draws (errors below 1e-4 deg drawn at 1e-4).")
    prow = [[g, summary["groups"][g]["degree"], v["iterations_median"],
             f"{v['iterations_min']}-{v['iterations_max']}", v["newton_iterations_median"],
             f"{100 * v['local_minimum_fraction']:.0f} %", _fmt(v["mean_angle_deg_powell"], 3),
             _fmt(v["mean_angle_deg_newton"], 3)] for g, v in summary["powell"].items()]
    page.table(prow, columns=["group", "constraints", "Powell iterations (median)", "range",
                              "Newton iterations (median)", "Powell worse than Newton",
                              "mean error Powell (deg)", "mean error Newton (deg)"],
               caption=f"Powell's method over three Euler angles from the Gram-Schmidt start "
                       f"(8.28), the thesis's solver (thesis: {THESIS_POWELL_STEPS} steps), "
                       "against the library's batched Newton from the trace and ratio starts, same draws. "
                       "'Worse' = a lower log-likelihood than Newton's frame: a local minimum.")
    page.table([[c.label] + [f"{summary['tables'][c.key][g]['optimum_missed']} / "
                             f"{summary['tables'][c.key][g]['draws']}" for g in ("plane", "line")]
                for c in CONFIGS if c.form == "constraint"],
               columns=["configuration", "plane", "line"],
               caption="Draws (sizes >= 25) in which the true frame has a higher log-likelihood "
                       "than the estimate: the solver missed the optimum of 8.22.")
    page.heading("Where ours differ and why")
    for text in _differences(summary):
        page.paragraph(text)
    page.table([[k, v] for k, v in summary["seconds"].items()],
               columns=["configuration", "fit time (s, all groups, sizes and draws)"])
    page.write()
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")


def _differences(summary: dict) -> list[str]:
    t = summary["tables"]
    pw = summary["powell"]
    out = [
        "Free space and the fixed corner: the constraint form has nothing to estimate (NA, "
        "0 deg) as in tables 8.3-8.5; the stiffness form has small errors "
        f"({t['stiffness-friction']['free']['angle_deg']:.2f} / "
        f"{t['stiffness-friction']['corner']['angle_deg']:.2f} deg compensated, thesis 0.34 / "
        "0.53): it must find the 3 quiet directions among 6.",
        "One and two contacts, constraint form: plane "
        f"{t['constraint-friction']['plane']['angle_deg']:.2f} deg, line "
        f"{t['constraint-friction']['line']['angle_deg']:.2f} deg compensated (thesis 1.2 and "
        "0.5), against the surfaces' physical normals (the thesis's 'assumed true P'; the "
        "strict reading). The error is flat in n (table by size) because it is a bias of "
        "the apparatus, not of the estimator: the simulated PHANToM reports position "
        "through its kinematic error (about 1 deg per entry of its linear part and the "
        "curvature identified from '1 mm over 80 mm', 8.1.1.2), so in the frame of the "
        "reported positions the surfaces' normals are J^-T n, not n; these differ from the "
        f"physical normals by {summary['groups']['plane'].get('reported_vs_physical_deg', float('nan')):.2f} deg "
        f"(plane) and {summary['groups']['line'].get('reported_vs_physical_deg', float('nan')):.2f} deg "
        "(line) -- the size of the flat error. Measured against the normals in the reported "
        "frame (each draw's own: the mean of J^-T n over its samples, so every run and place "
        "gets its own truth) the compensated normals are off by "
        f"{t['constraint-friction']['plane']['mean_normal_reported_deg']:.2f} deg (plane) and "
        f"{t['constraint-friction']['line']['mean_normal_reported_deg']:.2f} deg (line): the "
        "generous reading (table by size, 'reported frame'). What remains on the plane is the "
        "force frame, which the kinematic error does not rotate: one orthonormal frame "
        "cannot fit both, and the estimate lies between them. The thesis names the same "
        "chain ('1-2 deg of angular error') as the limit of its own truth. "
        "(Earlier versions of this page said the runs' tilts differ; they do not: every "
        "run's plane lies 8 deg out of level.)",
        "Stiffness form: the thesis found it poor without friction compensation (78 deg for one "
        "contact) and usable with it (6.3 deg). Ours: plane "
        f"{t['stiffness']['plane']['angle_deg']:.1f} deg without, "
        f"{t['stiffness-friction']['plane']['angle_deg']:.1f} deg with compensation; line "
        f"{t['stiffness']['line']['angle_deg']:.1f} / "
        f"{t['stiffness-friction']['line']['angle_deg']:.1f} deg. The stiffness form takes the "
        "three smallest eigen-directions of the (centred) joint covariance, so any direction "
        "in which the hand's pressing force varies less than the friction left along the "
        "motion gets read as a free direction. On our line the fluctuation of the force into "
        "the crease (the sum of the two normals' forces, which the hand model varies together) "
        "is smaller than the friction residual that the filter leaves at slow speeds (it passes "
        "samples under 3 mm/s), so the estimate is near 90 deg off. The thesis's 11 deg says "
        "its hand pressed less evenly; our hand model is not calibrated to a human hand.",
    ]
    v = t["velocity-friction"]["line"]
    out.append(
        f"Velocity-based, line: {v['angle_deg']:.2f} deg against the physical normals, "
        f"{v['mean_normal_reported_deg']:.2f} deg against the reported frame (thesis 0.59). "
        "An earlier version reported 83 deg here: a defect of the solver, not of the "
        "criterion. The hand sticks on the rough wood for more than half of each run (median "
        "speed 0.1 mm/s), the friction filter passes stopped samples, and in normalised units "
        "the stick friction along the line (sd 0.7 N = 70 units) outweighs the velocity along "
        "it (27 mm/s = 27 units). The trace criterion's start (eigenvectors of Ixx - Iww) "
        "then takes the line's direction for a normal and Newton stayed in that basin, while "
        "the true frame scores a higher log-likelihood (e.g. -2450 against -2607 on run 0). "
        "The estimator now also starts from the generalised eigenvectors of Ixx against Iww "
        "(each direction's motion relative to its force; the exact optimum when both are "
        "diagonal in one frame) and keeps the better end point; "
        f"{v['optimum_missed']} of {v['draws']} draws still score the true frame higher.")
    if pw:
        it = ", ".join(f"{g} {v['iterations_median']:g} ({v['iterations_min']}-"
                       f"{v['iterations_max']})" for g, v in pw.items())
        lm = ", ".join(f"{g} {100 * v['local_minimum_fraction']:.0f} %" for g, v in pw.items())
        out.append(
            f"Powell (8.28): median iterations {it} against the thesis's 2-3 (scipy counts a "
            "full sweep over the three directions as one iteration, as the thesis's 'each step "
            "requires searching for a minimum in three different directions'). From the "
            f"Gram-Schmidt start it ends in a local minimum in {lm} of the draws: the start "
            "takes each free direction from the smallest eigenvectors of the uncentred force "
            "information, and on the line the force into the crease varies less than the "
            "friction along the line, so the start's free direction points into the crease and "
            "Powell's line searches stay in that basin. The library's Newton from the trace and ratio "
            "starts finds the global optimum on the same draws; the "
            "tables' constraint rows use it.")
    return out


def run(*, out_dir: Path, seed: int, quiet: bool = False, sizes=SAMPLE_SIZES,
        draws: int = N_DRAWS, duration_s: float | None = None) -> dict:
    """Reproduce tables 8.1-8.5 and figs 8.1-8.2 on simulated hand-moved data."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    groups = load_groups(seed=seed, quiet=quiet, duration_s=duration_s)
    t_sim = time.perf_counter() - t0
    sizes = tuple(n for n in sizes if n <= min(len(g) for g in groups.values()))
    errs = draw_errors(groups, seed=seed, sizes=sizes, draws=draws, quiet=quiet)
    summary = summarize(groups, errs, seed=seed, sizes=sizes)
    summary["seconds"]["simulation"] = round(t_sim, 3)
    write_report(groups, errs, summary, out_dir)
    summary["seconds"]["total"] = round(time.perf_counter() - t0, 3)
    return summary
