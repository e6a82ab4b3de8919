"""CSV import: one trial per CSV file, columns mapped onto archive fields.

A column map says which CSV columns hold which archive field::

    {"time": "t", "wrench": "fx,fy,fz,tx,ty,tz", "position": ["x", "y", "z"],
     "strain": "s*", "labels": "state"}

Vector fields take a list of names, a comma-separated string, or glob patterns
(``s*``, ``s[0-7]``) matched against the header in file order. As text (the
CLI's ``--columns``) the same map reads ``time=t;wrench=fx,fy,fz,tx,ty,tz;strain=s*``.

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
VECTOR_FIELDS = ("strain", "wrench", "position", "velocity")
FIELDS = SCALAR_FIELDS + VECTOR_FIELDS
#: Delimiters the importer recognises, by name (``--delimiter``) and character.
DELIMITERS = {"comma": ",", "semicolon": ";", "tab": "\t", "pipe": "|", "space": " "}
_DECIMAL_COMMA = re.compile(r"(?:^|;)\s*-?\d+,\d+\s*(?:;|$)", re.MULTILINE)
#: Largest integer label code: codes name classes 0..code, each stored as a label
#: name; a code beyond this is a data error, not a thousand-class labelling.
MAX_LABEL_CODE = 1023


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


def import_csv(csv_paths: Sequence[str | os.PathLike], *, out: str | os.PathLike,
               columns: dict, rate_hz: float | None = None, force: bool = False,
               label_names: Sequence[str] | None = None, controller: str = "",
               environment: str = "", quiet: bool = False,
               delimiter: str | None = None) -> Path:
    """Write one archive trial per CSV file (trial id = file stem); return ``out``.

    ``rate_hz`` defaults to 1 / the median time step of each file; with no time
    column it is required and times are i / rate_hz. Label columns may hold
    names (collected over all files in order of appearance, or checked against
    ``label_names``) or integer codes; empty cells are unlabelled (-1).
    ``delimiter``: a name or character of :data:`DELIMITERS` (default: found per file,
    :func:`sniff_delimiter`).
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
    check_writable(out, force=force, inputs=paths)
    for p in paths:
        if not p.stem or p.stem in (".", "..") or "/" in p.stem:
            raise DataError(f"gives the trial id {p.stem!r}, which is not a valid name; "
                            "rename the file", file=str(p))
    stems = [p.stem for p in paths]
    dup = next((s for s in stems if stems.count(s) > 1), None)
    if dup is not None:
        raise UsageError(f"two CSV files give the same trial id {dup!r}")
    tables = [_read_table(p, mapping, rate_hz, delimiter)
              for p in progress(paths, total=len(paths), desc="import", quiet=quiet, unit="file")]
    names = _label_names(tables, paths, mapping, label_names)
    for path, table in zip(paths, tables):  # every check before the first byte is written
        if "labels" in table:
            table["labels"] = _label_codes(table["labels"], names, path, mapping)
    out = Path(out)
    # incremental: a write failure or an interrupt keeps the trials already written
    with create_archive(out, force=force, incremental=True) as archive:
        for path, table in zip(paths, tables):
            rate = table.pop("rate_hz")
            trial = archive.add_trial(path.stem, rate_hz=rate,
                                      controller=controller, environment=environment,
                                      source="import", description=f"imported from {path.name}")
            labels = table.pop("labels", None)
            trial.append(**table)
            if labels is not None:
                trial.set_ground_truth(labels=labels, names=names,
                                       segments=label_segments(labels, table["time"], rate))
            trial.close()
    return out


def _is_pattern(name: str) -> bool:
    return any(c in name for c in "*?[")


def _read_table(path: Path, mapping: dict[str, list[str]], rate_hz: float | None,
                delimiter: str | None = None) -> dict:
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
        rule = spec.trailing_shape(spec.MEASUREMENTS, field)
        if field in VECTOR_FIELDS and isinstance(rule[0], int) and values.shape[1] != rule[0]:
            raise DataError(f"field {field} needs {rule[0]} columns, the map gives "
                            f"{values.shape[1]} ({', '.join(cols)})", file=str(path),
                            field=field)
        if field == "action":
            if not np.all(values == np.round(values)):
                raise DataError("action codes must be integers", file=str(path), field=cols[0])
            values = values.astype(np.int64)
        table[field] = values[:, 0] if field in SCALAR_FIELDS else values
    n = len(frame)
    if "time" in table:
        t = table["time"]
        step = np.diff(t)
        if np.any(step <= 0):
            i = int(np.flatnonzero(step <= 0)[0]) + 1
            raise DataError(f"time is not strictly increasing (data row {i + 1})",
                            file=str(path), field=mapping["time"][0])
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
    else:
        table["time"] = np.arange(n) / rate_hz
    table.setdefault("rate_hz", rate_hz)
    return table


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
