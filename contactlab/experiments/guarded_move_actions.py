"""guarded-move-actions: the corner reached by three guarded moves (9.1.3, figs 9.4-9.5).

Twenty training and twenty test runs of datasets_spec/guarded-move-actions.toml
(integral force control: "down" onto the table, "to-wall" into the YZ wall,
"into-corner" along it; the wall's angle about z drawn in [-10, 45] deg, the
range over which 9.1.3's sticking analysis says the three actions reach the
corner) are simulated through the acquire path into ``out_dir/tmp`` (deleted
after).  The models of datasets_spec/graphs/guarded-move-actions.toml (the
nodes and models of 9.1.2) are trained on the training runs' labels; the
observer of 6.4 recognises the test runs twice: with the action-dependent
edges (the graph of fig 9.5, the recorded action channel selecting them) and,
for comparison, with every edge of the one-command graph of 9.1.2 active.
Runs are scored as in guarded-move-multi (:mod:`contactlab.observer.corner`):
the surfaces the final MAP path visits against the simulator's labels.
"""

from __future__ import annotations

import json
import re
import time
import tomllib
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from contactlab.fileio import write_text_atomic
from contactlab.observer.corner import recognize_corner_runs
from contactlab.observer.graph import FeatureGraph, bundled_graphs, load_graph, parse_graph
from contactlab.observer.draw import plot_recognised_run
from contactlab.observer.recognize import merge_path, typical_run
from contactlab.observer.training import train_graph
from contactlab.progress import bar
from contactlab.report.page import ReportPage
from contactlab.experiments.scratch import scratch_dir

SPEC = "guarded-move-actions"
THESIS = {"correct": 20, "trials": 20, "angles": (-10.0, 45.0)}
#: training block (samples at 250 Hz): the slides here are stick-slip, 0.1-0.25 s between
#: stops, shorter than the toolkit's 100-sample blocks (our choice: 0.1 s, 8.2's block)
TRAIN_BLOCK = 25
_ANGLE = re.compile(r"angle_y_deg=(-?[0-9.]+)")


def wall_angles(archive) -> dict[str, float | None]:
    """Each run's YZ-wall angle about z (deg) as the simulator recorded it."""
    from contactlab.archive import open_archive

    with open_archive(archive) as arch:
        out = {}
        for tid in arch.select():
            m = _ANGLE.search(str(arch.trial(tid).attrs.get("description", "")))
            out[tid] = float(m.group(1)) if m else None
    return out


def every_edge_graph() -> FeatureGraph:
    """The bundled guarded-move-actions graph with every action's edges active at once
    (the comparison of 9.1.3: what the actions' bounds on the transitions buy)."""
    path = bundled_graphs()[SPEC]
    doc = tomllib.loads(path.read_text())
    doc["edges"] = list(doc.get("edges", [])) + [e for es in doc.pop("edge_sets", [])
                                                 for e in es["edges"]]
    doc.pop("actions", None)
    doc["name"] = f"{SPEC}-every-edge"
    return parse_graph(doc, source=str(path))


def run(*, out_dir: Path, seed: int, quiet: bool = False) -> dict:
    """Simulate, train, recognise with and without the action-dependent edges; the page."""
    from contactlab.acquire.simulated import record_spec

    out_dir = Path(out_dir)
    with scratch_dir(out_dir) as tmp:
        with bar(total=4, desc=SPEC, quiet=quiet, unit="step") as pbar:
            train = record_spec(SPEC, tmp / "train.h5", seed=seed)
            test = record_spec(SPEC, tmp / "test.h5", seed=seed + 1)
            pbar.update(1)
            graph = load_graph(bundled_graphs()[SPEC])
            gm = train_graph(train, graph, block=TRAIN_BLOCK)
            pbar.update(1)
            res, secs = {}, {}
            for key, g in (("actions", graph), ("one command", every_edge_graph())):
                t0 = time.perf_counter()
                res[key] = recognize_corner_runs(test, g, gm, None)
                secs[key] = time.perf_counter() - t0
                pbar.update(1)
            angles = wall_angles(test)
            sig = typical_run(test, res["actions"])
        with plt.rc_context({"figure.max_open_warning": 0}):
            return _report(res, angles, sig, secs, graph, out_dir=out_dir, seed=seed)


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------
def _count(res, key="correct") -> int:
    return sum(bool(e["score"][key]) for e in res["trials"].values())


def _reached(res) -> list[str]:
    return [t for t, e in res["trials"].items() if (e["score"]["truth"] or [])[-1:] == ["corner"]]


def fig_angles(res, angles):
    """Each test run's wall angle against whether the finger reached the corner and
    whether the observer tracked it."""
    fig, ax = plt.subplots(figsize=(8, 3.2))
    reached = set(_reached(res))
    for tid, e in res["trials"].items():
        a = angles.get(tid)
        if a is None:
            continue
        y = 1 if tid in reached else 0
        ok = e["score"]["correct"]
        ax.scatter([a], [y + (0.08 if ok else -0.08)], marker="o" if ok else "x",
                   color="tab:green" if ok else "tab:red", s=40, zorder=3)
    ax.scatter([], [], marker="o", color="tab:green", label="tracked correctly")
    ax.scatter([], [], marker="x", color="tab:red", label="tracked wrongly")
    ax.axvspan(*THESIS["angles"], color="0.9", zorder=0,
               label="thesis: actions reach the corner")
    ax.set_ylim(-0.5, 1.5)
    ax.set_yticks([0, 1])
    ax.set_yticklabels(["stopped on the wall", "reached the corner"])
    ax.set_xlabel("YZ wall angle about z (deg)")
    ax.set_ylabel("simulated outcome")
    ax.set_title("Three guarded moves: wall angle, outcome and tracking (action graph)")
    ax.legend(loc="center right", fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f} %"


def _report(res, angles, sig, secs, graph, *, out_dir: Path, seed: int) -> dict:
    page = ReportPage(title="Action-dependent guarded moves into a corner (9.1.3, figs 9.4-9.5)",
                      out_dir=out_dir)
    n = len(res["actions"]["trials"])
    reached = _reached(res["actions"])
    page.paragraph(
        f"Training: the 20 runs of datasets_spec/guarded-move-actions.toml simulated with seed "
        f"{seed}; test: the same spec with seed {seed + 1}. Each run: at rest, a guarded move "
        "down onto the table, one into the YZ wall, one along it into the corner, under the "
        "integral force controller of 9.1.2 (the forces are our choice: 9.1.3 gives none); "
        "the wall's angle about z drawn in [-10, 45] deg. Models from train_graph on the "
        "training runs' labels (the nodes and models of 9.1.2); the observer of 6.4 with the "
        "recorded action selecting the edges of datasets_spec/graphs/guarded-move-actions.toml, "
        "and, for comparison, with every action's edges active at once.")
    page.note(
        "Choices where the thesis is silent: the edge sets are our reading of fig 9.5 (each "
        "command moves the finger on, stops it, or ends in an impact onto the next surface; "
        "an impact ends on its surface under any command); runs are scored by the surfaces "
        "their final MAP path visits against the simulator's labels (chatter under 50 ms "
        "dropped); a run that ends stuck on the wall and whose path ends in (S,3,F) is "
        "counted separately.")
    rows = []
    for key, title in (("actions", "action-dependent graph (fig 9.5)"),
                       ("one command", "every action's edges active at once")):
        r = res[key]
        rows.append([title, f"{THESIS['correct']}/{THESIS['trials']}" if key == "actions"
                     else "-", f"{_count(r)}/{n}", f"{_count(r, 'stuck_ok')}/{n}",
                     _pct(r["accuracy"])])
    page.table(rows, columns=["graph", "thesis", "ours: runs correct",
                              "correct, a stuck end read as (S,3,F)", "points correct"],
               caption="Test runs whose final MAP path visits the surfaces the finger "
                       "visited, in order; points marked with the right node at 250 Hz.")
    page.table([[tid, "-" if angles.get(tid) is None else f"{angles[tid]:.1f}",
                 " ".join(nd for nd, _ in e["merged_path"]), " > ".join(e["score"]["ours"]),
                 " > ".join(e["score"]["truth"] or []),
                 "yes" if e["score"]["correct"] else
                 ("stuck end" if e["score"]["stuck_ok"] else "no")]
                for tid, e in res["actions"]["trials"].items()],
               columns=["run", "wall angle (deg)", "final MAP path (merged)",
                        "surfaces (ours)", "surfaces (simulator)", "correct"],
               caption="Each test run under the action-dependent graph.")
    page.table([[k, f"{v:.1f} s"] for k, v in secs.items()],
               columns=["graph", "recognition of the test runs"],
               caption="Runtime on this machine (one core).")
    page.figure(fig_angles(res["actions"], angles), name="fig-angles",
                caption="Each test run's wall angle, whether the simulated finger reached the "
                        "corner, and whether the observer tracked it (action graph); shaded: "
                        "the range 9.1.3's sticking analysis gives.")
    path = " ".join(nd for nd, _ in merge_path(sig["rec"].result.map_path))
    page.figure(plot_recognised_run(sig, graph, title=f"Three guarded moves into the corner, "
                                                       f"{sig['id']}: path {path}"),
                name="fig-9-4",
                caption=f"Fig 9.4 (ours): test run {sig['id']}: position, force and the final "
                        "MAP node under the action-dependent graph, beside the simulator's "
                        "labels mapped to nodes.")
    page.heading("Where ours differ and why")
    stuck = [t for t in res["actions"]["trials"] if t not in reached]
    stuck_angles = [angles[t] for t in stuck if angles.get(t) is not None]
    page.paragraph(
        f"The simulated finger reaches the corner in {len(reached)} of {n} runs"
        + (f"; in the others ({', '.join(stuck)}; wall angles "
           + ", ".join(f"{a:.0f}" for a in sorted(stuck_angles))
           + " deg) it stick-slips along the YZ wall or stops on it" if stuck else "")
        + ". 9.1.3's sticking analysis, which leaves out the table's friction, has every "
        "angle in [-10, 45] deg reach the corner and the finger stick on the YZ wall below "
        "-10 deg (facts corner-window and corner-stick-below of 'reproduce apparatus'). With "
        "the simulator's static coefficients (wall 0.61, table 0.40) the two cannot both "
        "hold: the window's -10 deg edge needs the table to take at most 10 mN of the "
        "push's margin (a vertical load of at most 26 mN), and a finger pressed into the "
        "corner stays on the table only under a load above the walls' static friction "
        "(0.61 x 141 mN, 86 mN; at 20 mN the impact into the XZ wall left it held off the "
        "table in 7 of 20 runs). At this spec's 0.1 N both hold only with a wall "
        "coefficient near 0.35 (9.1.3's 35-deg friction angle less the table's share). "
        "Runs are scored against where the finger went.")
    a = res["actions"]
    stuck_read = [t for t, e in a["trials"].items()
                  if e["score"]["stuck_ok"] and not e["score"]["correct"]]
    other = [t for t, e in a["trials"].items() if not e["score"]["stuck_ok"]]
    page.paragraph(
        f"Tracking: {_count(a)} of {n} runs exactly with the action-dependent graph, against "
        f"{_count(res['one command'])} of {n} with every action's edges active at once (the "
        "actions bound which transitions can occur, as 9.1.3 says; the thesis reports 20 of "
        f"20). Of the runs tracked wrongly, {len(stuck_read)} "
        f"({', '.join(stuck_read) or 'none'}) are fingers stopped on the wall whose path "
        "ends in the corner's (S,3,F): a finger held by friction on the wall is constrained "
        "in all three directions, which is how 9.1.2 itself models sticking, and no force or "
        f"position measurement tells it from the corner; {len(other)} "
        f"({', '.join(other) or 'none'}) go wrong otherwise.")
    paths = page.write()
    summary = {"experiment": SPEC, "seed": seed, "trials": n, "reached_corner": len(reached),
               "correct": {k: _count(r) for k, r in res.items()},
               "stuck_ok": {k: _count(r, "stuck_ok") for k, r in res.items()},
               "accuracy": {k: r["accuracy"] for k, r in res.items()},
               "angles": angles,
               "paths": {k: {tid: e["merged_path"] for tid, e in r["trials"].items()}
                         for k, r in res.items()},
               "surfaces": {k: {tid: e["score"] for tid, e in r["trials"].items()}
                            for k, r in res.items()},
               "headline": _headline(res, n, len(reached)), "seconds": secs,
               "report": {k: str(v) for k, v in paths.items()}}
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _headline(res, n, reached) -> str:
    return (f"action graph {_count(res['actions'])}/{n} runs tracked "
            f"({_count(res['actions'], 'stuck_ok')}/{n} reading a stuck end as (S,3,F); "
            f"thesis 20/20), every edge active {_count(res['one command'])}/{n}; the finger "
            f"reaches the corner in {reached}/{n} runs (thesis: every angle in -10..45 deg)")
