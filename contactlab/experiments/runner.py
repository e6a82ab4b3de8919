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


def reproduce(experiments: list[Experiment], *, out: Path, seed: int, quiet: bool = False,
              workers: int = 1, scheduler: str | None = None) -> dict:
    """Run each experiment into ``out/<name>/`` and rewrite ``out/index.html``.

    ``workers`` > 1 runs experiments in that many local processes, ``scheduler``
    on a Dask distributed cluster (:func:`contactlab.stages.parallel_map`; its
    workers must see ``out``); each experiment is seeded by ``seed`` alone, so
    the reports are the same either way. Returns ``{name: summary}`` with each
    run's summary dict plus its wall time; an experiment that fails is raised
    after the others finished and the index was written.
    """
    from contactlab.fileio import make_directory
    from contactlab.stages import check_workers, parallel_map

    check_workers(workers, scheduler)
    out = make_directory(out)  # a read-only or full place: one line naming it
    serial = workers == 1 and scheduler is None   # in this process: each shows its own bar
    got = parallel_map(run_experiment,
                       [(exp.name, out, seed, quiet if serial else True) for exp in experiments],
                       workers=workers, scheduler=scheduler, quiet=quiet or serial,
                       desc="reproduce")
    summaries = {exp.name: r for exp, r in zip(experiments, got)}
    write_index(out)
    failed = next((r for r in summaries.values() if isinstance(r, Exception)), None)
    if failed is not None:
        raise failed
    return summaries


def run_experiment(name: str, out: Path, seed: int, quiet: bool = True) -> dict:
    """Run the experiment ``name`` into ``out/<name>/``; its summary and wall time."""
    t0 = time.perf_counter()
    summary = dict(EXPERIMENTS[name].run(out_dir=Path(out) / name, seed=seed, quiet=quiet))
    summary.setdefault("wall_time_s", round(time.perf_counter() - t0, 3))
    return summary


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
