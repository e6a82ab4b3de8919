"""``contactlab report``: a thesis-style figure report of what an archive holds.

Per trial one figure of the measurements (position, velocity, force, strain,
the high-frequency log-energy of section 7.1, ground-truth labels) and one
figure per results stage written by later stages; an HTML page with PNGs and
a PDF. Later stages add their own panels through :data:`RESULT_PLOTTERS`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.archive import open_archive  # noqa: E402
from contactlab.fileio import atomic_directory  # noqa: E402
from contactlab.signals import condition, default_signal  # noqa: E402
from contactlab.progress import progress  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402

#: stage name -> function(trial, results: dict, fig) drawing that stage's figure and
#: returning its caption (what each panel shows, with units).
#: Stages without an entry get the generic drawing of :func:`_plot_results`.
RESULT_PLOTTERS: dict[str, Callable] = {}


def report_archive(path: str | Path, *, out_dir: str | Path, trials: list[str] | None = None,
                   quiet: bool = False) -> dict:
    """Write ``out_dir/index.html`` and ``report.pdf`` for the archive at ``path``.

    Returns a summary: file, out_dir, trials reported, the figures written, the
    recognition summary and the explanation of the trial recognised worst
    (:func:`explain_worst`).
    """
    path = Path(path)
    out_dir = Path(out_dir)
    with atomic_directory(out_dir) as aside:  # a failure leaves no partial report
        summary = _write_report(path, aside, trials, quiet)
    return {"file": summary["file"], "out_dir": str(out_dir), "trials": summary["trials"],
            "figures": summary["figures"], "recognition": summary["recognition"],
            "explained": summary["explained"], "html": str(out_dir / "index.html"), "pdf": str(out_dir / "report.pdf")}


def _write_report(path: Path, out_dir: Path, trials, quiet: bool) -> dict:
    figures: list[str] = []
    with open_archive(path) as archive:
        ids = archive.select(trials)
        page = ReportPage(title=f"Archive report: {path.name}", out_dir=out_dir)
        attrs = archive.attrs
        page.paragraph(f"{len(archive.trial_ids)} trials; written by contactlab "
                       f"{attrs.get('software_version', '?')} on {attrs.get('created', '?')}. "
                       f"{attrs.get('title', '')}")
        page.table(_trial_rows(archive, ids),
                   columns=["trial", "duration (s)", "samples", "rate (Hz)", "controller",
                            "environment", "labels", "results"],
                   caption="Trials in the archive.")
        for tid in progress(ids, total=len(ids), desc="report", quiet=quiet, unit="trial"):
            trial = archive.trial(tid)
            page.heading(f"Trial {tid}")
            desc = trial.attrs.get("description", "")
            if desc:
                page.paragraph(str(desc))
            panels = _measurement_panels(trial)
            fig = _plot_measurements(trial, panels)
            name = f"trial-{_safe(tid)}"
            page.figure(fig, name=name, caption=_measurement_caption(trial, panels))
            figures.append(name)
            for stage in trial.result_stages():
                results = trial.results(stage)
                fig = plt.figure(figsize=(10, 5))
                caption = RESULT_PLOTTERS.get(stage, _plot_results)(trial, results, fig)
                if not fig.texts and not any(ax.get_title() for ax in fig.axes):
                    fig.suptitle(f"Trial {tid}: results of stage '{stage}'", fontsize=10)
                rname = f"trial-{_safe(tid)}-{_safe(stage)}"
                page.figure(fig, name=rname, caption=caption
                            or f"Results of stage '{stage}' for trial {tid}.")
                figures.append(rname)
        recognition = recognition_summary(archive, ids)
        explained = None
        if recognition is not None:
            _recognition_section(page, recognition)
            explained = explain_worst(archive, path, recognition)
            if explained is not None:
                _explain_section(page, explained)
        page.write()
    return {"file": str(path), "trials": ids, "figures": figures, "recognition": recognition,
            "explained": explained}


def explain_worst(archive, path, r: dict) -> dict | None:
    """``recognize --explain`` of the trial recognised worst (the lowest share of labelled
    points, below 100 %), rerun with the graph, models and settings its results name
    (:func:`contactlab.observer.explain.explain_trial`); None when every trial was
    recognised fully or none has an accuracy.  Where the graph or models file can no
    longer be read, ``{"trial", "note"}`` says so."""
    from contactlab.errors import ContactlabError
    from contactlab.observer.explain import explain_trial
    from contactlab.observer.recognize import RecognizeStage

    scored = [t for t in r["trials"] if t["accuracy"] is not None and t["accuracy"] < 1.0]
    if not scored:
        return None
    worst = min(scored, key=lambda t: t["accuracy"])
    trial = archive.trial(worst["trial"])
    params = _parameters(trial.results("recognize"))
    ts = params.get("transient_max_s")
    try:
        stage = RecognizeStage(
            graph=params["graph"], models=params["models"], action=params.get("action"),
            threshold=params["threshold"], change_size=params["change_size"],
            p_prune=params["p_prune"], gap=params["gap"], sides=params["sides"],
            transitions=params.get("transitions", "graph"), label_map=params.get("label_map"),
            transient_max_s=None if isinstance(ts, dict) else (0 if ts is None else ts),
            write=False)
        label_map, _ = stage._trial_label_map(trial)
        ex = explain_trial(trial, stage.graph, stage.built, reduce=stage.models.reduce,
                           action=stage.action, observer_kw=stage.observer_kw,
                           label_map=label_map, path=path)
    except (ContactlabError, OSError, KeyError, ValueError) as exc:
        return {"trial": worst["trial"], "note": f"the explanation needs the graph and "
                f"models files the results name, which could not be read ({exc})"}
    return ex


def _explain_section(page, ex: dict) -> None:
    page.heading(f"Why trial {ex['trial']} was recognised worst")
    if "transitions" not in ex:
        page.paragraph(f"No explanation: {ex.get('note', 'nothing to explain')}. "
                       f"'contactlab recognize ARCHIVE --graph G --models M --explain "
                       f"{ex['trial']}' gives it.")
        return
    if ex.get("accuracy") is None:
        page.paragraph(ex.get("note", "The trial has no ground truth to explain against."))
        return
    fs = ex["rate_hz"]
    page.paragraph(
        f"The final MAP path marks {100 * ex['accuracy']:.1f} % of its labelled points "
        f"correctly; with the true boundaries given, the models alone label "
        f"{100 * ex['segment_accuracy']:.1f} % (each true segment by the node whose fresh "
        f"instance explains it best), so the gap between the two is the path search's and "
        f"the rest the models'. Each true change below: what the observer did within "
        f"{ex['window_samples']} samples of it ('contactlab recognize --explain "
        f"{ex['trial']}' gives the detectors' statistics and every alarm).")
    rows = []
    for tr in ex["transitions"]:
        alarms = len({e["time"] for e in tr["events"]})
        rows.append([f"{tr['from']} -> {tr['to']}", f"{tr['time_s']:.3f}", tr["verdict"],
                     "-" if tr["delay"] is None else f"{tr['delay']}",
                     tr["path_node"], alarms, f"{tr['margin']:+.1f}"])
    page.table(rows, columns=["true change", "time (s)", "verdict", "delay (samples)",
                              "path's node then", "alarm times", "true node's margin (nats)"],
               caption=f"The true changes of trial {ex['trial']} ({fs:g} Hz). Verdicts: "
                       "detected; models confuse (another node explains the samples after "
                       "the change better); pruned (the new path was started and dropped); "
                       "no alarm; not kept. The margin: the true node's fresh log-likelihood "
                       "over the window minus the best other node's.")


def recognition_summary(archive, ids) -> dict | None:
    """How well ``recognize`` did on the labelled points of trials ``ids`` (None: not run).

    Pooled over the trials with ``results/recognize`` and ground truth: the
    point confusion of the final MAP path and of the on-line MAP node (rows
    true node, columns chosen; unlabelled points left out), their accuracies,
    and two chance levels to read them against: always choosing the most
    frequent true node, and choosing uniformly among the graph's nodes.
    """
    from contactlab.metrics import confusion_matrix

    names, total, online, per_trial, graph = None, None, None, [], None
    for tid in ids:
        trial = archive.trial(tid)
        if "recognize" not in trial.result_stages():
            continue
        res = trial.results("recognize")
        nodes = [x for x in str(res.attrs.get("nodes", "")).split(",") if x]
        if names is None:
            names = nodes
            total = np.zeros((len(names), len(names)), np.int64)
            online = total.copy()
            graph = _parameters(res).get("graph")
        if nodes != names or "truth" not in res:
            per_trial.append({"trial": tid, "accuracy": None, "points": 0})
            continue
        c = confusion_matrix(res["truth"], res["labels"], len(names))[0]
        total += c
        if "map_node" in res:
            online += confusion_matrix(res["truth"], res["map_node"], len(names))[0]
        n = int(c.sum())
        per_trial.append({"trial": tid, "points": n,
                          "accuracy": float(np.trace(c) / n) if n else None,
                          "path": str(res.attrs.get("merged_path", ""))})
    if names is None:
        return None
    n = int(total.sum())
    counts = total.sum(axis=1)
    title, thesis, labels = _graph_info(graph)
    return {"graph": graph, "graph_title": title, "graph_thesis": thesis, "nodes": names,
            "node_labels": {k: labels[k] for k in names if labels.get(k, k) != k},
            "points": n,
            "accuracy": float(np.trace(total) / n) if n else None,
            "accuracy_online": float(np.trace(online) / online.sum()) if online.sum() else None,
            "chance_majority": float(counts.max() / n) if n else None,
            "majority_node": names[int(np.argmax(counts))] if n else None,
            "chance_uniform": 1.0 / len(names),
            "confusion": total.tolist(), "trials": per_trial}


def _graph_info(graph) -> tuple[str | None, str, dict]:
    """Title, thesis section and node labels (name -> label) of the graph file the results
    name (None, "", {} if unreadable)."""
    from contactlab.errors import ContactlabError
    from contactlab.observer.graph import load_graph

    if not graph:
        return None, "", {}
    try:
        g = load_graph(graph)
    except (ContactlabError, OSError, ValueError):
        return None, "", {}
    return g.title, str(g.thesis or ""), {nd.name: nd.label for nd in g.nodes if nd.label}


def _named(r: dict, node: str) -> str:
    """``node`` with its graph label where the graph gives one: "H0 (stationary, free)"."""
    label = r.get("node_labels", {}).get(node)
    return f"{node} ({label})" if label else str(node)


def _recognition_section(page, r: dict) -> None:
    page.heading("What was recognised, and how well")
    if r.get("graph"):
        text = f"Feature graph: {r['graph']}" + (f" ({r['graph_title']})"
                                                 if r.get("graph_title") else "") + "."
        if r.get("graph_thesis", "").startswith("7.3"):
            text += (" 'contactlab reproduce hf-recognition' runs the same pipeline on the "
                     "thesis's 15 training and 12 test runs and puts its accuracy beside the "
                     "thesis's and a Gaussian HMM's on the same data.")
        page.paragraph(text)
    if not r["points"]:
        page.paragraph("No trial with recognition results has ground truth named like the "
                       "graph's nodes, so no accuracy can be given.")
        return
    page.paragraph(
        f"Over {r['points']} labelled points of {sum(t['points'] > 0 for t in r['trials'])} "
        f"trials the final MAP path marks {100 * r['accuracy']:.1f} % correctly (the on-line "
        f"MAP node: {100 * r['accuracy_online']:.1f} %). Chance levels to read this against: "
        f"always choosing the most frequent true node ({_named(r, r['majority_node'])}) scores "
        f"{100 * r['chance_majority']:.1f} %, choosing uniformly among the "
        f"{len(r['nodes'])} nodes {100 * r['chance_uniform']:.1f} %. A point is a sample of "
        "the observer's signal; unlabelled points are left out.")
    m = np.asarray(r["confusion"])
    rows = []
    for name, row in zip(r["nodes"], m):
        n = row.sum()
        rows.append([_named(r, name), *row.tolist(), int(n),
                     f"{100 * row[len(rows)] / n:.1f} %" if n else "-"])
    page.table(rows, columns=["true \\ chosen", *r["nodes"], "points", "row correct"],
               caption="Point confusion of the final MAP path, pooled over the trials (rows: "
                       "true node; columns: the node the path chose).")
    page.table([[t["trial"], t["points"], "-" if t["accuracy"] is None
                 else f"{100 * t['accuracy']:.1f} %", t.get("path", "")]
                for t in r["trials"]],
               columns=["trial", "labelled points", "marked correctly", "MAP path (node@s)"],
               caption="Per trial: the share of labelled points the final MAP path marks "
                       "correctly, and the path itself.")


def _trial_rows(archive, ids) -> list[list]:
    rows = []
    for tid in ids:
        t = archive.trial(tid)
        names = t.label_names or []
        rows.append([tid, t.duration_s, t.n_samples, t.rate_hz, t.attrs.get("controller", ""),
                     t.attrs.get("environment", ""), ", ".join(names) or "-",
                     ", ".join(t.result_stages()) or "-"])
    return rows


def plot_trial(trial):
    """The measurement figure of one archive trial (like thesis figs 7.5 and 9.1).

    Panels: position, velocity, force, raw strains, the high-frequency
    log-energy y_h of section 7.1 and, when the trial has them, its ground-truth
    labels; impact intervals of the simulator's truth are shaded on every panel.
    Returns the matplotlib Figure (the caller saves or closes it).
    """
    fig = _plot_measurements(trial)
    intervals = trial.truth("impact_intervals") if hasattr(trial, "truth") else None
    if intervals is not None:
        for ax in fig.axes:
            for a, b in np.asarray(intervals).reshape(-1, 2):
                ax.axvspan(a, b, color="C3", alpha=0.15, lw=0)
    return fig


def _measurement_panels(trial) -> list[tuple]:
    """(y label with unit, x, y, legend entries or None, caption phrase) per panel present."""
    t = trial.time
    panels = []
    if trial.position is not None:
        cols = _columns(trial, "position", ["x", "y", "z"])
        unit = "m, rad" if "theta" in cols else "m"
        panels.append((f"position ({unit})", t, trial.position, cols, f"position ({unit})"))
    if trial.velocity is not None:
        panels.append(("velocity (m/s)", t, trial.velocity,
                       _columns(trial, "velocity", ["x", "y", "z"]), "velocity"))
    if trial.wrench is not None:
        cols = _columns(trial, "wrench", ["fx", "fy", "fz", "tx", "ty", "tz"])[:3]
        panels.append(("force (N)", t, trial.wrench[:, :3], cols, "force (wrench[:, :3])"))
    units = str(trial.dataset_attrs("strain").get("units", "V")) if trial.strain is not None \
        else ""
    if trial.strain is not None:
        c = trial.strain.shape[1]
        panels.append((f"strain ({units})", t, trial.strain,
                       [f"gauge {k + 1}" for k in range(c)] if c <= 8 else None,
                       f"raw strains of the {c} gauges"))
    hf_source = trial.strain if trial.strain is not None else trial.wrench
    # y_h is the energy above the 125 Hz lowpass (7.1): it exists only above 250 Hz
    if hf_source is not None and len(t) > 16 and trial.rate_hz > 2 * 125.0:
        hf = condition(trial, "hf", source=default_signal(trial))
        what, unit = ("strains", units) if trial.strain is not None else ("wrench", "N")
        c = hf.y.shape[1] if hf.y.ndim > 1 else 1
        legend = ([f"gauge {k + 1}" for k in range(c)] if trial.strain is not None
                  else ["fx", "fy", "fz", "tx", "ty", "tz"][:c]) if c <= 8 else None
        # plotted at the newest input sample of each block (causal, as on line)
        panels.append((f"y_h (log {unit})", hf.times, hf.y, legend,
                       f"high-frequency log-energy y_h = log|y_d| of the {what}, averaged "
                       "in blocks of 8 (section 7.1)"))
    return panels


def _columns(trial, name: str, default: list[str]) -> list[str]:
    cols = trial.dataset_attrs(name).get("columns")
    return [str(c) for c in cols] if cols is not None and len(cols) else default


def _measurement_caption(trial, panels) -> str:
    parts = [p[4] for p in panels] + (["ground-truth labels"] if trial.labels is not None
                                      else [])
    return (f"Trial {trial.id}: measurements at {trial.rate_hz:g} Hz against time (s). "
            f"Panels from the top: {', '.join(parts)}.")


def _plot_measurements(trial, panels=None):
    t = trial.time
    panels = _measurement_panels(trial) if panels is None else panels
    has_labels = trial.labels is not None
    n = len(panels) + (1 if has_labels else 0)
    fig, axes = plt.subplots(max(n, 1), 1, figsize=(10, 1.9 * max(n, 1) + 0.6), sharex=True,
                             squeeze=False)
    axes = axes[:, 0]
    for ax, (label, x, y, legend, _) in zip(axes, panels):
        ax.plot(x, y, lw=0.7)
        ax.set_ylabel(label, fontsize=8)
        if legend:
            ax.legend(legend, fontsize=6, loc="upper right", ncol=min(len(legend), 8),
                      framealpha=0.7)
    if has_labels:
        ax = axes[len(panels)]
        _truth_steps(ax, t, trial.labels, trial.label_names or [])
        ax.set_ylabel("truth", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"Trial {trial.id}: measurements", fontsize=10)
    fig.tight_layout()
    return fig


def _truth_steps(ax, t, codes, names, **style) -> None:
    """Label codes as a step line with one tick per label visited ('unlabelled' for < 0)."""
    codes = np.asarray(codes)
    present, rows = np.unique(codes, return_inverse=True)
    ax.step(t, rows, where="post", lw=style.pop("lw", 1.0), color=style.pop("color", "k"),
            **style)
    ax.set_yticks(range(len(present)))
    ax.set_yticklabels([names[c] if 0 <= c < len(names) else "unlabelled" for c in present],
                       fontsize=7)
    ax.set_ylim(-0.5, len(present) - 0.5)


def _stage_axes(fig, n: int):
    return fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]


def _plot_results(trial, results: dict, fig) -> str:
    """Generic drawing of a stage without its own plotter.

    Per-sample series become panels against time; a series ``X`` with an
    ``X_time_s`` dataset is drawn against those times; other short ``*_s``
    datasets are event times, drawn as vertical lines.
    """
    n = trial.n_samples
    series, events = {}, {}
    for k, v in results.items():
        v = np.asarray(v)
        if k.endswith("_time_s") or v.ndim < 1 or not len(v):
            continue
        own = results.get(f"{k}_time_s")
        if own is not None and len(own) == len(v):
            series[k] = (np.asarray(own, dtype=float), v)
        elif len(v) == n and not k.endswith("_s"):
            series[k] = (trial.time, v)
        elif k.endswith("_s") and v.ndim == 1 and len(v) <= 200:
            events[k] = v
    axes = _stage_axes(fig, max(len(series), 1))
    for ax, (k, (x, v)) in zip(axes, series.items()):
        ax.plot(x, v, lw=0.7)
        ax.set_ylabel(k, fontsize=8)
    if not series:
        _signal_panel(axes[0], trial)
    for i, (k, times) in enumerate(events.items()):
        for ax in axes:
            for j, x in enumerate(times):
                ax.axvline(x, color=f"C{(i + 3) % 10}", lw=0.8, label=k if j == 0 else None)
    if events:
        axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    return (f"Per-sample results against time (s): {', '.join(series) or 'none'}"
            + (f"; vertical lines: {', '.join(events)} (s)" if events else "") + ".")


def _signal_panel(ax, trial) -> str:
    """The trial's strains (or force) in grey as a backdrop; returns what was drawn."""
    if trial.strain is not None:
        units = trial.dataset_attrs("strain").get("units", "V")
        ax.plot(trial.time, trial.strain, lw=0.4, color="0.65")
        ax.set_ylabel(f"strain ({units})", fontsize=8)
        return "the raw strains"
    if trial.wrench is not None:
        ax.plot(trial.time, trial.wrench[:, :3], lw=0.4, color="0.65")
        ax.set_ylabel("force (N)", fontsize=8)
        return "the force"
    return "nothing"


def _plot_segment(trial, results: dict, fig) -> str:
    """``segment``: the signal with detected (and true) boundaries, and the detector input."""
    stat = results.get("statistic")
    axes = _stage_axes(fig, 1 if stat is None else 2)
    ax1, ax2 = axes[0], (axes[1] if stat is not None else None)
    drew = _signal_panel(ax1, trial)
    for j, b in enumerate(np.asarray(results.get("boundaries_s", [])).ravel()):
        for ax in (ax1, ax2):
            if ax is not None:
                ax.axvline(b, color="C3", lw=1.0, label="detected boundary" if j == 0 and
                           ax is ax1 else None)
    segs = trial.segments
    true_b = [] if segs is None else np.asarray(segs["start_s"], float)[1:]
    for j, b in enumerate(true_b):
        ax1.axvline(b, color="k", lw=1.0, ls="--", label="true boundary" if j == 0 else None)
    ax1.legend(fontsize=7, loc="upper right")
    params = _parameters(results)
    glr = params.get("method") == "glr"
    if ax2 is not None:
        x = results.get("statistic_time_s")
        stat = np.asarray(stat, float)
        x = trial.time if x is None or len(x) != len(stat) else np.asarray(x, float)
        ax2.plot(x, stat, lw=0.6, color="C0",
                 label=None if stat.ndim > 1 else ("likelihood ratio per degree of freedom"
                                                   if glr else "chi-square of the innovations"))
        ax2.set_yscale("log")
        ax2.set_ylabel("detector input\n(" + ("GLR" if glr else "chi-square") + ", -)",
                       fontsize=8)
        if stat.ndim == 1:
            ax2.legend(fontsize=7, loc="upper right")
    (ax2 or ax1).set_xlabel("time (s)")
    signal = getattr(results, "attrs", {}).get("signal", "?")
    fig.suptitle(f"Trial {trial.id}: segmentation of the {signal} signal (7.2.1)", fontsize=10)
    fig.tight_layout()
    th = params.get("threshold")
    what, bottom = _SEGMENT_WORDS[glr]
    return (f"Segmentation of trial {trial.id} ({what}"
            + (f", threshold {th:g}" if th is not None else "") + "). Top: "
            f"{drew} with the detected boundaries (red, the first sample of each new segment)"
            + (" and the ground-truth boundaries (dashed)" if len(true_b) else "") + "."
            + (f" Bottom: {bottom}" if ax2 is not None else ""))


#: (method, bottom panel) words of the segment figure: page-hinkley, glr
_SEGMENT_WORDS = {
    False: ("AR + Page-Hinkley, 7.2.1", "the sum of squared normalised innovations fed to the "
            "Page-Hinkley test (log scale; NaN while the estimators restart)."),
    True: ("two-model AR likelihood-ratio test", "the window likelihood ratio per degree of "
           "freedom; peaks above the threshold are changes (log scale)."),
}


def _plot_label(trial, results: dict, fig) -> str:
    """``label``: each block's chosen class beside its true class."""
    names = [str(x) for x in getattr(results, "attrs", {}).get("label_names", [])]
    start = np.asarray(results["start_s"], float)
    end = np.asarray(results["end_s"], float)
    pred = np.asarray(results["predicted"], int)
    true = np.asarray(results.get("true", np.full(len(pred), -1)), int)
    ax = _stage_axes(fig, 1)[0]
    ticks = sorted(set(pred.tolist()) | set(true.tolist()))
    row = {c: i for i, c in enumerate(ticks)}
    to_row = np.vectorize(row.get, otypes=[float])
    ok = true == pred
    ax.hlines(to_row(true) + 0.12, start, end, color="k", lw=3, label="true class")
    for good, color, what in ((True, "C2", "correct"), (False, "C3", "wrong")):
        sel = ok == good
        if sel.any():
            ax.hlines(to_row(pred[sel]) - 0.12, start[sel], end[sel], color=color, lw=3,
                      label=f"chosen, {what}")
    ax.set_yticks(range(len(ticks)), [names[c] if 0 <= c < len(names) else "unlabelled / "
                                      "not a model class" for c in ticks], fontsize=7)
    ax.set_ylim(-0.6, len(ticks) - 0.4)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("class", fontsize=8)
    ax.legend(fontsize=7, loc="upper right", ncol=3)
    scored = true >= 0
    acc = float(np.mean(pred[scored] == true[scored])) if scored.any() else None
    fig.suptitle(f"Trial {trial.id}: block labels (7.2.2)"
                 + ("" if acc is None else f", {100 * acc:.1f} % of {scored.sum()} blocks "
                                           "correct"), fontsize=10)
    fig.tight_layout()
    return (f"Likelihood labelling of trial {trial.id} (7.2.2): one bar per block of "
            f"{_parameters(results).get('block', '?')} samples, black its true class, "
            "coloured the class of largest likelihood (green where it matches).")


def _plot_estimate(trial, results: dict, fig) -> str:
    """``estimate``: per piece the degree of constraint (or fit) and its spread."""
    start = np.asarray(results["start_s"], float)
    end = np.asarray(results["end_s"], float)
    panels = [(k, lab) for k, lab in (("degree", "degree of constraint (-)"),
                                      ("angle_sd_deg", "normal direction sd (deg)"),
                                      ("angle_error_deg", "error vs true normal (deg)"),
                                      ("log_likelihood", "log-likelihood (-)"))
              if k in results]
    axes = _stage_axes(fig, max(len(panels), 1))
    for ax, (k, lab) in zip(axes, panels):
        ax.hlines(np.asarray(results[k], float), start, end, lw=3, color="C0",
                  label="estimated, per piece")
        ax.set_ylabel(lab, fontsize=8)
        if k == "degree":
            ax.set_yticks(range(4))
            ax.set_ylim(-0.5, 3.5)
        ax.legend(fontsize=7, loc="upper right")
    if not panels:
        _signal_panel(axes[0], trial)
    axes[-1].set_xlabel("time (s)")
    model = getattr(results, "attrs", {}).get("model", "cartesian")
    fig.suptitle(f"Trial {trial.id}: constraint estimation ({model}, 8.1-8.2)", fontsize=10)
    fig.tight_layout()
    return (f"Constraint estimation of trial {trial.id} ({model}): one bar per estimated "
            "piece over its time span; "
            + "; ".join({"degree": "the degree of constraint chosen by the largest "
                                   "log-likelihood over 0..3 (8.2)",
                         "angle_sd_deg": "the standard deviation of the constraint normals' "
                                         "direction",
                         "angle_error_deg": "the angle between the estimated and the true "
                                            "normals",
                         "log_likelihood": "the fit's log-likelihood"}[k] for k, _ in panels)
            + ". Undetermined pieces are gaps.")


def _plot_recognize(trial, results: dict, fig) -> str:
    """``recognize``: node probabilities over time, and truth beside the MAP labels."""
    t = np.asarray(results["time_s"], dtype=float)
    prob = np.asarray(results["node_prob"], dtype=float)
    attrs = getattr(results, "attrs", {})
    names = [x for x in str(attrs.get("nodes", "")).split(",") if x]
    names = names if len(names) == prob.shape[1] else [f"node {k}" for k in range(prob.shape[1])]
    ax1, ax2 = _stage_axes(fig, 2)
    ax1.stackplot(t, prob.T, labels=names, alpha=0.85)
    ax1.set_ylim(0, 1)
    ax1.set_ylabel("P(node | data so far)", fontsize=8)
    ax1.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0), title="node",
               title_fontsize=7)
    truth = np.asarray(results["truth"]) if "truth" in results else None
    codes = np.arange(len(names))
    if truth is not None and (truth < 0).any():
        codes = np.r_[-1, codes]            # a row for unlabelled points
    row = {c: i for i, c in enumerate(codes)}
    to_rows = np.vectorize(lambda c: row.get(int(c), 0), otypes=[float])
    ax2.step(t, to_rows(results["labels"]), where="post", lw=1.6, color="C3",
             label="final MAP path")
    if "map_node" in results:
        ax2.step(t, to_rows(results["map_node"]) - 0.1, where="post", lw=0.8, color="C0",
                 alpha=0.8, label="on-line MAP node")
    if truth is not None:
        ax2.step(t, to_rows(truth) + 0.1, where="post", lw=0.9, ls="--", color="k",
                 label="truth")
    ax2.set_yticks(range(len(codes)), [names[c] if c >= 0 else "unlabelled" for c in codes],
                   fontsize=7)
    ax2.set_ylim(-0.5, len(codes) - 0.5)
    ax2.set_ylabel("node", fontsize=8)
    ax2.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0))
    ax2.set_xlabel("time (s)")
    acc = attrs.get("accuracy")
    fig.suptitle(f"Trial {trial.id}: contact-state recognition (6.4)"
                 + ("" if acc is None else f", {100 * float(acc):.1f} % of labelled points "
                                           "marked correctly"), fontsize=10)
    fig.tight_layout()
    return (f"Recognition of trial {trial.id}. Top: each node's probability after each sample, "
            "summed over the paths the observer keeps, using only the data up to that "
            "sample. Bottom: the final MAP path (the single most probable sequence of nodes "
            "given the whole trial, the labelling the observer ends with), the on-line MAP "
            "node (the most probable node after each sample) and the truth. The MAP path can "
            "sit at a node that the top panel does not show as most probable: the "
            "probabilities there are pointwise and on-line, summed over many paths, while the "
            "MAP path is one whole path chosen with hindsight: a later change can make an "
            "earlier, then less probable, hypothesis the best explanation of the past.")


RESULT_PLOTTERS.update(segment=_plot_segment, label=_plot_label, estimate=_plot_estimate,
                       recognize=_plot_recognize)


def _parameters(results) -> dict:
    """The stage's decoded parameters (:class:`~contactlab.archive.reader.Results`), or none."""
    params = getattr(results, "parameters", None)
    return params if isinstance(params, dict) else {}


def _safe(s: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in str(s))
