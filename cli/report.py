"""contactlab report: a figure report (HTML + PDF) of what an archive holds."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.cli.common import (archive_argument, count, echo_json, json_option,
                                   quiet_option)
from contactlab.cli.inputs import checks_archive
from contactlab.errors import DataError


@click.command()
@archive_argument
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output directory [default: reports/ARCHIVE-STEM].")
@click.option("--trial", "trials", multiple=True, help="Only this trial (repeatable).")
@click.option("--force", is_flag=True, help="Replace a report already in OUT.")
@json_option
@quiet_option
@checks_archive
def report(archive, out, trials, force, as_json, quiet):
    """Write a thesis-style figure report of ARCHIVE: signals, truth and results.

    Each trial's position, velocity, force, strains, high-frequency
    log-energy and ground truth, plus whatever later stages wrote in its
    results part, as OUT/index.html with PNG figures and OUT/report.pdf.
    After 'contactlab recognize' the report adds what was recognised and how
    well: the share of labelled points marked correctly beside two chance
    levels (always the most frequent true node; uniform), the pooled confusion
    and each trial's path; the same line is printed. The report is written
    aside and moved into OUT whole, so a failure (a full disk, Ctrl-C) leaves
    OUT as it was.

    \b
    Examples:
      contactlab report runs.h5
      contactlab report runs.h5 --out reports/runs --trial t001 --force
    """
    from contactlab.report.archive_report import report_archive

    out = out if out is not None else Path("reports") / archive.stem
    existing = [out / name for name in ("index.html", "report.pdf") if (out / name).exists()]
    if existing and not force:
        raise DataError("holds a report already; pass --force to replace it", file=str(out))
    if out.exists() and not out.is_dir():
        raise DataError("is not a directory", file=str(out))
    summary = report_archive(archive, out_dir=out, trials=list(trials) or None, quiet=quiet)
    if as_json:
        echo_json(summary)
        return
    click.echo(f"{archive}: {count(len(summary['trials']), 'trial')} -> {summary['html']}, {summary['pdf']}")
    r = summary.get("recognition")
    if r and r["points"]:
        major = r["majority_node"]
        label = r.get("node_labels", {}).get(major)
        major = f"{major} ({label})" if label else major
        click.echo(f"recognised: {100 * r['accuracy']:.1f} % of {r['points']} labelled points "
                   f"marked correctly by the MAP path (on-line {100 * r['accuracy_online']:.1f} "
                   f"%); chance: {100 * r['chance_majority']:.1f} % always {major}, "
                   f"{100 * r['chance_uniform']:.0f} % uniform")
    ex = summary.get("explained")
    if ex and ex.get("transitions"):
        verdicts: dict = {}
        for tr in ex["transitions"]:
            verdicts[tr["verdict"]] = verdicts.get(tr["verdict"], 0) + 1
        click.echo(f"worst trial {ex['trial']}: {100 * ex['accuracy']:.1f} % (the models "
                   f"alone, true boundaries given: {100 * ex['segment_accuracy']:.1f} %); its "
                   "true changes: " + ", ".join(f"{v} {k}" for k, v in verdicts.items())
                   + " (the report's explanation section)")
