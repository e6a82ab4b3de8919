"""contactlab info: what an archive holds, one row per trial."""

from __future__ import annotations

import click

from contactlab.archive import summarize
from contactlab.cli.common import archive_argument, count, echo_json, json_option
from contactlab.cli.inputs import checks_archive

COLUMNS = ("trial", "duration (s)", "samples", "rate (Hz)", "channels", "labels", "results")


@click.command()
@archive_argument
@json_option
@checks_archive
def info(archive, as_json):
    """Show the trials in ARCHIVE: duration, samples, rate, channels, labels, results.

    \b
    Examples:
      contactlab info runs.h5
      contactlab info runs.h5 --json
    """
    summary = summarize(archive)
    if as_json:
        echo_json(summary)
        return
    title = f" - {summary['title']}" if summary["title"] else ""
    click.echo(f"{archive}{title}: {count(summary['n_trials'], 'trial')}, format "
               f"{summary['format_version']}, written by contactlab "
               f"{summary['software_version']} on {summary['created']}")
    if summary["trials"]:
        click.echo(format_table([_row(t) for t in summary["trials"]], COLUMNS))


def _row(trial: dict) -> list[str]:
    channels = ", ".join(f"{k} {v}" for k, v in trial["channels"].items())
    labels = trial["labels"]
    if labels is None:
        label_text = "-"
    elif labels["counts"]:
        # labels the trial never uses are left out (integer-coded imports name every code
        # from 0 up; --json keeps every count)
        parts = [f"{k} {v}" for k, v in labels["counts"].items() if v]
        if labels["unlabelled"]:
            parts.append(f"unlabelled {labels['unlabelled']}")
        label_text = ", ".join(parts) or "-"
    else:
        label_text = ", ".join(labels["names"]) + " (segments only)"
    return [trial["id"], f"{trial['duration_s']:.3f}", str(trial["n_samples"]),
            f"{trial['rate_hz']:g}", channels, label_text, ", ".join(trial["results"]) or "-"]


def format_table(rows: list[list[str]], columns) -> str:
    """Left-aligned plain-text columns separated by two spaces."""
    widths = [max(len(str(c)) for c in col) for col in zip(columns, *rows)]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(r, widths)).rstrip()
             for r in [list(columns), *rows]]
    return "\n".join(lines)
