"""hf-recognition: recognising the four high-frequency hypotheses on-line (7.3.1-7.3.3, fig 7.10).

The 15 training runs (datasets_spec/hf-train.toml) and 12 test runs
(hf-test.toml) are simulated through the acquire path into ``out_dir/tmp``
(deleted after).  ``contactlab train --graph`` fits the models the graph
names: H0-H2 AR(1) with a mean on y_h, units of 100 (7.3), the trained
orthogonal prior and mean driving variance used in the orthogonal square-root
Kalman filter (7.3.1); H3 the linear-decay impact prior (7.1).  The observer
of 6.4 runs with change size 2.0 and threshold 8.0 (7.3.1):

1. context free (datasets_spec/graphs/hf-context-free.toml: any transition,
   equal initial probabilities) on the training and the test runs (7.3.2);
2. with context (hf-context.toml: the transitions the commanded action allows,
   initial state H0) on the test runs (7.3.3).

Peer: a Gaussian HMM (hmmlearn) over the same four states and the same
signal, trained supervised on the same runs (per-state mean and variance of
the labelled points, transitions and initial probabilities from label
counts) and decoded with Viterbi -- the approach of Hannaford and Lee that
the thesis argues against (1.x, 6).

Signal: y_h, the channel mean over the 8 strain gauges (the choice of
hf-models), log floor at half the quantisation step.  The 8-channel variant
(channels independent) is reported as a check.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab import defaults as D  # noqa: E402
from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.observer.draw import plot_graph  # noqa: E402
from contactlab.observer.graph import bundled_graphs, load_graph  # noqa: E402
from contactlab.observer.graph_learn import learn_from_labels  # noqa: E402
from contactlab.observer.graph_toml import write_graph  # noqa: E402
from contactlab.observer.recognize import (DELAY_BINS, change_dwell,  # noqa: E402
                                          change_priors, detection_delays, merge_path,
                                          recognize_archive)
from contactlab.observer.training import train_graph  # noqa: E402
from contactlab.peers.hmm import decode, fit_hmm, labelled_points  # noqa: E402
from contactlab.progress import bar  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402
from contactlab.experiments.scratch import scratch_dir  # noqa: E402

GRAPHS = bundled_graphs()["hf-context"].parent
STATES = ("H0", "H1", "H2", "H3")
ORDER, MEAN, BLOCK = D.GRAPH_ORDER, D.GRAPH_MEAN, D.BLOCK   # 7.3: AR(1) with a mean, units of 100
THRESHOLD, CHANGE_SIZE = 8.0, 2.0          # 7.3.1
THESIS = {
    "train_cf": {"accuracy": 0.81, "confusion": [[6175, 119, 1508, 0], [19, 2859, 159, 0],
                                                 [654, 621, 4279, 208], [0, 7, 12, 981]],
                 "delays": [28, 8, 1, 3, 15]},
    "test_cf": {"accuracy": 0.66, "confusion": [[4769, 86, 3302, 0], [35, 2904, 222, 0],
                                                [794, 1014, 2774, 101], [0, 49, 12, 405]],
                "delays": [22, 1, 2, 0, 14]},
    "test_ctx": {"accuracy": 0.95, "confusion": [[7981, 176, 0, 0], [18, 3142, 0, 1],
                                                 [0, 636, 3946, 101], [0, 47, 2, 405]],
                 "delays": None},
}
TITLES = {"train_cf": "training runs, context free (7.3.2)",
          "test_cf": "test runs, context free (7.3.2)",
          "test_ctx": "test runs, with context (7.3.3)"}


# ---------------------------------------------------------------------------
# the HMM peer
# ---------------------------------------------------------------------------
def decode_hmm(model, runs: list[dict]) -> tuple[np.ndarray, float, list[np.ndarray]]:
    """Viterbi state sequences; pooled confusion counts and the time (s) to decode and
    count them (:func:`contactlab.peers.hmm.decode`)."""
    t0 = time.perf_counter()
    total, states = decode(model, runs, len(STATES))
    return total, time.perf_counter() - t0, states


# ---------------------------------------------------------------------------
# run
# ---------------------------------------------------------------------------
def run(*, out_dir: Path, seed: int, quiet: bool = False) -> dict:
    """Simulate, train, recognise (3 settings + HMM + 8-channel check); write the page."""
    from contactlab.acquire.simulated import record_spec

    out_dir = Path(out_dir)
    cf = load_graph(GRAPHS / "hf-context-free.toml")
    ctx = load_graph(GRAPHS / "hf-context.toml")
    with scratch_dir(out_dir) as tmp:
        with bar(total=8, desc="hf-recognition", quiet=quiet, unit="step") as pbar:
            train = record_spec("hf-train", tmp / "hf-train.h5", seed=seed)
            test = record_spec("hf-test", tmp / "hf-test.h5", seed=seed + 1)
            pbar.update(1)
            models = {}
            for reduce in ("mean", "none"):
                gm = train_graph(train, cf, order=ORDER, mean=MEAN, block=BLOCK, reduce=reduce)
                gm.save(tmp / f"models-{reduce}.h5", force=True)
                models[reduce] = gm
            pbar.update(1)
            kw = dict(threshold=THRESHOLD, change_size=CHANGE_SIZE, write=False, keep=True)
            res, secs = {}, {}
            for key, arc, g in (("train_cf", train, cf), ("test_cf", test, cf),
                                ("test_ctx", test, ctx)):
                t0 = time.perf_counter()
                res[key] = recognize_archive(arc, graph=g, models=models["mean"], **kw)
                secs[key] = time.perf_counter() - t0
                pbar.update(1)
            check = {key: recognize_archive(arc, graph=g, models=models["none"], **kw)
                     for key, arc, g in (("test_cf", test, cf), ("test_ctx", test, ctx))}
            pbar.update(1)
            # our variant, beside: the same graphs with Gaussian stationary hypotheses
            gauss = load_graph(GRAPHS / "hf-gaussian.toml")
            gauss_ctx = load_graph(GRAPHS / "hf-gaussian-context.toml")
            gm_gauss = train_graph(train, gauss, reduce="mean")
            check.update({f"{key}_gauss": recognize_archive(arc, graph=g, models=gm_gauss,
                                                            threshold=THRESHOLD,
                                                            change_size=CHANGE_SIZE, write=False,
                                                            keep=True)
                          for key, arc, g in (("train_cf", train, gauss),
                                              ("test_cf", test, gauss),
                                              ("test_ctx", test, gauss_ctx))})
            # and with the edges learned from the training labels (graph learn
            # --models-from hf-gaussian), as the HMM learns its transitions from them
            doc, _ = learn_from_labels([train], {s: s for s in STATES}, base=gauss,
                                       name="hf-gaussian-learned")
            learned = load_graph(write_graph(doc, tmp / "hf-gaussian-learned.toml"))
            check["test_learned_gauss"] = recognize_archive(
                test, graph=learned, models=gm_gauss, threshold=THRESHOLD,
                change_size=CHANGE_SIZE, write=False, keep=True)
            # the pruning's part: context free with the 20-nat gap alone (P_prune 1, 9.1.1's
            # rule), beside each node's price of a change (its trained change prior split
            # over its other successors, as the observer prices it)
            gap = recognize_archive(test, graph=gauss, models=gm_gauss, threshold=THRESHOLD,
                                    change_size=CHANGE_SIZE, p_prune=1.0, write=False)
            h = change_priors(change_dwell(gauss, gm_gauss), gm_gauss.fs) or {}
            others = {n: sum(j != i for j in gauss.successors(i))
                      for i, n in enumerate(gauss.node_names)}
            gap["change_price_nats"] = {n: float(np.log(p / others[n])) for n, p in h.items()}
            check["test_cf_gap_gauss"] = gap
            pbar.update(1)
            tr_pts, te_pts = labelled_points(train, STATES), labelled_points(test, STATES)
            hmm = fit_hmm(tr_pts, len(STATES))
            hmm_res = {"train": decode_hmm(hmm, tr_pts), "test": decode_hmm(hmm, te_pts)}
            pbar.update(1)
        with plt.rc_context({"figure.max_open_warning": 0}):
            return _report(res, secs, check, hmm, hmm_res, models["mean"], te_pts, cf, ctx,
                           out_dir=out_dir, seed=seed)


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------
def _acc(m) -> float:
    m = np.asarray(m)
    return float(np.trace(m) / m.sum()) if m.sum() else float("nan")


def _conf_rows(label, m) -> list[list]:
    return [[f"{label}: {s}"] + [int(x) for x in row] + [f"{100 * row[i] / max(sum(row), 1):.0f} %"]
            for i, (s, row) in enumerate(zip(STATES, np.asarray(m).tolist()))]


def fig_run(rec, graph, y, *, title: str, hmm_states=None):
    """Fig 7.10 for one run: data with truth, graph with final node probabilities,
    node probability traces, and the final MAP path against truth (and the HMM)."""
    r = rec.result
    t = rec.times - rec.times[0]
    fig = plt.figure(figsize=(10, 6.2))
    gs = fig.add_gridspec(2, 2, width_ratios=[2.2, 1])
    ax = fig.add_subplot(gs[0, 0])
    # data: channel-mean y_h, truth as background colour
    ax.plot(t, np.asarray(y)[:, 0], color="k", lw=0.6)
    if rec.truth is not None:
        for k in range(len(STATES)):
            m = rec.truth == k
            if m.any():
                ax.fill_between(t, 0, 1, where=m, color=f"C{k}", alpha=0.15, step="post",
                                transform=ax.get_xaxis_transform(), label=f"truth {STATES[k]}")
    ax.set_ylabel("y_h, channel mean (log V)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=4, loc="upper right")
    axg = fig.add_subplot(gs[0, 1])
    plot_graph(graph, axg, probabilities=r.node_prob[-1])
    axg.set_title("graph, final node probabilities", fontsize=8)
    axp = fig.add_subplot(gs[1, 0], sharex=ax)
    for k in range(len(STATES)):
        axp.plot(t, r.node_prob[:, k], color=f"C{k}", lw=0.9, label=STATES[k])
    axp.set_ylabel("P(node | data so far)")
    axp.set_xlabel("time (s)")
    axp.legend(fontsize=7, ncol=4, title="node", title_fontsize=7)
    axl = fig.add_subplot(gs[1, 1])
    rows = [("truth", rec.truth), ("MAP path", r.labels), ("on-line MAP", r.map_node)]
    if hmm_states is not None:
        rows.append(("HMM Viterbi", hmm_states))
    for i, (name, lab) in enumerate(rows):
        if lab is None:
            continue
        lab = np.asarray(lab)
        for k in range(len(STATES)):
            m = lab == k
            axl.fill_between(t, i + 0.1, i + 0.9, where=m, color=f"C{k}", step="post")
    axl.set_yticks(np.arange(len(rows)) + 0.5, [n for n, _ in rows], fontsize=7)
    axl.set_xlabel("time (s)")
    axl.legend(handles=[plt.Rectangle((0, 0), 1, 1, color=f"C{k}", label=s)
                        for k, s in enumerate(STATES)]
               + [plt.Rectangle((0, 0), 1, 1, fc="white", ec="0.6", label="unlabelled")],
               fontsize=6, ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.22),
               frameon=False)
    hist = " -> ".join(f"{n}@{t[min(max(s, 0), len(t) - 1)]:.2f}"
                       for n, s in merge_path(r.map_path))
    axl.set_title("paths; MAP: " + (hist if len(hist) < 60 else hist[:57] + "..."), fontsize=7)
    fig.tight_layout()
    return fig


def _report(res, secs, check, hmm, hmm_res, gm, te_pts, cf, ctx, *, out_dir, seed) -> dict:
    page = ReportPage(title="hf-recognition: recognising high-frequency events (7.3.1-7.3.3, "
                            "fig 7.10)", out_dir=out_dir)
    blocks = {k: m.n_blocks for k, m in gm.temporal.items()}
    page.paragraph(
        f"Training: the 15 runs of hf-train.toml (seed {seed}); test: the 12 runs of "
        f"hf-test.toml (seed {seed + 1}). Models from 'contactlab train --graph' on the "
        f"channel-mean y_h: AR({ORDER}) with a mean in units of {BLOCK} (blocks per class "
        f"{blocks}), and the H3 linear-decay prior from "
        f"{gm.impacts['H3'].n_segments_} labelled impacts. Observer (6.4): change size "
        f"{CHANGE_SIZE}, threshold {THRESHOLD}, P_prune 0.999, gap 20, the default detector "
        "tests (the covariance increase of 6.14 and a two-sided test of the normalised "
        "innovation's mean, contactlab.observer.observer). Points are the 250 Hz "
        "samples of y_h; a point's truth is the simulator's label; unlabelled points are left "
        "out. 'Points marked correctly' uses the final MAP path (the labelling the program "
        "ends with); the on-line column uses the MAP node after each sample.")
    page.note(
        "Choices where the thesis is silent: the channel mean of the 8 strain gauges as y_h "
        "(as hf-models); simulator ground truth instead of hand segmentation; the action "
        "channel for the context graph is 'move' while the commanded position changes (the "
        "simulator records no action); the context graph is one network for all test runs "
        "(the union of the impact and free-space guarded moves), where the thesis gave each "
        "run 'the appropriately constrained network'; delays match each truth transition "
        "to the nearest MAP-path change into the same node within 50 samples (0.2 s).")
    rows = []
    for key in ("train_cf", "test_cf", "test_ctx"):
        s = res[key]
        hm = hmm_res["train" if key == "train_cf" else "test"][0]
        rows.append([TITLES[key], f"{100 * THESIS[key]['accuracy']:.0f} %",
                     f"{100 * s['accuracy']:.1f} %", f"{100 * s['accuracy_online']:.1f} %",
                     f"{100 * check[key]['accuracy']:.1f} %" if key in check else "-",
                     f"{100 * check[key + '_gauss']['accuracy']:.1f} %"
                     if key + "_gauss" in check else "-",
                     f"{100 * _acc(hm):.1f} %" if key != "test_ctx" else "(same as above)"])
    if "test_learned_gauss" in check:
        rows.append(["test runs, edges learned from the training labels (our variant)", "-",
                     "-", "-", "-", f"{100 * check['test_learned_gauss']['accuracy']:.1f} %",
                     "(same as above)"])
    page.table(rows, columns=["setting", "thesis", "ours (MAP path)", "ours (on-line)",
                              "ours, 8 channels", "ours, Gaussian hypotheses", "HMM Viterbi"],
               caption="Points marked correctly. 'ours, 8 channels': the same pipeline with "
                       "the 8 gauges' y_h as independent channels. 'ours, Gaussian "
                       "hypotheses': graphs hf-gaussian and hf-gaussian-context, our variant of "
                       "the thesis's two graphs whose stationary hypotheses are trained "
                       "Gaussians of y_h (their levels fixed, where the thesis's AR models "
                       "re-estimate each segment's level from a trained prior), the same "
                       "edges, actions and observer settings. "
                       "The HMM has no context graph; its row is the same for both test "
                       "settings.")
    for key in ("train_cf", "test_cf", "test_ctx"):
        m = np.asarray(res[key]["confusion"]["matrix"])
        page.table(_conf_rows("thesis", THESIS[key]["confusion"]) + _conf_rows("ours", m),
                   columns=["true", *STATES, "row correct"],
                   caption=f"Point confusion, {TITLES[key]} (rows true, columns chosen).")
    for key in ("train", "test"):
        page.table(_conf_rows("HMM", hmm_res[key][0]), columns=["true", *STATES, "row correct"],
                   caption=f"Point confusion of the Gaussian HMM (Viterbi), {key} runs.")
    rows = []
    for key in ("train_cf", "test_cf", "test_ctx"):
        d = res[key]["delays"]
        th = THESIS[key]["delays"]
        if th:
            rows.append([f"thesis, {TITLES[key]}", *th, "-", "-", "-"])
        rows.append([f"ours, {TITLES[key]}", *[d["counts"][b] for b in DELAY_BINS],
                     d["missed"], d["extra"], d["transitions"]])
        if key + "_gauss" in check:
            d = check[key + "_gauss"]["delays"]
            rows.append([f"ours, Gaussian hypotheses, {TITLES[key]}",
                         *[d["counts"][b] for b in DELAY_BINS], d["missed"], d["extra"],
                         d["transitions"]])
    if "test_learned_gauss" in check:
        d = check["test_learned_gauss"]["delays"]
        rows.append(["ours, Gaussian hypotheses, test runs, learned edges",
                     *[d["counts"][b] for b in DELAY_BINS], d["missed"], d["extra"],
                     d["transitions"]])
    page.table(rows, columns=["", *[f"delay {b}" for b in DELAY_BINS], "missed",
                              "extra marks", "true transitions"],
               caption="Detection delays (samples at 250 Hz) of the marked transitions (7.3.2).")
    within = _within_table(res, check, hmm_res["test"][2], te_pts)
    page.table([[name, f"{n_in}/{n}", f"{100 * n_in / max(n, 1):.0f} %"]
                for name, (n_in, n, _) in within.items()],
               columns=["", "marked within 0.25 s", "share"],
               caption="A second reading of the delays, beside the table above: the true "
                       "transitions between label runs of at least 0.1 s (a shorter run, the "
                       "speed label's flicker, is taken as the run before it), each matched "
                       "to the nearest change of the final MAP path into the same node within "
                       "0.25 s. The HMM peer's Viterbi path is scored the same way. The last "
                       "row is no detector: for each true transition, knowing it and its "
                       "neighbours, the single change of y_h's mean between the midpoints to "
                       "the neighbouring transitions (ruptures' one-break binary segmentation, "
                       "l2 cost): where the signal itself changes. A transition it misses is "
                       "one whose y_h does not change within 0.25 s of the label.")
    page.table([[k, f"{v:.2f} s"] for k, v in secs.items()],
               columns=["setting", "recognition time (incl. conditioning)"],
               caption="Runtime on this machine (one core).")
    # figures: every test run, with context; and context free
    hmm_states = dict(zip([p["id"] for p in te_pts], hmm_res["test"][2]))
    ys = {p["id"]: p["y"] for p in te_pts}
    for key, g in (("test_ctx", ctx), ("test_cf", cf)):
        for rec in res[key]["_runs"]:
            fig = fig_run(rec, g, ys[rec.trial_id], title=f"{rec.trial_id}: {TITLES[key]}",
                          hmm_states=hmm_states.get(rec.trial_id))
            page.figure(fig, name=f"fig-7-10-{key}-{rec.trial_id}",
                        caption=f"Fig 7.10 (ours), {TITLES[key]}, {rec.trial_id}: y_h with the "
                                "truth shaded; the graph with its final node probabilities; "
                                "node probabilities over time; truth, final MAP path, on-line "
                                "MAP node and the HMM's Viterbi path. The node probabilities "
                                "are pointwise and on-line (each sample's probability summed "
                                "over the kept paths, from the data so far); the final MAP "
                                "path is the one most probable whole path, chosen with "
                                "hindsight, so it can sit at a node that was not the most "
                                "probable at the time: a later change re-explains the past.")
    page.heading("Where ours differ and why")
    for text in _differences(res, hmm_res, gm, check, within):
        page.paragraph(text)
    paths = page.write()
    summary = {"experiment": "hf-recognition", "seed": seed,
               "accuracy": {k: res[k]["accuracy"] for k in res},
               "accuracy_online": {k: res[k]["accuracy_online"] for k in res},
               "accuracy_8_channels": {k: check[k]["accuracy"] for k in check
                                       if not k.endswith("_gauss")},
               "accuracy_gaussian": {k[:-len("_gauss")]: check[k]["accuracy"] for k in check
                                     if k.endswith("_gauss")},
               "accuracy_hmm": {k: _acc(v[0]) for k, v in hmm_res.items()},
               "confusion": {k: res[k]["confusion"]["matrix"] for k in res},
               "confusion_hmm": {k: v[0].tolist() for k, v in hmm_res.items()},
               "delays": {k: res[k]["delays"] for k in res},
               "within_0_25_s": {k: list(v[:2]) for k, v in within.items()},
               "headline": _headline(res, hmm_res, check),
               "thesis": THESIS, "seconds": secs,
               "hmm_decode_s": {k: v[1] for k, v in hmm_res.items()},
               "paths": {k: {tid: e["merged_path"] for tid, e in res[k]["trials"].items()}
                         for k in res},
               "report": {k: str(v) for k, v in paths.items()}}
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _gap_text(gap: dict, default: dict) -> str:
    """The pruning's part in the context-free Gaussian graph's errors, in words."""
    prices = gap["change_price_nats"]
    cut = -np.log((1 - D.OBSERVER_PRUNE) / D.OBSERVER_PRUNE)
    return (
        " Part of what it loses is the pruning's: a change out of each node costs "
        + ", ".join(f"{n} {-v:.1f}" for n, v in prices.items())
        + f" nats, about what 6.4's mass rule at P_prune {D.OBSERVER_PRUNE:g} drops "
        f"({cut:.1f} nats behind the best path), so a successor into a node whose Gaussian "
        "overlaps the current one's (rest H0 and pressing H2) is dropped at its birth "
        "unless its catch-up samples already favour it ('pruned: mass' in recognize "
        "--explain). With the 20-nat gap alone (P_prune 1, 9.1.1's rule) context free "
        f"marks {100 * gap['accuracy']:.1f} % (default {100 * default['accuracy']:.1f} %); "
        "on seeds 1-10 (diagnostic runs, not on this page) 83.1 % on average against "
        "80.6 %, below the HMM on one seed (by 0.3 points) instead of three. It is not the "
        "default: measured beside the defaults, it gave the same accuracy "
        "on the wrist recordings at about 40 % more recognition time, and on the switching "
        "suite's fresh variant it cost hf-gaussian 5 points (0.686 -> 0.637).")


def _headline(res, hmm_res, check) -> str:
    """One line: points marked correctly on the test runs, ours beside the thesis and the HMM."""
    cf, ctx = res["test_cf"], res["test_ctx"]
    return (f"test runs marked correctly: context free {100 * cf['accuracy']:.0f} % (thesis "
            f"{100 * THESIS['test_cf']['accuracy']:.0f} %, HMM peer "
            f"{100 * _acc(hmm_res['test'][0]):.0f} %; hf-gaussian "
            f"{100 * check['test_cf_gauss']['accuracy']:.0f} %), with context "
            f"{100 * ctx['accuracy']:.0f} % (thesis {100 * THESIS['test_ctx']['accuracy']:.0f} "
            "%" + (f"; hf-gaussian-context {100 * check['test_ctx_gauss']['accuracy']:.0f} %"
                   if "test_ctx_gauss" in check else "") + "); see 'Where ours differ'")


def _differences(res, hmm_res, gm, check, within: dict) -> list[str]:
    means = {k: float(m.theta_mean[0, 0]) for k, m in gm.temporal.items()}
    out = [
        "The stationary classes: the trained means of the LPC mean coefficient are "
        + ", ".join(f"{k} {v:.3f}" for k, v in means.items())
        + " (ordered: " + " < ".join(sorted(means, key=means.get)) + "). The simulated "
        "moving drive raises y_h above the stationary floor and a finger pressed still "
        "carries the motors' force noise through the contact (hf-models; the thesis has "
        "pressed between stationary and moving). The levels are close against their "
        "spread, so the confusions say more about the simulator than about the observer "
        "(reproduce apparatus lists which signal facts hold). The pipeline (train --graph, "
        "recognize, this page) is not tuned to them.",
        "H3 (impact): the transient node ends: a path leaves H3 when the decay stops "
        "(the mean tests of the observer fire on the flat y_h that the decay model "
        f"mispredicts); H2 points marked H3 on the test runs, context free: "
        f"{res['test_cf']['confusion']['matrix'][2][3]}.",
        f"The HMM peer marks {100 * _acc(hmm_res['test'][0]):.1f} % of the test points "
        f"correctly against the observer's {100 * res['test_cf']['accuracy']:.1f} % on the "
        "channel mean (context free). On this signal the three stationary levels overlap "
        "(above); the HMM's label-count transitions keep it in a state for as long "
        "as the runs do, while the observer re-estimates each segment's parameters from "
        "its prior, so a moving segment whose level lies inside the stationary prior can "
        "be taken for stationary. The same pipeline on the 8 gauges as independent "
        "channels (the table's 'ours, 8 channels') sees more of the difference and marks "
        f"{100 * check['test_cf']['accuracy']:.1f} % (context free, "
        f"{100 * check['test_ctx']['accuracy']:.1f} % with context). On synthetic "
        "switching data made without the simulator (benchmarks/bench_observer.py) the "
        "observer with default flags matches the supervised HMM when every state has "
        "fixed parameters and beats it when each segment draws its own (6.1).",
        "Why a run goes wrong: 'contactlab recognize --explain TRIAL' shows, per true "
        "transition, what the path's detectors did at the change, the hypotheses started "
        "and pruned, how well each node's model explains the 0.25 s after it, and how the "
        "models alone label the run's true segments given the true boundaries. On these "
        "runs the last is low (about 64 % of the segments at seed 3, context free): a fresh "
        "AR instance of rest, of moving and of pressing explain a segment of any of the "
        "three within a few nats of each other, so most errors are the models' confusions "
        "rather than missed changes, and lowering T^2 (more hypotheses) does not help "
        "(seed 3: T^2 4 58 %, 2 54 %, 1 50 %, with hundreds of extra marks).",
        "The models' confusion, not the observer, is the cause: the same observer with "
        "each stationary hypothesis a trained Gaussian of y_h (graph hf-gaussian, our "
        "variant: the HMM's emission model, its level fixed at training) marks "
        f"{100 * check['test_cf_gauss']['accuracy']:.1f} % of the test points "
        f"({100 * check['train_cf_gauss']['accuracy']:.1f} % of the training points). "
        "A fresh AR instance re-estimates its level from a prior wide enough to hold every "
        "training block's, so rest, motion and pressing explain one another's segments; "
        "a fixed level does not bend. Where each segment draws its own level (the "
        "switching suite's fresh variant) the thesis's estimated levels are the better "
        "model (datasets_spec/graphs/hf-gaussian.toml gives both measurements).",
    ]
    if "test_ctx_gauss" in check:
        out.append(
            "With context, the Gaussian hypotheses (graph hf-gaussian-context: 7.3.3's edges, "
            "actions and initial state, exactly as hf-context) mark "
            f"{100 * check['test_ctx_gauss']['accuracy']:.1f} % of the test points, against "
            f"the thesis's 95 % and the HMM's {100 * _acc(hmm_res['test'][0]):.1f} %"
            + (f"; with the edges learned from the training labels instead (graph learn "
               f"--models-from hf-gaussian, how the HMM gets its transitions) "
               f"{100 * check['test_learned_gauss']['accuracy']:.1f} %"
               if "test_learned_gauss" in check else "")
            + ". Context free, hf-gaussian prices each change by the rate of changes its "
            "node showed in training (the graph's change_prior, the supervised HMM's "
            "transition matrix with the edges split evenly) and starts from the training "
            "runs' first nodes (initial = \"trained\", the HMM's start probabilities): "
            f"{100 * check['test_cf_gauss']['accuracy']:.1f} % against the HMM's "
            f"{100 * _acc(hmm_res['test'][0]):.1f} %; without that price two overlapping "
            "Gaussians trade the lead at every alarm (seeds 3-6 of the demo's pipeline: "
            "69-75 % without either, 83-89 % with the price, 85-89 % with both). The thesis's graphs leave changes free, "
            "as 6.1 wrote them (it had no transition probabilities): their AR hypotheses "
            "re-estimate a level at each start, whose prior predictive already pays for a "
            "change, and priced they lost about 4 points."
            + (_gap_text(check["test_cf_gap_gauss"], check["test_cf_gauss"])
               if "test_cf_gap_gauss" in check else ""))
    out.append(
        "Transitions: the truth's 'moving' is the fingertip's speed above 1 mm/s "
        "(contactlab/sim/constants.py), which at the end of a move and while the position "
        "controller settles crosses the threshold back and forth: of the test runs' true "
        "transitions, " + _short_share(res["test_cf"]) + " are into or out of a run of rest "
        "or motion shorter than 0.1 s (7.3's unit of 100 samples): the speed label's "
        "flicker more than a change of vibration a detector could mark. The thesis's runs "
        "were segmented by hand, 30 transitions for 12 runs of three or two phases; the "
        "'missed' column counts both. Taking each such run as the run before it leaves "
        + _within_text(within) + " (the second delay table)." + _hindsight_text(within))
    return out


def _within_table(res, check, hmm_paths=None, points=None) -> dict:
    """Per setting: (transitions marked within 0.25 s, transitions, missed) over the test
    runs, label runs shorter than 0.1 s taken as the run before them (missed: the set of
    (trial, sample) of the transitions not marked); with the HMM's state sequences and
    the test points (:func:`labelled_points`), also the HMM peer and the hindsight change
    points of y_h (:func:`contactlab.peers.hindsight.hindsight_path`)."""
    settings = {"thesis's models, context free": res["test_cf"],
                "thesis's models, with context": res["test_ctx"]}
    for key, name in (("test_cf_gauss", "Gaussian hypotheses, context free"),
                      ("test_ctx_gauss", "Gaussian hypotheses, with context"),
                      ("test_learned_gauss", "Gaussian hypotheses, learned edges")):
        if key in check and "_runs" in check[key]:
            settings[name] = check[key]
    out = {}
    for name, r in settings.items():
        out[name] = _within_count((rec.trial_id, rec.truth, rec.result.map_path, rec.fs)
                                  for rec in r["_runs"])
    if hmm_paths is not None and points is not None:
        from contactlab.peers.hindsight import hindsight_path
        from contactlab.peers.hmm import state_path

        fs = res["test_cf"]["_runs"][0].fs
        out[HMM_ROW] = _within_count((p["id"], p["truth"], state_path(s, STATES), fs)
                                     for p, s in zip(points, hmm_paths))
        out[HINDSIGHT_ROW] = _within_count(
            (p["id"], p["truth"], hindsight_path(p["y"], p["truth"], STATES,
                                                 min_run=int(round(0.1 * fs))), fs)
            for p in points)
    return out


HMM_ROW = "supervised HMM peer"
HINDSIGHT_ROW = "hindsight: where y_h's mean changes (no detector)"


def _within_count(runs) -> tuple[int, int, set]:
    """(transitions marked within 0.25 s, transitions, {(trial, sample) missed}) over
    ``(trial, truth, path, fs)`` runs."""
    found = total = 0
    missed = set()
    for tid, truth, path, fs in runs:
        d = detection_delays(truth, path, STATES, window=int(round(0.25 * fs)),
                             min_run=int(round(0.1 * fs)))
        found += d["transitions"] - d["missed"]
        total += d["transitions"]
        missed.update((tid, s) for s in d["missed_at"])
    return found, total, missed


def _hindsight_text(within: dict) -> str:
    """How many of the Gaussian observer's misses (with context) the hindsight change
    points also miss."""
    ours = within.get("Gaussian hypotheses, with context")
    hind = within.get(HINDSIGHT_ROW)
    if ours is None or hind is None:
        return ""
    n, both = len(ours[2]), len(ours[2] & hind[2])
    if not n:
        return " The Gaussian hypotheses with context miss no transition."
    return (f" Of the {n} transition{'s' if n > 1 else ''} the Gaussian hypotheses with "
            f"context miss, {both} {'is' if both == 1 else 'are'} missed by the hindsight "
            "row too: y_h's mean changes more than 0.25 s from the label there, because the "
            "label's speed threshold is crossed while the vibration is still at rest's level "
            "when a move starts or ends slowly.")


def _within_text(within: dict) -> str:
    """'N transitions, marked within 0.25 s by ...' from :func:`_within_table`."""
    n = max(v[1] for v in within.values())
    parts = [f"{name} {v[0]}" for name, v in within.items()]
    return f"{n} transitions, marked within 0.25 s: " + ", ".join(parts)


def _short_share(res) -> str:
    """'K of N': true transitions of the test runs into or out of a run of H0 or H1 (the
    speed label) shorter than 0.1 s of the 250 Hz points."""
    short = total = 0
    for rec in res["_runs"]:
        t = np.asarray(rec.truth)
        lab = t[t >= 0]
        ch = np.flatnonzero(np.diff(lab) != 0) + 1
        runs = np.diff(np.r_[0, ch, len(lab)])
        first = np.r_[0, ch]
        flicker = (runs < 25) & (lab[first] <= 1)
        total += len(ch)
        short += int(np.sum(flicker[:-1] | flicker[1:]))
    return f"{short} of {total}"
