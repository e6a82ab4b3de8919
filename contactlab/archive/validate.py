"""Check a file against ``archive.schema.json`` and name every offending HDF5 path.

:func:`validate_archive` never raises for bad input: it returns a list of
:class:`Problem` (empty when the file conforms). The walk is driven by the
schema (see ``datasets_spec/ARCHIVE.md``); the value checks the schema names
(``finite``, ``matches_rate``, ...) are the functions in :data:`CHECKS`.

Measurements are the bulk of an archive.  ``values=False`` checks their
layout only (dtypes, shapes, attributes, declared against stored sizes): the
analysis stages check their values with :func:`measurement_problems` on the
arrays they read anyway (:func:`contactlab.stages.run_stage`), so a stage
decompresses every measurement once, and bad values are reported in the same
words, naming the same file and field.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import h5py
import jsonschema
import numpy as np

from contactlab.archive import spec
from contactlab.archive.reader import archive_version_problem, h5_reason
from contactlab.errors import DataError

#: Deflate never compresses better than about 1032:1 (RFC 1951: a 258-byte match
#: costs at least 2 bits), so a dataset that declares more bytes than this many
#: times its stored bytes cannot hold them: it is refused before anything is read.
MAX_COMPRESSION_RATIO = 1100
#: Declared sizes up to this many bytes are never questioned (tiny datasets).
SMALL_DATASET_BYTES = 1 << 16

#: What h5py raises for a corrupt header, chunk or attribute.
_READ_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError)


@dataclass(frozen=True)
class Problem:
    """One way a file does not conform: where (HDF5 path or file name) and what."""

    path: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"


def validate_archive(path: str | os.PathLike, *, trials=None,
                     values: bool = True, walk_trials: bool = True) -> list[Problem]:
    """Every way the file at ``path`` departs from the archive format ([] = conforms).

    ``trials`` (ids) limits the walk under ``/trials`` to those trials; an id
    the archive does not hold is a problem.  ``values=False`` leaves out the
    value checks of the trials' measurements (see the module notes).
    ``walk_trials=False`` leaves out the trials' own contents too (their ids are
    still checked): a stage walks each trial where it runs
    (:func:`trial_problems`), so the walk is shared among its workers.
    """
    name = str(path)
    path = Path(path)
    if not path.exists():
        return [Problem(name, "no such file")]
    if not path.is_file():
        return [Problem(name, "not a file")]
    if not h5py.is_hdf5(path):
        return [Problem(name, "not an HDF5 file")]
    try:
        h5 = h5py.File(path, "r")
    except OSError as err:
        return [Problem(name, h5_reason(err))]
    with h5:
        try:
            problem = archive_version_problem(h5)
        except Exception as err:  # noqa: BLE001 - a corrupt root is a problem, not a crash
            return [Problem(name, h5_reason(err))]
        if problem:
            return [Problem(name, problem)]
        walker = _Walker(trials=trials, values=values, walk_trials=walk_trials)
        try:
            walker.group(h5, spec.schema()["root"], scope=None)
        except _READ_ERRORS as err:  # a corrupt header the walk could not step past
            walker.report(name, f"cannot be read: {h5_reason(err)}")
        return walker.problems


#: the problem of a trial asked for (``--trial``) that the archive lacks
NO_SUCH_TRIAL = "no such trial"


def check_archive(path: str | os.PathLike, *, trials=None, values: bool = True,
                  walk_trials: bool = True) -> None:
    """The up-front check every command runs on an archive it reads.

    Raises a :class:`DataError` naming the file, the first offending HDF5 path
    and what is wrong (the same words as ``contactlab validate``), with the
    number of further problems; returns None when the archive (or the trials
    ``trials`` of it) conforms.  ``values`` and ``walk_trials`` as for
    :func:`validate_archive`.
    """
    raise_problems(path, validate_archive(path, trials=trials or None, values=values,
                                          walk_trials=walk_trials))


def raise_problems(path: str | os.PathLike, problems: list[Problem]) -> None:
    """The DataError of :func:`check_archive` for ``problems`` (none: return)."""
    if not problems:
        return
    first = problems[0]
    more = len(problems) - 1
    if all(p.message.startswith(NO_SUCH_TRIAL) for p in problems):    # a mistyped --trial
        message = first.message + (f"; {more} more of the trials asked for are missing"
                                   if more else "")
    else:
        message = first.message + (f" (and {more} more problem{'s' if more > 1 else ''}; "
                                    f"see 'contactlab validate {path}')" if more else "")
    field = None if first.path == str(path) else first.path
    raise DataError(message, file=str(path), field=field)


def dataset_size_problem(ds: h5py.Dataset, file_size: int) -> str | None:
    """Why ``ds`` cannot hold the data its shape declares (None when it can).

    Compares the declared size with the bytes the file stores for it (and the
    file's size) before anything is allocated, so a header declaring 10^12
    rows is an error message, not a memory error.
    """
    declared = int(np.prod(ds.shape, dtype=np.float64) * ds.dtype.itemsize) \
        if ds.shape is not None else 0
    if declared <= SMALL_DATASET_BYTES:
        return None
    stored = int(ds.id.get_storage_size())
    limit = MAX_COMPRESSION_RATIO * min(max(stored, 1), max(file_size, 1))
    if declared > limit:
        return (f"shape {ds.shape} declares {declared:,} bytes, but the file stores only "
                f"{stored:,} bytes for it (a file of {file_size:,} bytes cannot hold it)")
    return None


# -- value checks named by the schema -------------------------------------------------

@dataclass
class _Scope:
    """The group that binds 'n' (a trial) and its time base."""

    group: h5py.Group
    time_path: str
    n: int | None = None
    #: the time base's values are checked later (``values=False``): do not use them
    deferred: bool = False

    def time_span(self) -> tuple[float, float] | None:
        """First and last sample time (reads two values, not the time base)."""
        if self.deferred:
            return None
        ds = self.group.get(self.time_path)
        if isinstance(ds, h5py.Dataset) and ds.ndim == 1 and ds.dtype.kind == "f" and \
                len(ds) and dataset_size_problem(ds, _file_size(ds)) is None:
            return float(ds[0]), float(ds[-1])
        return None

    def rate_hz(self) -> float | None:
        rate = spec.to_plain(self.group.attrs.get("rate_hz"))
        if isinstance(rate, (int, float)) and not isinstance(rate, bool) and rate > 0 \
                and np.isfinite(rate):
            return float(rate)
        return None


def _file_size(obj) -> int:
    try:       # the file's name from HDF5 itself: ``obj.file`` builds a File object
        return os.path.getsize(h5py.h5f.get_name(obj.id))
    except (OSError, ValueError, RuntimeError):
        return 0


def _first(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def _check_finite(ds: h5py.Dataset, data: np.ndarray, scope: _Scope | None) -> list[str]:
    fields = ([f for f in data.dtype.names if data.dtype[f].kind == "f"]
              if data.dtype.names else [None])
    out = []
    for f in fields:
        values = data if f is None else data[f]
        bad = ~np.isfinite(values)
        if bad.any():
            where = np.argwhere(bad)[0]
            out.append(f"{int(bad.sum())} non-finite values (NaN or Inf)"
                       f"{'' if f is None else f' in field {f}'}, first at index "
                       f"{tuple(int(i) for i in where) if len(where) > 1 else int(where[0])}")
    return out


def _check_nonempty(ds, data, scope) -> list[str]:
    return [] if len(data) else ["no samples (an empty trial)"]


def _check_strictly_increasing(ds, data, scope) -> list[str]:
    step = np.diff(data)
    bad = step <= 0
    if not bad.any():
        return []
    i = _first(bad)
    return [f"not strictly increasing: sample {i + 1} ({data[i + 1]:.9g} s) does not follow "
            f"sample {i} ({data[i]:.9g} s); {int(bad.sum())} such steps"]


def _check_matches_rate(ds, data, scope) -> list[str]:
    rate = scope.rate_hz() if scope else None
    if rate is None or len(data) < 2:
        return []
    dt = float(np.median(np.diff(data)))
    if abs(dt * rate - 1.0) <= spec.RATE_TOLERANCE:
        return []
    implied = f"{1.0 / dt:.6g} Hz" if dt > 0 else "no rate"
    return [f"median time step {dt:.6g} s implies {implied}, but the trial's rate_hz is "
            f"{rate:g} (tolerance {spec.RATE_TOLERANCE:.0%})"]


def _names(ds: h5py.Dataset) -> list[str] | None:
    names = spec.to_plain(ds.attrs.get("names"))
    return names if isinstance(names, list) else None


def _check_label_codes(ds, data, scope) -> list[str]:
    names = _names(ds)
    if names is None:
        return []
    bad = (data < -1) | (data >= len(names))
    if not bad.any():
        return []
    i = _first(bad)
    return [f"{int(bad.sum())} samples with an unknown label code (first: code {int(data[i])} "
            f"at sample {i}; names has {len(names)} entries, -1 = unlabelled)"]


def _check_segments(ds, data, scope) -> list[str]:
    out = []
    start, end, label = data["start_s"], data["end_s"], data["label"]
    backwards = end < start
    if backwards.any():
        i = _first(backwards)
        out.append(f"{int(backwards.sum())} segments end before they start (first: row {i}, "
                   f"start_s {start[i]:.9g}, end_s {end[i]:.9g})")
    span = scope.time_span() if scope else None
    if span is not None:
        out += _segments_outside(start, end, span, scope.rate_hz())
    names = _names(ds)
    if names is not None:
        unknown = (label < -1) | (label >= len(names))
        if unknown.any():
            i = _first(unknown)
            out.append(f"{int(unknown.sum())} segments with an unknown label code (first: row "
                       f"{i}, code {int(label[i])}; names has {len(names)} entries)")
    return out


def _segments_outside(start, end, span: tuple[float, float], rate: float | None) -> list[str]:
    first, last = span
    period = 1.0 / rate if rate else 0.0
    lo, hi = first - 1e-9, last + period * (1 + 1e-6) + 1e-9
    outside = (start < lo) | (end > hi) | (start > hi) | (end < lo)
    if not outside.any():
        return []
    i = _first(outside)
    return [f"{int(outside.sum())} segments outside the time base "
            f"[{first:g}, {last + period:g}] s (first: row {i}, {start[i]:g}-{end[i]:g} s)"]


def _check_unit_norm(ds, data, scope) -> list[str]:
    off = np.abs(np.linalg.norm(data, axis=-1) - 1.0) > spec.UNIT_NORM_TOLERANCE
    if not off.any():
        return []
    i = _first(off)
    return [f"{int(off.sum())} rows are not unit quaternions (first: sample {i}, norm "
            f"{float(np.linalg.norm(data[i])):.9g})"]


#: check name (as used in the schema) -> function(dataset, data, scope) -> messages.
CHECKS: dict[str, Callable] = {
    "finite": _check_finite,
    "nonempty": _check_nonempty,
    "strictly_increasing": _check_strictly_increasing,
    "matches_rate": _check_matches_rate,
    "label_codes": _check_label_codes,
    "segments": _check_segments,
    "unit_norm": _check_unit_norm,
}


def _check_json_attr(value) -> str | None:
    try:
        json.loads(value)
    except (TypeError, ValueError) as err:
        return f"is not valid JSON ({err})"
    return None


def _check_finite_attr(value) -> str | None:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and \
            not np.isfinite(value):
        return f"is {value!r}, expected a finite number"
    return None


#: attribute check name -> function(value) -> message or None.
ATTRIBUTE_CHECKS: dict[str, Callable] = {"json": _check_json_attr,
                                         "finite": _check_finite_attr}


def measurement_problems(trial) -> list[Problem]:
    """The value checks of the schema on the measurements of an open archive trial
    (:class:`contactlab.archive.reader.Trial`), run on the arrays the trial reads
    and caches: a stage that checks them first reads each dataset once."""
    nodes = _trial_node()["members"][spec.MEASUREMENTS]["members"]
    group = trial.h5_group
    scope = _Scope(group, _trial_node()["symbols"]["n"])
    out = []
    measurements = group.get(spec.MEASUREMENTS)
    for name, node in nodes.items():
        # members looked up by link name in their group (a path lookup per member
        # costs several times more, and most optional members are absent)
        if not node.get("checks") or not isinstance(measurements, h5py.Group) or \
                not measurements.id.links.exists(name.encode()):
            continue
        ds = measurements.get(name)
        if not isinstance(ds, h5py.Dataset):
            continue
        data = getattr(trial, name)         # Trial reads and caches each measurement
        for check in node["checks"]:
            out += [Problem(ds.name, m) for m in CHECKS[check](ds, data, scope)]
    truth = group.get(spec.GROUND_TRUTH)
    segments = truth.get("segments") if isinstance(truth, h5py.Group) else None
    if not out and isinstance(segments, h5py.Dataset) and len(trial.time):
        # the part of the segments check that needs the time base's values
        table = segments[()]
        out += [Problem(segments.name, m) for m in _segments_outside(
            table["start_s"], table["end_s"], (float(trial.time[0]), float(trial.time[-1])),
            scope.rate_hz())]
    return out


def trial_problems(trial, *, values: bool = True) -> list[Problem]:
    """The problems of one open archive trial (:class:`contactlab.archive.reader.Trial`):
    the schema walk of :func:`validate_archive` over ``/trials/<id>`` (its layout,
    in the same words), then, when that is clean and ``values``, the value checks
    of :func:`measurement_problems`."""
    group = trial.h5_group
    walker = _Walker(values=False)
    # the trial's own attributes were read (and decoded) when the trial was opened
    walker.preread[group.name] = trial.attrs
    try:
        walker.member(group.parent, group.name.rsplit("/", 1)[-1], _trial_node(), None)
    except _READ_ERRORS as err:
        walker.report(group.name, f"cannot be read: {h5_reason(err)}")
    if walker.problems or not values:
        return walker.problems
    return measurement_problems(trial)


def _trial_node() -> dict:
    return spec.schema()["root"]["members"]["trials"]["each"]


# -- the schema walk ------------------------------------------------------------------

_VALIDATORS: dict[int, tuple[dict, jsonschema.Draft202012Validator]] = {}


def _validator(aspec: dict) -> jsonschema.Draft202012Validator:
    """The JSON Schema validator of one attribute's spec (made once per spec)."""
    got = _VALIDATORS.get(id(aspec))
    if got is None or got[0] is not aspec:
        got = _VALIDATORS[id(aspec)] = (aspec, jsonschema.Draft202012Validator(aspec["schema"]))
    return got[1]


class _Walker:
    """Walks an HDF5 tree beside the schema, collecting problems."""

    def __init__(self, trials=None, values: bool = True, walk_trials: bool = True):
        self.problems: list[Problem] = []
        self.trials = None if trials is None else list(trials)
        self.values = values
        self.walk_trials = walk_trials
        #: object path -> its attributes already read and decoded (``spec.to_plain``)
        self.preread: dict[str, dict] = {}

    def report(self, path: str, message: str) -> None:
        self.problems.append(Problem(path, message))

    def group(self, group: h5py.Group, node: dict, scope: _Scope | None) -> None:
        path = group.name
        if "symbols" in node:
            scope = self._bind(group, node["symbols"])
        self.attributes(group, node.get("attributes", {}), symbols={})
        members = node.get("members", {})
        for name, child in members.items():
            self.member(group, name, child, scope)
        if "require_any" in node and not any(n in group for n in node["require_any"]):
            self.report(path, f"needs at least one of {', '.join(node['require_any'])}")
        each = node.get("each")
        if each is not None:
            names = sorted(group.keys())
            if path == "/trials" and self.trials is not None:
                have = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")
                for name in self.trials:
                    if name not in group:
                        self.report(f"/trials/{name}", f"{NO_SUCH_TRIAL} (its trials: {have}; "
                                    f"{len(names)} in all, 'contactlab info' lists them)")
                names = [n for n in self.trials if n in group]
            if path == "/trials" and not self.walk_trials:
                names = []
            for name in names:
                if name not in members:
                    self.member(group, name, each, scope)

    def member(self, parent: h5py.Group, name: str, node: dict, scope: _Scope | None) -> None:
        path = f"{parent.name.rstrip('/')}/{name}"
        kind = node["kind"]
        try:
            link = parent.get(name, getlink=True)
            if isinstance(link, h5py.ExternalLink):
                self.report(path, f"is an external link to {link.filename}:{link.path} "
                                  "(an archive holds its data itself)")
                return
            obj = None if link is None else parent.get(name)   # no link: one lookup, not two
            if obj is None and isinstance(link, h5py.SoftLink):
                self.report(path, f"is a dangling soft link (to {link.path}, which does "
                                  "not exist)")
                return
            if obj is None:
                if node.get("required"):
                    self.report(path, f"missing {kind}")
                return
            expected = h5py.Group if kind == "group" else h5py.Dataset
            if not isinstance(obj, expected):
                self.report(path, f"is a {type(obj).__name__.lower()}, expected a {kind}")
                return
            if kind == "group":
                self.group(obj, node, scope)
            else:
                self.dataset(obj, node, scope)
        except _READ_ERRORS as err:
            self.report(path, f"cannot be read: {h5_reason(err)}")

    def _bind(self, group: h5py.Group, symbols: dict) -> _Scope:
        time_path = symbols["n"]
        scope = _Scope(group, time_path, deferred=not self.values)
        try:
            ds = group.get(time_path)
        except (OSError, RuntimeError, KeyError, ValueError, TypeError):
            ds = None  # reported when the walk reaches it
        if isinstance(ds, h5py.Dataset) and ds.ndim == 1:
            scope.n = int(ds.shape[0])
        return scope

    def dataset(self, ds: h5py.Dataset, node: dict, scope: _Scope | None) -> None:
        path = ds.name
        ok = self._dtype(ds, node)
        symbols: dict[str, int] = {}
        ok = self._shape(path, ds.shape, node["shape"], symbols, scope, what="shape") and ok
        self.attributes(ds, node.get("attributes", {}), symbols)
        if ok:
            too_big = dataset_size_problem(ds, _file_size(ds))
            if too_big:
                self.report(path, too_big)
                ok = False
        if ok and node.get("checks") and (
                self.values or path.rsplit("/", 2)[-2:-1] != [spec.MEASUREMENTS]):
            data = ds[()]
            for check in node["checks"]:
                for message in CHECKS[check](ds, data, scope):
                    self.report(path, message)

    def _dtype(self, ds: h5py.Dataset, node: dict) -> bool:
        kind = node["dtype"]
        dtype = ds.dtype
        if kind == "compound":
            fields = node.get("fields", {})
            if dtype.names is None:
                self.report(ds.name, f"dtype {dtype}, expected a compound of "
                                     f"{', '.join(fields)}")
                return False
            ok = True
            for field, fkind in fields.items():
                if field not in dtype.names:
                    self.report(ds.name, f"compound dtype has no field '{field}'")
                    ok = False
                elif dtype[field].kind not in spec.DTYPE_KINDS[fkind]:
                    self.report(ds.name, f"field '{field}' has dtype {dtype[field]}, "
                                         f"expected {fkind}")
                    ok = False
            return ok
        if dtype.kind not in spec.DTYPE_KINDS[kind] or (
                kind == "string" and not h5py.check_string_dtype(dtype)):
            self.report(ds.name, f"dtype {dtype}, expected {kind}")
            return False
        if "itemsize" in node and dtype.itemsize != node["itemsize"]:
            self.report(ds.name, f"dtype {dtype}, expected {kind}{8 * node['itemsize']}")
            return False
        return True

    def _shape(self, path: str, shape: tuple, rule: list, symbols: dict,
               scope: _Scope | None, *, what: str) -> bool:
        if len(shape) != len(rule):
            self.report(path, f"{what} {shape} has {len(shape)} dimensions, expected "
                              f"{spec.shape_text(rule)}")
            return False
        for axis, (size, want) in enumerate(zip(shape, rule)):
            if isinstance(want, int):
                if size != want:
                    self.report(path, f"{what} {shape}, expected {spec.shape_text(rule)}")
                    return False
            elif want == "n" and scope is not None:
                if scope.n is not None and size != scope.n:
                    self.report(path, f"{what} {shape}: {size} along axis {axis}, but "
                                      f"{scope.time_path} has {scope.n} samples")
                    return False
            elif symbols.setdefault(want, size) != size:
                self.report(path, f"{what} {shape}, expected {spec.shape_text(rule)} with "
                                  f"{want} = {symbols[want]}")
                return False
        return True

    def attributes(self, obj, specs: dict, symbols: dict) -> None:
        path = obj.name
        for name, aspec in specs.items():
            try:
                self.attribute(obj, path, name, aspec, symbols)
            except _READ_ERRORS as err:
                self.report(path, f"attribute '{name}' cannot be read: {h5_reason(err)}")

    def attribute(self, obj, path: str, name: str, aspec: dict, symbols: dict) -> None:
        known = self.preread.get(path) if "shape" not in aspec else None   # raw arrays
        if name not in (obj.attrs if known is None else known):
            if aspec.get("required"):
                self.report(path, f"missing attribute '{name}'")
            return
        if known is None:
            raw = obj.attrs[name]
            value = spec.to_plain(raw)
        else:
            raw = value = known[name]
        if "schema" in aspec:
            validator = _validator(aspec)
            err = None if validator.is_valid(value) else \
                jsonschema.exceptions.best_match(validator.iter_errors(value))
            if err is not None:
                message = (f"{err.instance!r}, expected {err.validator_value!r}"
                           if err.validator == "const" else err.message)
                self.report(path, f"attribute '{name}': {aspec.get('message', message)}")
                return
        if "shape" in aspec:
            arr = np.asarray(raw)
            kind = aspec.get("dtype")
            if kind and arr.dtype.kind not in spec.DTYPE_KINDS[kind]:
                self.report(path, f"attribute '{name}' has dtype {arr.dtype}, expected {kind}")
                return
            if not self._shape(path, arr.shape, aspec["shape"], symbols, None,
                               what=f"attribute '{name}' shape"):
                return
        for check in aspec.get("checks", []):
            message = ATTRIBUTE_CHECKS[check](value)
            if message:
                self.report(path, f"attribute '{name}' {message}")

