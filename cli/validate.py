"""contactlab validate: check an archive against datasets_spec/archive.schema.json."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.archive import open_archive, summarize, validate_archive
from contactlab.cli.common import PROG, count, echo_json, json_option
from contactlab.errors import DataError
from contactlab.fileio import refuse_while_recorded, remove_stale_temp_files


@click.command()
@click.argument("archives", nargs=-1, required=True, metavar="ARCHIVE...",
                type=click.Path(dir_okay=False, path_type=Path))
@json_option
def validate(archives, as_json):
    """Check that each ARCHIVE follows the archive format (datasets_spec/ARCHIVE.md).

    Exit status 0 and a one-line summary per archive when all conform;
    otherwise one line per problem on stdout, "HDF5-PATH: what is wrong", and
    exit status 1 (a file that does not exist is an error line on stderr, as with
    every verb).  --json prints {"file", "ok", "problems": [{"path",
    "message"}], "trials"} for one archive ("trials" is null when the file
    cannot be read as an archive), {"ok", "archives": [...]} for several.

    \b
    Examples:
      contactlab validate runs.h5
      contactlab validate runs.h5 --json
      contactlab validate runs.h5 recording.h5
    """
    results = [_check(a, quiet=as_json) for a in archives]
    if as_json:
        echo_json(results[0] if len(results) == 1 else
                  {"ok": all(r["ok"] for r in results), "archives": results})
    if not all(r["ok"] for r in results):
        click.get_current_context().exit(1)


def _check(archive: Path, *, quiet: bool) -> dict:
    refuse_while_recorded(archive)
    remove_stale_temp_files(archive)  # a killed recording's journal: played back first
    problems = validate_archive(archive)
    summary = summarize(archive) if not problems else None
    if quiet:
        pass
    elif summary:
        click.echo(f"{archive}: ok, {count(summary['n_trials'], 'trial')}, "
                   f"{count(summary['n_samples'], 'sample')} ({summary['duration_s']:.3g} s), format "
                   f"{summary['format_version']}")
    elif not archive.exists():          # no input: one error line, as every verb says it
        click.echo(f"{PROG}: error: {archive}: no such file", err=True)
    else:
        for problem in problems:
            click.echo(str(problem))
        click.echo(f"{PROG}: {archive}: does not conform ({len(problems)} "
                   f"problem{'s' if len(problems) != 1 else ''})", err=True)
    return {"file": str(archive), "ok": not problems,
            "problems": [{"path": p.path, "message": p.message} for p in problems],
            "trials": summary["n_trials"] if summary else _count_trials(archive)}


def _count_trials(path) -> int | None:
    try:
        with open_archive(path) as archive:
            return len(archive)
    except DataError:  # not readable as an archive at all: the problems say why
        return None
