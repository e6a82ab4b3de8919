"""contactlab import: CSV files -> an archive, one trial per file."""

from __future__ import annotations

from pathlib import Path

import click

from contactlab.archive import parse_column_map, summarize
from contactlab.archive.importer import import_files, parse_window
from contactlab.cli.common import PROG, count, echo_json, json_option, quiet_option
from contactlab.errors import UsageError


class Window(click.ParamType):
    """``START:END`` seconds, either side optional."""

    name = "START:END"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        try:
            return parse_window(value)
        except UsageError as err:
            self.fail(str(err), param, ctx)


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
                   "same map. Fields: time, strain, wrench, position, velocity, "
                   "orientation (qw,qx,qy,qz) or rpy (roll,pitch,yaw, rad), labels, "
                   "action. Vector fields accept globs: strain=s*.")
@click.option("--rate", "rate_hz", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Sample rate in Hz [default: 1 / median time step of each file].")
@click.option("--label-names", default=None,
              help="Comma-separated label names; label cells must be one of them (or codes).")
@click.option("--delimiter", default=None, metavar="NAME",
              type=click.Choice(["comma", "semicolon", "tab", "pipe", "space"]),
              help="Field delimiter [default: found from each file's first lines; a "
                   "semicolon file with decimal commas is read as such].")
@click.option("--repair-time", is_flag=True,
              help="Sort rows whose time stamps go back and merge rows sharing a stamp "
                   "(an exact duplicate row is dropped, differing rows are averaged; labels: "
                   "the first row's), and say so.  Without it such a file is an error.")
@click.option("--zero-offset", "zero_offset_s", type=click.FloatRange(min=0, min_open=True),
              default=None, metavar="SECONDS",
              help="Subtract the mean wrench of each file's first SECONDS (the sensor at "
                   "rest, unloaded), kept as the trial attribute wrench_offset.")
@click.option("--wrench-frame", type=click.Choice(["sensor", "base"]), default="sensor",
              show_default=True,
              help="base: rotate force and torque from the sensor's axes into the base "
                   "frame with the orientation columns (the sensor-frame wrench is kept as "
                   "measurements/wrench_sensor).")
@click.option("--window", "windows", type=Window(), multiple=True,
              help="Import only START:END seconds from each file's first sample (either "
                   "side optional); repeat it for several trials from one file, named "
                   "STEM@START-END (run@0-20, run@20-end).")
@click.option("--controller", default="", help="Controller attribute of every trial.")
@click.option("--environment", default="", help="Environment attribute of every trial.")
@click.option("--force", is_flag=True, help="Replace OUT if it exists.")
@json_option
@quiet_option
def import_cmd(csv_files, out, columns, rate_hz, label_names, delimiter, repair_time,
               zero_offset_s, wrench_frame, windows, controller, environment, force, as_json,
               quiet):
    """Import CSV_FILES into the archive OUT, one trial per file (id = file stem).

    --columns maps archive fields to CSV columns: FIELD=COL[,COL...]
    separated by ';'. wrench takes 6 columns (fx fy fz tx ty tz, N and
    N*m), position 3 (m), velocity 3 (m/s), strain any number; time (s),
    labels (names or integer codes; empty = unlabelled) and action take one.
    Without a time column give --rate.  orientation takes the quaternion's
    columns in the order w,x,y,z (whatever their order in the file), rpy
    roll, pitch and yaw in rad (R = Rz(yaw) Ry(pitch) Rx(roll)); either is
    stored as a unit quaternion w x y z rotating tool-frame vectors into the
    base frame (measurements/orientation).

    Real recordings: time stamps that repeat or go back stop the import with
    the file, the column and the first such row, unless --repair-time; gaps
    (steps over 3 median steps: dropped samples) are reported, never filled.
    Every repair is printed and recorded in the trial's attributes.

    \b
    Examples:
      contactlab import run1.csv run2.csv --out recording.h5 \\
          --columns "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state"
      contactlab import strokes/*.csv --out imported.h5 --rate 1000 --columns "strain=s*"
      contactlab import run1.csv --out recording.h5 --columns columns.json --force
      contactlab import run-eu.csv --out eu.h5 --columns "time=t;wrench=fx,fy,fz,tx,ty,tz" \\
          --delimiter semicolon
      contactlab import run1.csv --out windows.h5 --window 0:0.5 --window 0.5: \\
          --columns "time=t;wrench=fx,fy,fz,tx,ty,tz;labels=state"
      contactlab import arm.csv --out arm.h5 --repair-time --zero-offset 0.1 \\
          --wrench-frame base --columns "time=t;wrench=fx,fy,fz,tx,ty,tz;rpy=roll,pitch,yaw"

    A recording without strain gauges (wrench and position only) needs no flag:
    segment, train and label read its wrench (--signal defaults to strain only
    where a trial has strain gauges).  The analysis expects at least 50 Hz; a
    slower time base (a time column in milliseconds?) is imported with a warning.
    """
    names = None if label_names is None else [n.strip() for n in label_names.split(",")]
    report = import_files(list(csv_files), out=out, columns=columns, rate_hz=rate_hz,
                          force=force, label_names=names, controller=controller,
                          environment=environment, quiet=quiet, delimiter=delimiter,
                          repair_time=repair_time, zero_offset_s=zero_offset_s,
                          wrench_frame=wrench_frame, windows=windows)
    path = report.path
    summary = summarize(path)
    slow = [t for t in summary["trials"] if t.get("rate_hz") and t["rate_hz"] < 50.0]
    for t in slow[:3]:
        click.echo(f"{PROG}: warning: {path}: trial {t['id']}: {t['rate_hz']:.3g} Hz, below the "
                   "50 Hz the analysis expects (time in milliseconds? give seconds, or --rate)",
                   err=True)
    if as_json:
        echo_json({"file": str(path), "trials": [t["id"] for t in summary["trials"]],
                   "n_samples": summary["n_samples"], "duration_s": summary["duration_s"],
                   "repairs": report.trials})
    else:
        click.echo(f"{path}: imported {count(summary['n_trials'], 'trial')}, "
                   f"{count(summary['n_samples'], 'sample')} ({summary['duration_s']:.3g} s)")
        for tid, notes in report.trials.items():
            for line in repair_lines(notes):
                click.echo(f"  {tid}: {line}")


def repair_lines(notes: dict) -> list[str]:
    """One line per thing the import did to a trial's rows, in words."""
    lines = []
    fix = notes.get("time_repair")
    if fix:
        done = [f"{count(fix['rows_reordered'], 'row')} out of order sorted"
                if fix["rows_reordered"] else "",
                f"{count(fix['duplicate_rows_dropped'], 'duplicate row')} dropped"
                if fix["duplicate_rows_dropped"] else "",
                f"{count(fix['stamps_averaged'], 'repeated stamp')} averaged"
                if fix["stamps_averaged"] else ""]
        lines.append("time repaired: " + ", ".join(d for d in done if d)
                     + f" ({count(fix['rows_merged'], 'row')} fewer)")
    gaps = notes.get("gaps")
    if gaps:
        lines.append(f"{count(gaps['count'], 'gap')} in the time base, not filled (longest "
                     f"{gaps['longest_s']:.3g} s at {gaps['longest_at_s']:.3g} s; about "
                     f"{count(gaps['missing_samples'], 'sample')} missing)")
    if "wrench_offset" in notes:
        offset = " ".join(f"{v:+.3g}" for v in notes["wrench_offset"])
        lines.append(f"wrench offset subtracted: mean of the first {notes['wrench_offset_s']:g} s "
                     f"({offset}; N, N*m; trial attribute wrench_offset)")
    if notes.get("wrench_frame") == "base":
        lines.append("wrench rotated into the base frame (as measured: "
                     "measurements/wrench_sensor)")
    return lines
