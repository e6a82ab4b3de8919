"""CSV import: one trial per CSV file, columns mapped onto archive fields.

A column map says which CSV columns hold which archive field::

    {"time": "t", "wrench": "fx,fy,fz,tx,ty,tz", "position": ["x", "y", "z"],
     "strain": "s*", "labels": "state"}

Vector fields take a list of names, a comma-separated string, or glob patterns
(``s*``, ``s[0-7]``) matched against the header in file order. As text (the
CLI's ``--columns``) the same map reads ``time=t;wrench=fx,fy,fz,tx,ty,tz;strain=s*``.

``orientation`` takes four columns, the unit quaternion's w x y z in that order
(``orientation=qw,qx,qy,qz``, whatever their order in the file); ``rpy`` takes roll,
pitch and yaw in rad (``rpy=roll,pitch,yaw``: fixed axes X, Y, Z, R = Rz(yaw) Ry(pitch)
Rx(roll), as ROS and URDF write them). Either is stored as ``measurements/orientation``,
the quaternion that rotates tool-frame vectors into the base frame.

Real recordings need a few repairs, each asked for and reported, never silent
(:func:`import_files` returns what was done per trial): ``repair_time`` sorts rows
whose stamps go back and merges rows sharing a stamp (an exact duplicate row is
dropped, differing rows are averaged), ``zero_offset_s`` subtracts the mean wrench of
the recording's first seconds (kept as the trial attribute ``wrench_offset``),
``wrench_frame="base"`` rotates the wrench into the base frame with the orientation
(the sensor-frame wrench kept as ``measurements/wrench_sensor``) and ``windows`` cut
several trials from one file (ids ``STEM@START-END``). Gaps in the time base (steps
above :data:`GAP_STEPS` median steps) are counted, never filled.

The delimiter is found from the file's first lines (comma, semicolon, tab, '|' or
runs of spaces; :func:`sniff_delimiter`) unless given; a semicolon file whose
numbers carry decimal commas (``1,5``, as spreadsheets in many locales write them)
is read with the decimal comma.
"""

from __future__ import annotations

import csv
import fnmatch
import json
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field as dc_field
from pathlib import Path

import numpy as np
import pandas as pd

from contactlab.archive import spec
from contactlab.archive.writer import create_archive, label_segments
from contactlab.errors import DataError, UsageError
from contactlab.fileio import check_writable
from contactlab.progress import progress

#: Fields that take exactly one column.
SCALAR_FIELDS = ("time", "labels", "action")
#: Fields that take several columns; the width is fixed by the schema where it says so.
VECTOR_FIELDS = ("strain", "wrench", "position", "velocity", "orientation", "rpy")
FIELDS = SCALAR_FIELDS + VECTOR_FIELDS
#: Delimiters the importer recognises, by name (``--delimiter``) and character.
DELIMITERS = {"comma": ",", "semicolon": ";", "tab": "\t", "pipe": "|", "space": " "}
_DECIMAL_COMMA = re.compile(r"(?:^|;)\s*-?\d+,\d+\s*(?:;|$)", re.MULTILINE)
#: Largest integer label code: codes name classes 0..code, each stored as a label
#: name; a code beyond this is a data error, not a thousand-class labelling.
MAX_LABEL_CODE = 1023
#: A step of the time base longer than this many median steps is a gap (dropped
#: samples): reported by the import, never filled.
GAP_STEPS = 3.0
#: Largest distance of an orientation quaternion's norm from 1 that the importer
#: normalises (a file printing fewer digits); beyond it the columns are not a quaternion.
QUATERNION_NORM_SLACK = 0.01
#: Widths of the column-map fields that are not stored under their own name.
_WIDTHS = {"rpy": 3}


def parse_column_map(text: str) -> dict[str, list[str]]:
    """``"time=t;wrench=fx,fy,fz,tx,ty,tz"`` (or a path to a JSON file) -> a column map.

    A mistake in the text is a UsageError (exit 2) naming ``--columns``; one in a
    JSON file, or a file that cannot be read, is a DataError (exit 1) naming the
    file and the field (the README's rule: where the mistake is written decides).
    """
    text = text.strip()
    path = Path(text)
    if text.endswith(".json") or (path.is_file() and "=" not in text):
        try:
            raw = json.loads(path.read_text(encoding="utf-8"))
        except OSError as err:
            raise DataError(f"column map file cannot be read ({err.strerror})",
                            file=text) from None
        except (ValueError, RecursionError) as err:
            raise DataError(f"is not valid JSON ({err})", file=text) from None
        if not isinstance(raw, dict):
            raise DataError(f"must hold one JSON object mapping fields to columns, not "
                            f"{type(raw).__name__ if raw is not None else 'null'}", file=text)
        return normalize_column_map(raw, file=text)
    mapping: dict[str, str] = {}
    for part in filter(None, (p.strip() for p in text.split(";"))):
        field, eq, cols = part.partition("=")
        field = field.strip()
        if not eq or not field or not cols.strip():
            raise UsageError(f"column map entry {part!r} is not FIELD=COLUMN[,COLUMN...]")
        if field in mapping:
            raise UsageError(f"column map names field {field!r} twice")
        mapping[field] = cols
    if not mapping:
        raise UsageError("column map is empty")
    return normalize_column_map(mapping)


def normalize_column_map(columns: dict, *, file: str | None = None) -> dict[str, list[str]]:
    """Check field names and turn every value into a list of column names/patterns.

    A mistake is a UsageError, or with ``file`` (the map came from that file) a
    DataError naming the file and the field."""
    def error(message: str, field: str | None = None):
        if file is not None:
            return DataError(message, file=file, field=field)
        return UsageError(message)

    out: dict[str, list[str]] = {}
    for field, value in columns.items():
        if field not in FIELDS:
            raise error(f"unknown field {field!r} in the column map (fields: "
                        f"{', '.join(FIELDS)})", field)
        if isinstance(value, str):
            names = value.split(",")
        elif isinstance(value, (list, tuple)) and all(isinstance(n, str) for n in value):
            names = list(value)
        else:
            raise error(f"field {field!r} must map to a column name or a list of column "
                        f"names, not {json.dumps(value) if file is not None else repr(value)}",
                        field)
        names = [n.strip() for n in names if n.strip()]
        if not names:
            raise error(f"field {field!r} maps to no column", field)
        if field in SCALAR_FIELDS and (len(names) > 1 or _is_pattern(names[0])):
            raise error(f"field {field!r} takes exactly one column, not {value!r}", field)
        out[field] = names
    if not {"strain", "wrench", "position"} & set(out):
        raise error("the column map needs strain, wrench or position")
    if {"orientation", "rpy"} <= set(out):
        raise error("give orientation (a quaternion) or rpy (roll, pitch, yaw), not both")
    return out


def _first_lines(path: Path, n: int = 20) -> str:
    """The first ``n`` lines of a text file (BOM dropped); DataError (file) if unreadable."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            return "".join(line for _, line in zip(range(n), f))
    except (OSError, UnicodeDecodeError) as err:
        raise DataError(f"cannot be read as CSV ({err})", file=str(path)) from None


def sniff_delimiter(path: Path, sample: str | None = None) -> tuple[str, str]:
    """``(delimiter, decimal)`` of a CSV file from its first lines: the character of
    :data:`DELIMITERS` that splits the header and the next lines into the same number of
    fields (comma first; a space delimiter means runs of spaces), and ``","`` as the
    decimal mark when the delimiter is a semicolon and the numbers carry decimal commas.
    DataError (file) when the file cannot be read."""
    if sample is None:
        sample = _first_lines(path)
    lines = [ln for ln in sample.splitlines() if ln.strip()][:20]
    delim = ","
    for d in (",", ";", "\t", "|", " "):
        counts = {len(next(csv.reader([ln], delimiter=d, skipinitialspace=True)))
                  for ln in lines} if d != " " else {len(ln.split()) for ln in lines}
        if lines and len(counts) == 1 and counts.pop() > 1:
            delim = d
            break
    decimal = "," if delim == ";" and _DECIMAL_COMMA.search("\n".join(lines[1:])) else "."
    return delim, decimal


@dataclass
class ImportReport:
    """What :func:`import_files` wrote: the archive and, per trial id, what was done to
    its rows (``time_repair``, ``gaps``, ``wrench_offset``, ``window``, ``wrench_frame``;
    only what applies)."""

    path: Path
    trials: dict[str, dict] = dc_field(default_factory=dict)


def import_csv(csv_paths: Sequence[str | os.PathLike], *, out: str | os.PathLike,
               columns: dict, **options) -> Path:
    """Write one archive trial per CSV file (trial id = file stem, or one per window);
    return ``out``.  The options are those of :func:`import_files`."""
    return import_files(csv_paths, out=out, columns=columns, **options).path


def import_files(csv_paths: Sequence[str | os.PathLike], *, out: str | os.PathLike,
                 columns: dict, rate_hz: float | None = None, force: bool = False,
                 label_names: Sequence[str] | None = None, controller: str = "",
                 environment: str = "", quiet: bool = False, delimiter: str | None = None,
                 repair_time: bool = False, zero_offset_s: float | None = None,
                 wrench_frame: str = "sensor",
                 windows: Sequence[tuple[float | None, float | None]] = ()) -> ImportReport:
    """Write one archive trial per CSV file (trial id = file stem); return an
    :class:`ImportReport`.

    ``rate_hz`` defaults to 1 / the median time step of each file; with no time
    column it is required and times are i / rate_hz. Label columns may hold
    names (collected over all files in order of appearance, or checked against
    ``label_names``) or integer codes; empty cells are unlabelled (-1).
    ``delimiter``: a name or character of :data:`DELIMITERS` (default: found per file,
    :func:`sniff_delimiter`).

    ``repair_time``: sort rows whose stamps go back (stable) and merge rows sharing a
    stamp: an exact duplicate row is dropped, differing rows are averaged (labels and
    action codes: the first row's); without it either is a DataError naming the file,
    the time column and the first offending row.  ``zero_offset_s``: subtract the mean
    wrench of the recording's first seconds (sensor frame, before any rotation or
    window; stored as the trial attributes ``wrench_offset`` and ``wrench_offset_s``).
    ``wrench_frame="base"``: rotate force and torque into the base frame with the
    orientation (the column map needs ``orientation`` or ``rpy``); the sensor-frame
    wrench is kept as ``measurements/wrench_sensor``.  ``windows``: ``(start, end)``
    pairs, seconds from each file's first sample (None: open), each giving the trial
    ``STEM@START-END`` (:func:`window_id`) of the rows with start <= t - t[0] < end.
    """
    if delimiter is not None:
        delimiter = DELIMITERS.get(delimiter, delimiter)
        if delimiter not in DELIMITERS.values():
            raise UsageError(f"unknown delimiter {delimiter!r}; use one of "
                             f"{', '.join(DELIMITERS)}")
    mapping = normalize_column_map(columns)
    paths = [Path(p) for p in csv_paths]
    if not paths:
        raise UsageError("no CSV files given")
    if "time" not in mapping and rate_hz is None:
        raise UsageError("without a time column the rate must be given")
    if wrench_frame not in ("sensor", "base"):
        raise UsageError(f"wrench frame {wrench_frame!r} is not 'sensor' or 'base'")
    if wrench_frame == "base" and not ({"orientation", "rpy"} & set(mapping)
                                       and "wrench" in mapping):
        raise UsageError("a base-frame wrench needs wrench and orientation (or rpy) columns "
                         "in the column map")
    if zero_offset_s is not None and ("wrench" not in mapping or not zero_offset_s > 0):
        raise UsageError("the offset to zero needs a wrench column and a positive number of "
                         "seconds")
    windows = [check_window(w) for w in windows]
    check_writable(out, force=force, inputs=paths)
    for p in paths:
        if not p.stem or p.stem in (".", "..") or "/" in p.stem:
            raise DataError(f"gives the trial id {p.stem!r}, which is not a valid name; "
                            "rename the file", file=str(p))
    ids = [window_id(p.stem, w) for p in paths for w in (windows or [None])]
    dup = next((s for s in ids if ids.count(s) > 1), None)
    if dup is not None:
        raise UsageError(f"two CSV files (or windows) give the same trial id {dup!r}")
    tables = [_read_table(p, mapping, rate_hz, delimiter, repair_time=repair_time)
              for p in progress(paths, total=len(paths), desc="import", quiet=quiet, unit="file")]
    names = _label_names(tables, paths, mapping, label_names)
    pieces = []                   # every check before the first byte is written
    for path, table in zip(paths, tables):
        if "labels" in table:
            table["labels"] = _label_codes(table["labels"], names, path, mapping)
        notes = table.pop("notes")
        if zero_offset_s is not None:
            notes.update(_zero_offset(path, table, zero_offset_s, mapping))
        if "orientation" in table:
            notes.update(_orient(path, table, mapping, wrench_frame))
        for w in (windows or [None]):
            piece = _cut(path, table, w, mapping) if w is not None else dict(table)
            piece_notes = dict(notes, **({"window": window_text(w)} if w else {}))
            pieces.append((path, window_id(path.stem, w), piece, piece_notes))
    out = Path(out)
    report = ImportReport(out)
    # incremental: a write failure or an interrupt keeps the trials already written
    with create_archive(out, force=force, incremental=True) as archive:
        for path, tid, table, notes in pieces:
            rate = table.pop("rate_hz")
            what = f"imported from {path.name}" + (f", {notes['window']} s"
                                                   if "window" in notes else "")
            trial = archive.add_trial(tid, rate_hz=rate, controller=controller,
                                      environment=environment, source="import",
                                      description=what,
                                      wrench_frame=notes.get("wrench_frame"))
            labels = table.pop("labels", None)
            sensor = table.pop("wrench_sensor", None)
            trial.append(**table)
            if sensor is not None:
                trial.set_extra("wrench_sensor", sensor, attrs={
                    "units": spec.fixed_units(spec.MEASUREMENTS, "wrench"), "frame": "sensor",
                    "columns": spec.string_array(
                        spec.default_attr(spec.MEASUREMENTS, "wrench", "columns"))})
            if labels is not None:
                trial.set_ground_truth(labels=labels, names=names,
                                       segments=label_segments(labels, table["time"], rate))
            trial.set_attrs(_trial_attrs(notes))
            trial.close()
            report.trials[tid] = notes
    return report


def check_window(window) -> tuple[float | None, float | None]:
    """``(start, end)`` seconds (None: open) checked: finite, start >= 0, end > start."""
    start, end = window
    for v in (start, end):
        if v is not None and not (isinstance(v, (int, float)) and np.isfinite(v) and v >= 0):
            raise UsageError(f"window {window_text(window)}: times must be seconds >= 0")
    if start is not None and end is not None and not end > start:
        raise UsageError(f"window {window_text(window)}: the end must come after the start")
    return (None if start is None else float(start), None if end is None else float(end))


def parse_window(text: str) -> tuple[float | None, float | None]:
    """``"0:20"``, ``"20:"``, ``":20"`` -> ``(start, end)`` seconds (None: open);
    UsageError when the text is not START:END."""
    left, colon, right = text.strip().partition(":")
    try:
        window = tuple(None if not v.strip() else float(v) for v in (left, right))
    except ValueError:
        window = None
    if not colon or window is None or window == (None, None):
        raise UsageError(f"window {text!r} is not START:END in seconds (e.g. 0:20, 20:, :20)")
    return check_window(window)


def window_text(window) -> str:
    """``(20.0, None)`` -> ``"20:"``: the window as it is written on the command line."""
    return ":".join("" if v is None else f"{v:g}" for v in window)


def window_id(stem: str, window) -> str:
    """The trial id of one window of a file: ``STEM@START-END`` (``run@0-20``; an open
    start reads 0, an open end ``end``: ``run@20-end``), or ``STEM`` without a window."""
    if window is None:
        return stem
    start, end = window
    return f"{stem}@{start or 0:g}-{'end' if end is None else f'{end:g}'}"


def _trial_attrs(notes: dict) -> dict:
    """The trial attributes that record an import's repairs (see ARCHIVE.md)."""
    attrs = {}
    if "window" in notes:
        attrs["window"] = notes["window"]
    if "wrench_offset" in notes:
        attrs["wrench_offset"] = np.asarray(notes["wrench_offset"], dtype=np.float64)
        attrs["wrench_offset_s"] = float(notes["wrench_offset_s"])
    if "time_repair" in notes:
        attrs["time_repair"] = json.dumps(notes["time_repair"])
    return attrs


def _zero_offset(path: Path, table: dict, seconds: float, mapping: dict) -> dict:
    """Subtract the mean wrench of the first ``seconds`` of ``table`` in place."""
    t = table["time"]
    first = t - t[0] < seconds
    if first.sum() < 2 or t[-1] - t[0] < seconds:
        raise DataError(f"the offset to zero needs {seconds:g} s of samples at the start, the "
                        f"recording lasts {t[-1] - t[0]:.3g} s", file=str(path),
                        field=mapping["wrench"][0])
    offset = table["wrench"][first].mean(axis=0)
    table["wrench"] = table["wrench"] - offset
    return {"wrench_offset": [float(v) for v in offset], "wrench_offset_s": float(seconds)}


def _orient(path: Path, table: dict, mapping: dict, wrench_frame: str) -> dict:
    """Normalise the orientation quaternions (or convert roll, pitch, yaw) in place and,
    for a base-frame wrench, rotate the wrench into the base frame."""
    if "rpy" in mapping:
        q = rpy_to_quaternion(table["orientation"])
    else:
        q = table["orientation"]
        norm = np.linalg.norm(q, axis=1)
        off = np.abs(norm - 1.0) > QUATERNION_NORM_SLACK
        if off.any():
            i = int(np.flatnonzero(off)[0])
            raise DataError(f"the orientation columns are not a unit quaternion w x y z (data "
                            f"row {i + 1}: norm {norm[i]:.4g})", file=str(path),
                            field=",".join(mapping["orientation"]))
        q = q / norm[:, None]
    table["orientation"] = q
    notes = {}
    if wrench_frame == "base":
        table["wrench_sensor"] = table["wrench"]
        table["wrench"] = rotate_wrench(q, table["wrench"])
        notes["wrench_frame"] = "base"
    return notes


def rpy_to_quaternion(rpy: np.ndarray) -> np.ndarray:
    """(n, 3) roll, pitch, yaw (rad; R = Rz(yaw) Ry(pitch) Rx(roll)) -> (n, 4) unit
    quaternions w x y z."""
    half = np.asarray(rpy, dtype=np.float64) / 2.0
    cr, cp, cy = np.cos(half).T
    sr, sp, sy = np.sin(half).T
    return np.column_stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 4) unit quaternions w x y z -> (n, 3, 3) rotation matrices."""
    w, x, y, z = np.asarray(q, dtype=np.float64).T
    return np.stack([
        np.column_stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)]),
        np.column_stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)]),
        np.column_stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]),
    ], axis=1)


def rotate_vectors(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(n, 3) vectors ``v`` rotated by the (n, 4) unit quaternions ``q`` (w x y z):
    ``R(q) v`` as ``v + 2 w (u x v) + 2 u x (u x v)`` with ``u`` the vector part (the
    matrices of :func:`quaternion_matrices` are not built)."""
    w, x, y, z = np.asarray(q, dtype=np.float64).T
    a, b, c = np.asarray(v, dtype=np.float64).T
    tx, ty, tz = 2.0 * (y * c - z * b), 2.0 * (z * a - x * c), 2.0 * (x * b - y * a)
    return np.column_stack([a + w * tx + y * tz - z * ty, b + w * ty + z * tx - x * tz,
                            c + w * tz + x * ty - y * tx])


def rotate_wrench(q: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """A sensor-frame wrench (n, 6) in the base frame's axes: force and torque each
    rotated by R(q) (the torque stays about the sensor's origin)."""
    return np.concatenate([rotate_vectors(q, wrench[:, :3]), rotate_vectors(q, wrench[:, 3:])],
                          axis=1)


def _cut(path: Path, table: dict, window, mapping: dict) -> dict:
    """The rows of ``table`` inside ``window`` (seconds from its first sample)."""
    t = table["time"]
    rel = t - t[0]
    start, end = window
    keep = (rel >= (start or 0.0)) & (rel < (np.inf if end is None else end))
    if keep.sum() < 2:
        raise DataError(f"window {window_text(window)} holds {int(keep.sum())} samples (the "
                        f"recording lasts {rel[-1]:.3g} s)", file=str(path), field="--window")
    return {k: (v[keep] if isinstance(v, np.ndarray) else v) for k, v in table.items()}


def _is_pattern(name: str) -> bool:
    return any(c in name for c in "*?[")


def _read_table(path: Path, mapping: dict[str, list[str]], rate_hz: float | None,
                delimiter: str | None = None, *, repair_time: bool = False) -> dict:
    """The file's fields as arrays (labels as read), its ``rate_hz`` and ``notes``: what
    was repaired, and the gaps of its time base."""
    sample = _first_lines(path)
    sep, decimal = sniff_delimiter(path, sample)
    if delimiter is not None and delimiter != sep:
        header = sample.split("\n", 1)[0]
        fields = len(header.split()) if delimiter == " " else header.count(delimiter) + 1
        if fields == 1:
            name = {v: k for k, v in DELIMITERS.items()}
            raise DataError(f"--delimiter {name[delimiter]} leaves the header one field; the file "
                            f"looks {name[sep]}-separated (give --delimiter {name[sep]} or leave "
                            "it out)", file=str(path), field="--delimiter")
    if delimiter is not None:
        sep, decimal = delimiter, (decimal if delimiter == sep else ".")
    try:
        frame = pd.read_csv(path, skipinitialspace=True, decimal=decimal,
                            **({"sep": r"\s+"} if sep == " " else {"sep": sep}))
    except (OSError, ValueError, UnicodeDecodeError, pd.errors.ParserError) as err:
        first = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise DataError(f"cannot be read as CSV ({first})", file=str(path)) from None
    frame.columns = [str(c).strip() for c in frame.columns]
    if frame.empty:
        raise DataError("no data rows", file=str(path))
    table: dict = {}
    named = {n for names in mapping.values() for n in names if not _is_pattern(n)}
    for field, names in mapping.items():
        cols = _resolve(path, frame, field, names, exclude=named)
        if field == "labels":
            table[field] = frame[cols[0]]
            continue
        values = np.column_stack([_numeric(path, frame, c) for c in cols])
        rule = (_WIDTHS[field],) if field in _WIDTHS else \
            spec.trailing_shape(spec.MEASUREMENTS, field)
        if field in VECTOR_FIELDS and isinstance(rule[0], int) and values.shape[1] != rule[0]:
            raise DataError(f"field {field} needs {rule[0]} columns, the map gives "
                            f"{values.shape[1]} ({', '.join(cols)})", file=str(path),
                            field=field)
        if field == "action":
            if not np.all(values == np.round(values)):
                raise DataError("action codes must be integers", file=str(path), field=cols[0])
            values = values.astype(np.int64)
        table["orientation" if field == "rpy" else field] = \
            values[:, 0] if field in SCALAR_FIELDS else values
    n = len(frame)
    table["notes"] = {}
    if "time" in table:
        table["notes"].update(_repair_time(path, table, mapping["time"][0], repair_time))
        t = table["time"]
        step = np.diff(t)
        if len(t) < 2 and rate_hz is None:
            raise DataError("cannot infer the rate from fewer than 2 samples; give the rate",
                            file=str(path), field=mapping["time"][0])
        if len(t) >= 2:
            dt = float(np.median(step))
            if rate_hz is None:
                # 9 significant digits: CSV times carry fewer, and 1 / 0.001 computed in
                # binary would otherwise read 999.9999999999991 Hz in every summary
                table["rate_hz"] = float(f"{1.0 / dt:.9g}")
            elif abs(dt * rate_hz - 1.0) > spec.RATE_TOLERANCE:
                raise DataError(f"median time step {dt:.6g} s disagrees with the given rate "
                                f"{rate_hz:g} Hz", file=str(path), field=mapping["time"][0])
            gaps = step > GAP_STEPS * dt
            if gaps.any():
                i = int(np.argmax(np.where(gaps, step, 0.0)))
                table["notes"]["gaps"] = {
                    "count": int(gaps.sum()), "longest_s": float(step[i]),
                    "longest_at_s": float(t[i] - t[0]),
                    "missing_samples": int(np.round(step[gaps] / dt).sum() - gaps.sum())}
    else:
        table["time"] = np.arange(n) / rate_hz
    table.setdefault("rate_hz", rate_hz)
    return table


def _repair_time(path: Path, table: dict, column: str, repair: bool) -> dict:
    """Make ``table["time"]`` strictly increasing in place, or raise a DataError naming
    the first row where it is not (``repair`` False).  Rows are sorted by time (stable);
    rows sharing a stamp become one: exact duplicates are dropped, differing rows averaged
    (labels and action codes: the first row's).  Returns ``{"time_repair": {...}}`` when
    something was done, else {}."""
    t = table["time"]
    step = np.diff(t)
    bad = step <= 0
    if not bad.any():
        return {}
    if not repair:
        i = int(np.flatnonzero(bad)[0]) + 1
        how = "repeats the time stamp" if step[i - 1] == 0 else "goes back from the time"
        raise DataError(f"time is not strictly increasing (data row {i + 1}, {t[i]:.9g} s, "
                        f"{how} {t[i - 1]:.9g} s of data row {i}; {int(bad.sum())} such "
                        f"row{'s' if bad.sum() != 1 else ''}): give --repair-time to sort the "
                        "rows and merge repeated stamps", file=str(path), field=column)
    order = np.argsort(t, kind="stable")
    reordered = int((step < 0).sum())
    data = {k: (v.to_numpy() if isinstance(v, pd.Series) else v)[order]
            for k, v in table.items() if k != "notes"}
    t = data["time"]
    starts = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
    sizes = np.diff(np.r_[starts, len(t)])
    shared = np.flatnonzero(sizes > 1)
    identical = 0
    for g in shared:
        rows = slice(starts[g], starts[g] + sizes[g])
        identical += all(_same_rows(v[rows]) for v in data.values())
    for key, values in data.items():
        if key == "time" or values.dtype.kind != "f":
            data[key] = values[starts]                  # labels, action: the first row's
        else:
            data[key] = np.add.reduceat(values, starts, axis=0) / (
                sizes if values.ndim == 1 else sizes[:, None])
    for key, values in data.items():
        old = table[key]
        table[key] = pd.Series(values, dtype=old.dtype) if isinstance(old, pd.Series) else values
    return {"time_repair": {"rows_reordered": reordered,
                            "duplicate_rows_dropped": int(identical),
                            "stamps_averaged": int(len(shared) - identical),
                            "rows_merged": int((sizes[shared] - 1).sum())}}


def _same_rows(values: np.ndarray) -> bool:
    """Whether every row of ``values`` equals the first (NaN equal to NaN)."""
    return bool(pd.DataFrame(values.reshape(len(values), -1)).nunique(dropna=False).max() <= 1)


def _resolve(path: Path, frame: pd.DataFrame, field: str, names: list[str], *,
             exclude: set[str]) -> list[str]:
    """CSV columns of one field; patterns skip columns that the map names explicitly."""
    header = list(frame.columns)
    cols: list[str] = []
    for name in names:
        if _is_pattern(name):
            found = [c for c in fnmatch.filter(header, name) if c not in exclude]
        else:
            found = [name] if name in header else []
        if not found:
            raise DataError(f"no such column (field {field}; columns are "
                            f"{', '.join(header[:12])}{', ...' if len(header) > 12 else ''})",
                            file=str(path), field=name)
        cols.extend(c for c in found if c not in cols)
    return cols


def _numeric(path: Path, frame: pd.DataFrame, col: str) -> np.ndarray:
    values = pd.to_numeric(frame[col], errors="coerce").to_numpy(dtype=np.float64,
                                                                  na_value=np.nan)
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        row = frame.iloc[i]
        given = int(row.notna().sum())
        if row.iloc[given:].isna().all() and row.iloc[:given].notna().all() \
                and given < len(row):
            raise DataError(f"data row {i + 1} ends after {given} of {len(row)} fields (a "
                            "line cut short?)", file=str(path), field=col)
        cell = frame[col].iloc[i]
        shown = (repr(cell) if isinstance(cell, str) else "empty" if pd.isna(cell)
                 else str(float(cell)))
        n = int(bad.sum())
        raise DataError(f"{n} empty or non-numeric cell{'s' if n != 1 else ''} (first: data row "
                        f"{i + 1}, line {i + 2} of the file, {shown})", file=str(path), field=col)
    return values


def _label_names(tables: list[dict], paths: list[Path], mapping: dict,
                 given: Sequence[str] | None) -> list[str]:
    if "labels" not in mapping:
        return []
    if given is not None:
        return [str(n) for n in given]
    found: dict[str, None] = {}
    top = -1
    named, coded = None, None                    # a file of each kind, for the error
    for table, path in zip(tables, paths):
        column = table["labels"]
        if pd.api.types.is_numeric_dtype(column):
            codes = _label_codes(column, None, path, mapping)
            top = max(top, int(codes.max(initial=-1)))
            coded = coded or path
        else:
            found.update(dict.fromkeys(str(v).strip() for v in column.dropna()))
            named = named or path
    if found and top >= 0:
        raise DataError(f"label columns mix names and integer codes across files ({named.name} "
                        f"has names, {coded.name} integer codes)",
                        file=str(coded), field=mapping["labels"][0])
    return list(found) if found else [str(i) for i in range(top + 1)]


def _label_codes(column: pd.Series, names: list[str] | None, path: Path,
                 mapping: dict) -> np.ndarray:
    col = mapping["labels"][0]
    if pd.api.types.is_numeric_dtype(column):
        values = column.to_numpy(dtype=np.float64, na_value=np.nan)
        values = np.where(np.isnan(values), -1.0, values)
        if not np.all(values == np.round(values)) or values.min(initial=-1) < -1:
            raise DataError("integer label codes must be whole numbers >= -1", file=str(path),
                            field=col)
        if values.max(initial=-1) > MAX_LABEL_CODE:
            i = int(np.argmax(values))
            raise DataError(f"label code {values[i]:.0f} (data row {i + 1}) is above "
                            f"{MAX_LABEL_CODE}; give names with --label-names, or codes "
                            f"0..{MAX_LABEL_CODE}", file=str(path), field=col)
        codes = values.astype(np.int64)
        if names is not None and codes.max(initial=-1) >= len(names):
            raise DataError(f"label code {int(codes.max())} has no name ({len(names)} names)",
                            file=str(path), field=col)
        return codes
    index = {name: i for i, name in enumerate(names or [])}
    text = column.astype("string").str.strip()
    codes = text.map(index)
    unknown = text.notna().to_numpy() & codes.isna().to_numpy()
    if unknown.any():
        label = text.iloc[int(np.flatnonzero(unknown)[0])]
        raise DataError(f"label {label!r} is not one of the label names "
                        f"({', '.join(index)})", file=str(path), field=col)
    return codes.fillna(-1).to_numpy(dtype=np.int64)
