"""guarded-move: recognising a guarded move onto a surface with triple feature models (9.1.1, fig 9.1).

Ten training and ten test runs of datasets_spec/guarded-move.toml (3 wood, 3
aluminium, 4 hard plastic; a position-controlled move down onto the plane with
the 2 mm exploration of 9.1.1) are simulated through the acquire path into
``out_dir/tmp`` (deleted after).  ``train_graph`` fits the models the
guarded-move graph (datasets_spec/graphs/guarded-move.toml) names from the
training runs' labels: S (the moving AR model, 7.3), I (the impact prior),
C0 and CZ (the chapter-8 constraint form, 8.1.1) and F/M (velocity, 9.1.1);
the distractors 4 (XZ) and 5 (YZ) use the floor's trained noise in their own
frames.  The observer of 6.4 recognises the test runs; a run is marked correct
when its final MAP path is 0 -> 1 -> 2 -> 1 -> 3 (9.1.1) once spurious impact
excursions (2 -> 1 -> 2, 3 -> 1 -> 3: "an impact event is even detected during
the contact") are dropped; the strict count (the merged path exactly the
expected sequence) is reported beside it.

The rotated-feature test of 9.1.1: feature 4 replaced by the Z constraint
rotated by 5 deg and by 1 deg about x from feature 3's frame.
"""

from __future__ import annotations

import json
import shutil
import time
import tomllib
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from contactlab.fileio import write_text_atomic
from contactlab.observer.draw import plot_node_path
from contactlab.observer.graph import FeatureGraph, bundled_graphs, parse_graph
from contactlab.observer.recognize import RecognizeStage, typical_run
from contactlab.observer.training import train_graph
from contactlab.progress import bar
from contactlab.report.page import ReportPage
from contactlab.signals import trial_signals
from contactlab.stages import run_stage

SPEC = "guarded-move"
EXPECTED = ("0", "1", "2", "1", "3")          # 9.1.1
#: the simulated archive's labels -> the graph's nodes (the truth for point accuracy)
LABEL_NODES = {"free-fixed": "0", "impact": "1", "free-moving": "2", "floor-fixed": "3",
               "floor-moving": "3"}
ROTATIONS = (5.0, 1.0)                        # 9.1.1: feature 4 rotated by 5 and 1 deg
#: the rotated test runs on one run per material (wood, aluminium, hard plastic) to stay
#: within the experiment's time (the detectors on both sides keep many paths alive)
ROTATED_RUNS = ("guarded-move-000", "guarded-move-003", "guarded-move-006")
THESIS = {"correct": 10, "trials": 10,
          "rotated": {5.0: "correct", 1.0: "correct, but ~300 measurements to decide"}}


# ---------------------------------------------------------------------------
# library pieces
# ---------------------------------------------------------------------------
def guarded_graph(rotate_deg: float | None = None) -> FeatureGraph:
    """The bundled guarded-move graph; with ``rotate_deg`` feature 4's constraint is the
    Z constraint of feature 3 rotated by that angle about x (the 9.1.1 rotated test)."""
    path = bundled_graphs()["guarded-move"]
    doc = tomllib.loads(path.read_text())
    if rotate_deg is not None:
        doc["models"]["CXZ"].update(constraint="Z", rotate_deg=[float(rotate_deg), 0.0, 0.0])
        doc["name"] = f"guarded-move-rot{rotate_deg:g}"
    return parse_graph(doc, source=str(path))


def reduce_impacts(nodes, impact: str = "1") -> list[str]:
    """A merged node sequence without impact excursions that return to where they left
    (``a -> impact -> a`` becomes ``a``), repeated until none is left."""
    seq = list(nodes)
    changed = True
    while changed:
        changed = False
        out: list[str] = []
        i = 0
        while i < len(seq):
            if (out and seq[i] == impact and i + 1 < len(seq) and seq[i + 1] == out[-1]):
                i += 2
                changed = True
                continue
            if out and out[-1] == seq[i]:
                i += 1
                continue
            out.append(seq[i])
            i += 1
        seq = out
    return seq


def score_path(merged_nodes, expected=EXPECTED) -> dict:
    """``strict``: the merged path is exactly ``expected``; ``correct``: it is after
    :func:`reduce_impacts`; ``distractor``: it visits a node outside ``expected``."""
    nodes = list(merged_nodes)
    return {"strict": nodes == list(expected),
            "correct": reduce_impacts(nodes) == list(expected),
            "distractor": any(n not in expected for n in nodes)}


def recognize_runs(archive, graph: FeatureGraph, models, *, trials=None,
                   quiet: bool = True) -> dict:
    """The observer over every run of ``archive`` (truth from :data:`LABEL_NODES`);
    the stage summary with each trial's score under ``trials.ID.score``."""
    stage = RecognizeStage(graph=graph, models=models, write=False, keep=True,
                           label_map=LABEL_NODES)
    res = run_stage(stage, [archive], trials=trials, quiet=quiet)[Path(archive)]
    for e in res["trials"].values():
        e["score"] = score_path([n for n, _ in e["merged_path"]])
    return res


# ---------------------------------------------------------------------------
# run
# ---------------------------------------------------------------------------
def run(*, out_dir: Path, seed: int, quiet: bool = False) -> dict:
    """Simulate, train, recognise (the graph and the two rotated distractors); write the page."""
    from contactlab.acquire.simulated import record_spec

    out_dir = Path(out_dir)
    tmp = out_dir / "tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    graph = guarded_graph()
    try:
        with bar(total=3 + len(ROTATIONS), desc="guarded-move", quiet=quiet,
                 unit="step") as pbar:
            train = record_spec(SPEC, tmp / "train.h5", seed=seed)
            test = record_spec(SPEC, tmp / "test.h5", seed=seed + 1)
            pbar.update(1)
            gm = train_graph(train, graph)
            pbar.update(1)
            secs = {}
            t0 = time.perf_counter()
            res = recognize_runs(test, graph, gm)
            secs["graph"] = time.perf_counter() - t0
            pbar.update(1)
            rot = {}
            for deg in ROTATIONS:
                t0 = time.perf_counter()
                rot[deg] = recognize_runs(test, guarded_graph(deg), gm, trials=ROTATED_RUNS)
                secs[f"rotated {deg:g} deg"] = time.perf_counter() - t0
                pbar.update(1)
            signals = typical_run(test, res)
            slips = surface_points(test, res)
        with plt.rc_context({"figure.max_open_warning": 0}):
            return _report(res, rot, gm, signals, slips, secs, graph, out_dir=out_dir,
                           seed=seed)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def surface_points(archive, res) -> dict:
    """On the surface, per archive label (floor-fixed, floor-moving): how many points the
    final MAP paths of ``res`` mark 2 (free, moving) and how many in all."""
    from contactlab.archive import open_archive
    from contactlab.signals import truth_codes

    names = ("floor-fixed", "floor-moving")
    out = {n: {"points": 0, "marked_2": 0} for n in names}
    with open_archive(archive) as arch:
        for rec in res["_runs"]:
            trial = arch.trial(rec.trial_id)
            _, index, _ = trial_signals(trial, ["velocity"], path=archive)
            codes = truth_codes(trial, index, list(names))
            lab = rec.result.labels
            n = min(len(lab), len(codes))
            for k, name in enumerate(names):
                on = codes[:n] == k
                out[name]["points"] += int(on.sum())
                out[name]["marked_2"] += int((lab[:n][on] == 2).sum())
    return out


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------
def _count(res, key) -> int:
    return sum(bool(e["score"][key]) for e in res["trials"].values())


def fig_trial(sig, graph: FeatureGraph):
    """Fig 9.1 (ours): force and velocity of one run with the final MAP node over time."""
    rec = sig["rec"]
    t = sig["t"]
    n = min(len(t), len(rec.result.labels))
    fig, ax = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    for k, axis in enumerate("xyz"):
        ax[0].plot(t[:n], sig["force"][:n, k], lw=0.8, label=f"F{axis}")
        ax[1].plot(t[:n], 1e3 * sig["velocity"][:n, k], lw=0.8, label=f"v{axis}")
    ax[0].set_ylabel("force (N)")
    ax[1].set_ylabel("velocity (mm/s)")
    plot_node_path(ax[2], t, rec.result.labels, graph, truth=rec.truth,
                   truth_label="simulator truth")
    for a in ax:
        a.legend(loc="upper right", fontsize=7)
        a.grid(alpha=0.3)
    path = " ".join(n for n, _ in _merged(rec))
    ax[0].set_title(f"Guarded move {sig['id']}: force, velocity and node path ({path})")
    fig.tight_layout()
    return fig


def _merged(rec):
    from contactlab.observer.recognize import merge_path

    return merge_path(rec.result.map_path)


def _report(res, rot, gm, sig, slips, secs, graph, *, out_dir: Path, seed: int) -> dict:
    page = ReportPage(title="Guarded move onto a surface (9.1.1, fig 9.1)", out_dir=out_dir)
    ntr = len(res["trials"])
    page.paragraph(
        f"Training: the {ntr} runs of datasets_spec/guarded-move.toml simulated with seed "
        f"{seed}; test: the same spec with seed {seed + 1} (3 wood, 3 aluminium, 4 hard "
        "plastic; a position-controlled move 15 mm down over about 4 s onto a plane 10 mm "
        "below the start, with 2 mm sinusoidal exploration in x, y, z). Models from "
        "train_graph on the training runs' labels, as the graph file names them; the observer "
        "of 6.4 with the toolkit's defaults and detectors on both sides (the graph's "
        "'sides'). Expected path 0 -> 1 -> 2 -> 1 -> 3 (9.1.1).")
    page.note(
        "Choices where the thesis is silent: simulator truth instead of hand marking; "
        "'correct' allows impact excursions that return to the node they left (the thesis "
        "reports an impact detected during the contact and still counts the run correct); "
        "distractors 4 (XZ) and 5 (YZ) use the trained floor noise in their own frames; the "
        "rotated test turns feature 4 into feature 3's Z constraint rotated about x.")
    rows = [["graph of 9.1.1 (features 0-5)", f"{THESIS['correct']}/{THESIS['trials']}",
             f"{_count(res, 'correct')}/{ntr}", f"{_count(res, 'strict')}/{ntr}",
             f"{_count(res, 'distractor')}", _pct(res["accuracy"])]]
    for deg in ROTATIONS:
        r = rot[deg]
        nr = len(r["trials"])
        rows.append([f"feature 4 = Z rotated {deg:g} deg", THESIS["rotated"][deg],
                     f"{_count(r, 'correct')}/{nr}", f"{_count(r, 'strict')}/{nr}",
                     f"{_count(r, 'distractor')}", _pct(r["accuracy"])])
    page.table(rows, columns=["setting", "thesis", "ours correct", "ours strict",
                              "runs visiting 4/5", "points marked correctly"],
               caption="Test runs marked correctly. 'strict': merged final MAP path exactly "
                       "0 1 2 1 3; 'runs visiting 4/5': runs whose path enters a distractor "
                       "(for the rotated rows, feature 4 is the rotated Z; one test run per "
                       "material: " + ", ".join(ROTATED_RUNS) + ").")
    page.table([[tid, " ".join(f"{n}@{s:.2f}" for n, s in e["merged_path"]),
                 "yes" if e["score"]["correct"] else "no"]
                for tid, e in res["trials"].items()],
               columns=["run", "final MAP path (node@start s)", "correct"],
               caption="Each test run's path (graph of 9.1.1).")
    names = list(graph.node_names)
    m = np.asarray(res["confusion"]["matrix"])
    page.table([[f"true {names[i]}", *[int(x) for x in row]] for i, row in enumerate(m)
                if row.sum()], columns=["", *names],
               caption="Point confusion at 250 Hz (rows truth: free-fixed 0, impact 1, "
                       "free-moving 2, floor 3; columns chosen).")
    page.table([[k, f"{v:.1f} s"] for k, v in secs.items()],
               columns=["setting", "recognition of the test runs"],
               caption="Runtime on this machine (one core).")
    page.figure(fig_trial(sig, graph), name="fig-9-1",
                caption=f"Fig 9.1 (ours): test run {sig['id']}: the measured force and "
                        "velocity, and the final MAP node over time beside the simulator's "
                        "labels mapped to nodes.")
    page.heading("Where ours differ and why")
    for text in _differences(res, rot, slips, ntr):
        page.paragraph(text)
    paths = page.write()
    summary = {"experiment": "guarded-move", "seed": seed,
               "correct": _count(res, "correct"), "strict": _count(res, "strict"),
               "trials": ntr, "accuracy": res["accuracy"],
               "rotated": {f"{d:g}": {"correct": _count(rot[d], "correct"),
                                      "strict": _count(rot[d], "strict"),
                                      "distractor": _count(rot[d], "distractor")}
                           for d in ROTATIONS},
               "paths": {tid: e["merged_path"] for tid, e in res["trials"].items()},
               "headline": _headline(res, rot, ntr), "seconds": secs,
               "surface_points": slips,
               "report": {k: str(v) for k, v in paths.items()}}
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f} %"


def _headline(res, rot, ntr) -> str:
    r = ", ".join(f"{d:g} deg {_count(rot[d], 'correct')}/{len(rot[d]['trials'])}"
                  for d in ROTATIONS)
    return (f"{_count(res, 'correct')}/{ntr} runs correct ({_count(res, 'strict')} without "
            f"spurious impacts; thesis 10/10); feature 4 rotated: {r}")


def _share_still(slips) -> str:
    still, moving = slips["floor-fixed"]["points"], slips["floor-moving"]["points"]
    return "-" if still + moving == 0 else f"{100 * still / (still + moving):.0f} %"


def _differences(res, rot, slips, ntr) -> list[str]:
    wrong = [tid for tid, e in res["trials"].items() if not e["score"]["correct"]]
    via = {k: sum(any(n == k for n, _ in res["trials"][t]["merged_path"]) for t in wrong)
           for k in ("2", "4", "5")}
    out = [
        f"{_count(res, 'correct')} of {ntr} runs are marked correctly against the thesis's "
        "10 of 10. "
        + (f"Of the runs marked wrongly ({', '.join(wrong)}), {via['4']} visit the "
           f"distractor 4 (XZ), {via['5']} the distractor 5 (YZ) and {via['2']} free motion "
           "(2) while the finger is on the surface. The exploration slides the finger on the "
           "plane and friction sticks it between slides -- the finger is still in "
           f"{_share_still(slips)} of the samples on the surface, where the thesis's "
           "exploration gave its constraint models motion to decide by: a stuck finger is "
           "constrained in "
           "every direction, so a distractor with two normals explains the friction force "
           "along its second normal as constraint force, which the surface model (one "
           "normal) must explain as noise; and a finger sliding on the surface moves, which "
           "only the free-moving node 2 offers (3 is on the surface and fixed): the graph of "
           "9.1.1 has no node for moving on the surface. The constraint models are "
           "normalised by the measurement accuracies (the encoder's step where the simulated "
           "positions, lowpassed, show no noise at all); before that floor, a noise level of "
           "1e-15 m made every extra normal cost about 20 nats per sample and so hid the "
           "distractors. Measured over the ten test runs: " + ", ".join(
               f"{v['marked_2']} of {v['points']} {k} points are marked 2"
               for k, v in slips.items()) + "." if wrong else ""),
        f"Spurious impacts: no run's path is exactly 0 1 2 1 3 ({_count(res, 'strict')} of "
        f"{ntr}); the observer also marks short impact excursions during free motion and "
        "during the contact. The thesis reports an impact detected during the contact in a "
        "run it counted correct, and does not say how it counted the others.",
        "Detector sides: with the increase side only (the thesis's test) the impact node "
        "does not end, because the linear-decay impact model also fits a quiet signal; the "
        "graph declares both sides so that the fall of energy after an impact is detected. "
        "Both sides make the observer keep more paths: recognition is several times slower.",
    ]
    for d in ROTATIONS:
        r = rot[d]
        out.append(
            f"Feature 4 rotated {d:g} deg from feature 3: {_count(r, 'correct')} of "
            f"{len(r['trials'])} runs correct, {_count(r, 'distractor')} visit a distractor "
            f"(thesis: {THESIS['rotated'][d]}). The unrotated graph marks "
            f"{sum(res['trials'][t]['score']['correct'] for t in r['trials'])} of the same "
            "runs correctly.")
    return out
