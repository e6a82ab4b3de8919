"""Run experiments into a reports directory and keep its index page current."""

from __future__ import annotations

import json
import time
from pathlib import Path

from contactlab import __version__
from contactlab.errors import UsageError
from contactlab.experiments import EXPERIMENTS, Experiment
from contactlab.fileio import write_text_atomic
from contactlab.report.page import ReportPage


def resolve(names: list[str], *, run_all: bool = False) -> list[Experiment]:
    """The experiments to run: ``names`` in order, or every implemented one."""
    if run_all:
        return [e for e in EXPERIMENTS.values() if e.implemented]
    if not names:
        raise UsageError("name at least one experiment, or --all (see --list)")
    chosen = []
    for name in names:
        if name not in EXPERIMENTS:
            raise UsageError(f"unknown experiment {name!r}; known: {', '.join(EXPERIMENTS)}")
        exp = EXPERIMENTS[name]
        if not exp.implemented:
            raise UsageError(f"{name}: not reproduced yet (see --list)")
        chosen.append(exp)
    return chosen


def reproduce(experiments: list[Experiment], *, out: Path, seed: int, quiet: bool = False) -> dict:
    """Run each experiment into ``out/<name>/`` and rewrite ``out/index.html``.

    Returns ``{name: summary}`` with each run's summary dict plus its wall time.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summaries = {}
    for exp in experiments:
        t0 = time.perf_counter()
        summary = exp.run(out_dir=out / exp.name, seed=seed, quiet=quiet)
        summary = dict(summary)
        summary.setdefault("wall_time_s", round(time.perf_counter() - t0, 3))
        summaries[exp.name] = summary
    write_index(out)
    return summaries


def write_index(out: Path) -> Path:
    """The reports directory's front page: every experiment, its status and link."""
    page = ReportPage(title="contactlab: thesis experiments", out_dir=out)
    page.paragraph(
        "Each experiment of Eberman (1995) reproduced by 'contactlab reproduce NAME' on "
        f"simulated data (contactlab {__version__}). Each page puts our numbers beside "
        "the thesis's and explains the differences.")
    rows = []
    for exp in EXPERIMENTS.values():
        done = (out / exp.name / "index.html").exists()
        summary = out / exp.name / "results.json"
        seed = ""
        if summary.exists():
            try:
                seed = json.loads(summary.read_text()).get("seed", "")
            except (OSError, ValueError):
                seed = ""
        rows.append([exp.name, exp.title, exp.thesis, exp.status,
                     f"{exp.name}/index.html" if done else "not run", seed])
    page.table(rows, columns=["name", "experiment", "thesis", "status", "report", "seed"],
               caption="Thesis experiments and where their reports are.")
    paths = page.write()
    _link_reports(paths["html"])
    return paths["html"]


def _link_reports(index: Path) -> None:
    """Turn the 'report' cells into links (the page builder escapes text)."""
    text = index.read_text()
    for exp in EXPERIMENTS.values():
        cell = f"<td>{exp.name}/index.html</td>"
        text = text.replace(cell, f"<td><a href='{exp.name}/index.html'>{exp.name}</a></td>")
    write_text_atomic(index, text)
