"""datasets: one typical simulated trial of every dataset spec, beside the thesis's setup.

For each spec in ``datasets_spec/`` that the simulator can run, trial 0 (run
seed ``seed``) is simulated through the same acquisition path as
``contactlab acquire`` into a temporary archive (validated, then discarded:
``contactlab acquire --spec NAME --trials 1`` makes the same trials) and drawn like figs 7.5 and 9.1:
position, velocity, force, strains, the log-energy y_h of section 7.1 and the
ground-truth labels, with impact intervals shaded. A table lists every
dataset's trials and setup beside the thesis's counts.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contactlab.acquire.record import record  # noqa: E402
from contactlab.acquire.sim import SimSource  # noqa: E402
from contactlab.acquire.spec import load_all  # noqa: E402
from contactlab.archive import open_archive, validate_archive  # noqa: E402
from contactlab.fileio import write_text_atomic  # noqa: E402
from contactlab.progress import progress  # noqa: E402
from contactlab.report.archive_report import plot_trial  # noqa: E402
from contactlab.report.page import ReportPage  # noqa: E402


def _setup(spec) -> str:
    parts = []
    for g in spec.groups:
        env = g.environment.get("kind", "?")
        extra = {k: v for k, v in g.environment.items() if k != "kind"}
        if extra:
            env += " (" + ", ".join(f"{k}={v}" for k, v in extra.items()) + ")"
        ctrl = g.controller.get("kind", "?")
        moves = f", moves {list(g.move_duration_s)} s" if g.move_duration_s else ""
        parts.append(f"{g.name} x{g.trials}: {env}; {ctrl}{moves}; {g.duration_s:g} s")
    return " | ".join(parts)


def run(*, out_dir: Path, seed: int, quiet: bool = False) -> dict:
    """Simulate trial 0 of every ready spec, draw it, and tabulate every spec."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    specs = load_all()
    with tempfile.TemporaryDirectory() as tmp:
        return _run(specs, Path(tmp) / "datasets.h5", out_dir=out_dir, seed=seed, quiet=quiet)


def _run(specs, archive: Path, *, out_dir: Path, seed: int, quiet: bool) -> dict:
    ready = [s for s in specs if s.ready]
    for i, spec in enumerate(progress(ready, total=len(ready), desc="datasets", quiet=quiet,
                                      unit="spec")):
        record(SimSource(spec), out=archive, n_trials=1, seed=seed, append=i > 0,
               force=i == 0, title="One typical trial per dataset spec", quiet=True,
               log=lambda m: None)
    problems = [str(p) for p in validate_archive(archive)]

    page = ReportPage(title="Simulated datasets: one typical trial each", out_dir=out_dir)
    page.paragraph(
        "The thesis's recordings are gone, so every experiment runs on data from the "
        "simulator (contactlab.sim). Each dataset of the thesis is a spec file in "
        "datasets_spec/ (values commented with their thesis sections); "
        "'contactlab acquire --spec NAME --out FILE' records it. Below, trial 0 of each spec "
        f"(run seed {seed}) and a table of the datasets beside the thesis's trial counts. "
        f"The archive of these trials validates: {'yes' if not problems else 'NO'}.")
    rows = []
    for s in specs:
        rows.append([s.name, s.thesis, ", ".join(s.experiments) or "-",
                     s.thesis_trials if s.thesis_trials else "not stated", s.n_trials,
                     f"{s.rate_hz:g}", s.labels, _setup(s),
                     "simulated" if s.ready else s.status])
    page.table(rows, columns=["spec", "thesis", "experiments", "thesis trials", "our trials",
                              "rate (Hz)", "labels", "groups: environment; controller; length",
                              "status"],
               caption="Every dataset spec. 'thesis trials' is the count the thesis reports; "
                       "ours equals it wherever the thesis gives one. Notes and "
                       "trial-to-trial variation are in each spec file.")
    notes = [f"{s.name}: {s.notes}" for s in specs if s.notes]
    if notes:
        page.note(" ".join(notes))
    page.note("Units: the thesis's hf-model moves (0,0.7,0.7) and (1,0,0) carry no units; "
              "we read them as inches (see datasets_spec/hf-train.toml).")
    figures = []
    truth_summary = {}
    with open_archive(archive) as arc:
        for trial in arc:
            spec_name = trial.attrs.get("spec", trial.id)
            page.heading(f"{spec_name}: {trial.attrs.get('description', '')}", level=3)
            fig = plot_trial(trial)
            name = f"{spec_name}-trial"
            page.figure(fig, name=name, caption=_caption(trial))
            plt.close(fig)
            figures.append(name)
            labels = trial.labels
            names = trial.label_names or []
            counts = {names[c]: int((labels == c).sum()) for c in range(len(names))
                      if (labels == c).any()}
            truth_summary[spec_name] = {
                "samples": trial.n_samples, "impacts": int(len(trial.truth("impact_intervals"))),
                "labels": counts}
    paths = page.write()
    summary = {"valid": not problems, "problems": problems[:5],
               "specs": [s.name for s in specs], "simulated": [s.name for s in ready],
               "not_simulated": {s.name: s.status for s in specs if not s.ready},
               "trials": truth_summary, "figures": figures, "html": str(paths["html"])}
    write_text_atomic(out_dir / "results.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _caption(trial) -> str:
    labels = trial.label_names or []
    n_imp = len(np.asarray(trial.truth("impact_intervals")).reshape(-1, 2))
    return (f"Trial {trial.id} ({trial.attrs.get('environment', '')}, "
            f"{trial.attrs.get('controller', '')}, {trial.rate_hz:g} Hz). From the top: "
            "position, velocity, force, raw strains, log-energy y_h (7.1), ground-truth labels "
            f"({', '.join(labels)}); {n_imp} impact interval(s) of the simulator's truth shaded.")
