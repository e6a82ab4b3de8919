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
from contactlab.signals import condition  # noqa: E402
from contactlab.progress import progress  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402

#: stage name -> function(trial, results: dict, fig) drawing that stage's figure.
#: Stages without an entry get the generic drawing of :func:`_plot_results`.
RESULT_PLOTTERS: dict[str, Callable] = {}


def report_archive(path: str | Path, *, out_dir: str | Path, trials: list[str] | None = None,
                   quiet: bool = False) -> dict:
    """Write ``out_dir/index.html`` and ``report.pdf`` for the archive at ``path``.

    Returns a summary: file, out_dir, trials reported and the figures written.
    """
    path = Path(path)
    out_dir = Path(out_dir)
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
            fig = _plot_measurements(trial)
            name = f"trial-{_safe(tid)}"
            page.figure(fig, name=name, caption=_measurement_caption(trial))
            figures.append(name)
            for stage in trial.result_stages():
                results = trial.results(stage)
                fig = plt.figure(figsize=(10, 5))
                RESULT_PLOTTERS.get(stage, _plot_results)(trial, results, fig)
                rname = f"trial-{_safe(tid)}-{_safe(stage)}"
                page.figure(fig, name=rname, caption=f"Results of stage '{stage}' for trial {tid}.")
                figures.append(rname)
        paths = page.write()
    return {"file": str(path), "out_dir": str(out_dir), "trials": ids, "figures": figures,
            "html": str(paths["html"]), "pdf": str(paths["pdf"])}


def _trial_rows(archive, ids) -> list[list]:
    rows = []
    for tid in ids:
        t = archive.trial(tid)
        names = t.label_names or []
        rows.append([tid, t.duration_s, t.n_samples, t.rate_hz, t.attrs.get("controller", ""),
                     t.attrs.get("environment", ""), ", ".join(names) or "-",
                     ", ".join(t.result_stages()) or "-"])
    return rows


def _measurement_caption(trial) -> str:
    return (f"Trial {trial.id}: measurements at {trial.rate_hz:g} Hz. Panels from the top: "
            "position, velocity, force (wrench), raw strains, high-frequency log-energy "
            "y_h = log|y_d| averaged in blocks of 8 (section 7.1), ground-truth labels.")


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


def _plot_measurements(trial):
    t = trial.time
    panels = []
    if trial.position is not None:
        panels.append(("position (m)", t, trial.position, ["x", "y", "z"]))
    if trial.velocity is not None:
        panels.append(("velocity (m/s)", t, trial.velocity, ["x", "y", "z"]))
    if trial.wrench is not None:
        panels.append(("force (N)", t, trial.wrench[:, :3], ["fx", "fy", "fz"]))
    hf_source = trial.strain if trial.strain is not None else trial.wrench
    if trial.strain is not None:
        panels.append(("strain", t, trial.strain, None))
    if hf_source is not None and len(t) > 16:
        hf = condition(trial, "hf", source="strain" if trial.strain is not None else "wrench")
        # plotted at the newest input sample of each block (causal, as on line)
        panels.append(("log-energy y_h", hf.times, hf.y, None))
    has_labels = trial.labels is not None
    n = len(panels) + (1 if has_labels else 0)
    fig, axes = plt.subplots(max(n, 1), 1, figsize=(10, 1.9 * max(n, 1) + 0.6), sharex=True,
                             squeeze=False)
    axes = axes[:, 0]
    for ax, (label, x, y, legend) in zip(axes, panels):
        ax.plot(x, y, lw=0.7)
        ax.set_ylabel(label, fontsize=8)
        if legend:
            ax.legend(legend, fontsize=7, loc="upper right", ncol=len(legend))
    if has_labels:
        ax = axes[len(panels)]
        names = trial.label_names or []
        # only the labels this trial visits, in code order, one row each
        present, rows = np.unique(trial.labels, return_inverse=True)
        ax.step(t, rows, where="post", lw=1.0, color="k")
        ax.set_yticks(range(len(present)))
        ax.set_yticklabels([names[c] if 0 <= c < len(names) else "unlabelled" for c in present],
                           fontsize=7)
        ax.set_ylabel("truth", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"Trial {trial.id}", fontsize=10)
    fig.tight_layout()
    return fig


def _plot_results(trial, results: dict, fig) -> None:
    """Generic drawing: per-sample series as panels; ``*_s`` datasets as event lines."""
    n = trial.n_samples
    series = {k: np.asarray(v) for k, v in results.items()
              if np.ndim(v) >= 1 and len(v) == n and not k.endswith("_s")}
    events = {k: np.asarray(v).ravel() for k, v in results.items() if k.endswith("_s")}
    axes = fig.subplots(max(len(series), 1), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (k, v) in zip(axes, series.items()):
        ax.plot(trial.time, v, lw=0.7)
        ax.set_ylabel(k, fontsize=8)
    if not series:
        src = trial.strain if trial.strain is not None else trial.wrench
        if src is not None:
            axes[0].plot(trial.time, src, lw=0.5, color="0.6")
    for ax in axes:
        for k, times in events.items():
            for x in times:
                ax.axvline(x, color="C3", lw=0.8)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()


def _plot_recognize(trial, results: dict, fig) -> None:
    """``recognize``: node probabilities over time, and truth beside the MAP labels."""
    t = np.asarray(results["time_s"], dtype=float)
    prob = np.asarray(results["node_prob"], dtype=float)
    names = [x for x in str(getattr(results, "attrs", {}).get("nodes", "")).split(",") if x]
    names = names if len(names) == prob.shape[1] else [f"node {k}" for k in range(prob.shape[1])]
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.stackplot(t, prob.T, labels=names, alpha=0.85)
    ax1.set_ylim(0, 1)
    ax1.set_ylabel("P(node)", fontsize=8)
    ax1.legend(fontsize=7, ncol=len(names), loc="upper right")
    ax2.step(t, np.asarray(results["labels"]), where="post", lw=1.2, label="MAP path")
    if "truth" in results:
        ax2.step(t, np.asarray(results["truth"]), where="post", lw=0.8, ls="--", color="k",
                 label="truth")
    ax2.set_yticks(range(len(names)), names, fontsize=7)
    ax2.legend(fontsize=7, loc="upper right")
    ax2.set_xlabel("time (s)")
    fig.tight_layout()


RESULT_PLOTTERS["recognize"] = _plot_recognize


def _safe(s: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in str(s))
