"""contactlab import: CSV files -> an archive, one trial per file."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.archive import import_csv, parse_column_map, summarize
from contactlab.cli.common import PROG, count, echo_json, json_option, quiet_option
from contactlab.errors import UsageError


class ColumnMap(click.ParamType):
    """``FIELD=COL[,COL...];...`` or a JSON file, parsed into a column map."""

    name = "MAP"

    def convert(self, value, param, ctx):
        if isinstance(value, dict):
            return value
        try:
            return parse_column_map(value)  # a bad column-map file: DataError (exit 1)
        except UsageError as err:
            self.fail(str(err), param, ctx)


@click.command(name="import")
@click.argument("csv_files", nargs=-1, required=True,
                type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--out", "-o", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Archive to write (refused if it exists, unless --force).")
@click.option("--columns", "-c", required=True, type=ColumnMap(),
              help="FIELD=COL[,COL...] entries separated by ';', or a JSON file with the "
                   "same map. Fields: time, strain, wrench, position, velocity, labels, "
                   "action. Vector fields accept globs: strain=s*.")
@click.option("--rate", "rate_hz", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Sample rate in Hz [default: 1 / median time step of each file].")
@click.option("--label-names", default=None,
              help="Comma-separated label names; label cells must be one of them (or codes).")
@click.option("--delimiter", default=None, metavar="NAME",
              type=click.Choice(["comma", "semicolon", "tab", "pipe", "space"]),
              help="Field delimiter [default: found from each file's first lines; a "
                   "semicolon file with decimal commas is read as such].")
@click.option("--controller", default="", help="Controller attribute of every trial.")
@click.option("--environment", default="", help="Environment attribute of every trial.")
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
@json_option
@quiet_option
def import_cmd(csv_files, out, columns, rate_hz, label_names, delimiter, controller,
               environment, force, as_json, quiet):
    """Import CSV_FILES into the archive OUT, one trial per file (id = file stem).

    --columns maps archive fields to CSV columns: FIELD=COL[,COL...]
    separated by ';'. wrench takes 6 columns (fx fy fz tx ty tz, N and
    N*m), position 3 (m), velocity 3 (m/s), strain any number; time (s),
    labels (names or integer codes; empty = unlabelled) and action take one.
    Without a time column give --rate.

    \b
    Examples:
      contactlab import run1.csv run2.csv --out recording.h5 \\
          --columns "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state"
      contactlab import strokes/*.csv --out imported.h5 --rate 1000 --columns "strain=s*"
      contactlab import run1.csv --out recording.h5 --columns columns.json --force
      contactlab import run-eu.csv --out eu.h5 --columns "time=t;wrench=fx,fy,fz,tx,ty,tz" \\
          --delimiter semicolon

    A recording without strain gauges (wrench and position only) needs no flag:
    segment, train and label read its wrench (--signal defaults to strain only
    where a trial has strain gauges).  The analysis expects at least 50 Hz; a
    slower time base (a time column in milliseconds?) is imported with a warning.
    """
    names = None if label_names is None else [n.strip() for n in label_names.split(",")]
    path = import_csv(list(csv_files), out=out, columns=columns, rate_hz=rate_hz, force=force,
                      label_names=names, controller=controller, environment=environment,
                      quiet=quiet, delimiter=delimiter)
    summary = summarize(path)
    slow = [t for t in summary["trials"] if t.get("rate_hz") and t["rate_hz"] < 50.0]
    for t in slow[:3]:
        click.echo(f"{PROG}: warning: {path}: trial {t['id']}: {t['rate_hz']:.3g} Hz, below the "
                   "50 Hz the analysis expects (time in milliseconds? give seconds, or --rate)",
                   err=True)
    if as_json:
        echo_json({"file": str(path), "trials": [t["id"] for t in summary["trials"]],
                   "n_samples": summary["n_samples"], "duration_s": summary["duration_s"]})
    else:
        click.echo(f"{path}: imported {count(summary['n_trials'], 'trial')}, "
                   f"{count(summary['n_samples'], 'sample')} ({summary['duration_s']:.3g} s)")
