"""Analysis stages store their output under ``/trials/<id>/results/<stage>``.

:func:`write_stage` writes one stage's results for many trials in one atomic
step: under an exclusive lock it copies the archive byte for byte into a
temporary file beside it (the measurements are never decoded or re-encoded),
replaces the stage groups in the copy, and renames it over the original.
:func:`write_results` is the one-trial form of the same call.

Why a copy per call rather than in-place writes: HDF5 updates in place are
not crash-safe (a killed writer can leave a file whose superblock and object
headers disagree).  The copy costs one sequential pass over the file (the
kernel's ``copy_file_range``), so a stage's cost stays linear in the archive,
and the archive stays one file.

Dead space.  Replacing a group frees its space inside the file; HDF5 reuses
it for the new results of the same write (a rerun of a stage lands in the
space of the results it replaces) but forgets what is left when the file is
closed.  So once the file has grown by a quarter past its size at the last
rewrite (root attribute ``compacted_bytes``), the write rebuilds the archive
instead -- an HDF5 object copy of everything but the replaced groups, which
moves raw chunks and leaves no dead space -- and the cost of rebuilds stays
in proportion to the growth.

Small results datasets (below :data:`CONTIGUOUS_BYTES`) are stored
contiguous and uncompressed; larger ones chunked and compressed like the
measurements.

Guarantees:

- a crash or kill at any moment leaves the old results or the new, never a
  broken file; measurements are copied byte for byte;
- concurrent writers of one archive serialise on an ``flock`` of the
  archive's directory and each re-reads the latest file under it, so two
  stages run at once both land (the second waits for the first's rename);
- a read-only archive (no write bit) is refused with one line naming it and
  is left as it is; a replaced archive keeps its permission bits;
- temporary files left beside the archive by a killed write
  (``.NAME.PID-XXXX.tmp`` whose writer is gone) are removed, with a note on
  stderr, by the next write (:func:`contactlab.fileio.atomic_path`).
"""

from __future__ import annotations

import contextlib
import functools
import fcntl
import json
import os
import shutil
import stat
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from contactlab import __version__
from contactlab.archive import spec
from contactlab.archive.reader import open_archive
from contactlab.archive import writer
from contactlab.archive.writer import check_name, utc_now
from contactlab.errors import DataError, UsageError
from contactlab.fileio import (atomic_path, check_writable, read_only_reason,
                               refuse_while_recorded)

#: Attributes write_stage sets itself on every stage group.
RESERVED_ATTRS = ("created", "software_version", "parameters")
#: Results datasets smaller than this are stored contiguous and uncompressed.
CONTIGUOUS_BYTES = 1 << 20
#: Root attribute: the file's size in bytes when a results write last rebuilt it.
COMPACTED_ATTR = "compacted_bytes"
#: A results write rebuilds the archive once it is this much larger than then.
REBUILD_GROWTH = 1.25


@dataclass
class TrialResults:
    """One trial's results of one stage: datasets, attributes and parameters.

    ``datasets`` maps names to arrays (a name with '/' makes subgroups; string
    arrays are stored as UTF-8); ``parameters`` (JSON-serialisable) become the
    stage group's ``parameters`` attribute.
    """

    datasets: dict
    attrs: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)


def write_results(path: str | os.PathLike, trial_id: str, stage: str, *, datasets: dict,
                  attrs: dict | None = None, parameters: dict | None = None) -> None:
    """Replace ``results/<stage>`` of one trial (:func:`write_stage` for one trial)."""
    write_stage(path, stage, {trial_id: TrialResults(datasets, dict(attrs or {}),
                                                     dict(parameters or {}))})


def write_stage(path: str | os.PathLike, stage: str,
                results: Mapping[str, TrialResults]) -> None:
    """Replace ``results/<stage>`` of every trial in ``results`` in one atomic step.

    Trials not in ``results`` keep what they had; measurements are never
    touched. Raises DataError (naming the archive) when it is read-only or a
    trial is missing, UsageError for results that cannot be stored.
    """
    name = Path(path)                        # as the user gave it, for messages
    path = Path(os.path.realpath(path))      # through a symlink: replace the file, keep the link
    check_name(stage, "results stage")
    prepared = {tid: _prepare(r) for tid, r in results.items()}
    if not prepared:
        return
    check_archive_writable(name)
    targets = {f"/trials/{tid}/{spec.RESULTS}/{stage}" for tid in prepared}
    with archive_lock(path):
        with open_archive(path) as archive:
            missing = next((t for t in prepared if t not in archive), None)
        if missing is not None:
            raise DataError("no such trial", file=str(name), field=f"/trials/{missing}")
        mode = stat.S_IMODE(os.stat(path).st_mode)
        with atomic_path(path, force=True) as tmp:
            with h5py.File(path, "r") as src:
                compacted = spec.to_plain(src.attrs.get(COMPACTED_ATTR))
            size = os.path.getsize(path)
            rebuild = isinstance(compacted, int) and size > REBUILD_GROWTH * compacted
            if rebuild:
                with h5py.File(path, "r") as src, h5py.File(tmp, "w") as dst:
                    copy_tree(src, dst, skip=targets)
                    _write_stage_groups(dst, stage, prepared)
            else:
                shutil.copyfile(path, tmp)       # raw bytes: measurements never decoded
                with h5py.File(tmp, "r+") as dst:
                    _write_stage_groups(dst, stage, prepared, replace=True)
                    if not isinstance(compacted, int):
                        dst.attrs[COMPACTED_ATTR] = size
            if rebuild:
                with h5py.File(tmp, "r+") as dst:
                    dst.attrs[COMPACTED_ATTR] = os.path.getsize(tmp)
            os.chmod(tmp, mode)
            with open(tmp, "rb") as f:
                os.fsync(f.fileno())


def check_archive_writable(path: str | os.PathLike) -> None:
    """Refuse, before any work, an archive that is missing or read-only (or in a
    read-only directory) by its mode bits (:func:`contactlab.fileio.read_only_reason`: the super-user may write
    anything, so the bits, not ``os.access``, say whether it was made read-only)."""
    if not Path(path).exists():
        raise DataError("no such file", file=str(path))
    refuse_while_recorded(path)
    reason = read_only_reason(path)
    if reason:
        raise DataError(f"archive {reason}; results not written", file=str(path))
    # the rebuild goes to a temporary file beside it: its directory must take one too
    check_writable(os.path.realpath(path), force=True)


@contextlib.contextmanager
def archive_lock(path: str | os.PathLike) -> Iterator[None]:
    """Hold an exclusive ``flock`` on the archive's directory (results writers wait).

    The directory, not the archive, is locked because the archive is replaced
    by a rename (a lock on its inode would guard the old file) and HDF5 takes
    its own ``flock`` on files it opens; locking the directory leaves no lock
    file behind.
    """
    fd = os.open(Path(path).resolve().parent, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing the descriptor releases the lock


def copy_tree(src: h5py.Group, dst: h5py.Group, *, skip: set[str]) -> None:
    """Copy attributes and members of ``src`` into ``dst``, leaving out paths in ``skip``.

    Groups on the way to a skipped path are rebuilt; everything else is copied
    whole with HDF5's object copy (data, chunking, filters and attributes).
    """
    ancestors = {p.rsplit("/", k)[0] for p in skip for k in range(1, p.count("/"))}
    _copy_tree(src, dst, skip, ancestors)


def _copy_tree(src, dst, skip, ancestors) -> None:
    for key, value in src.attrs.items():
        dst.attrs[key] = value
    for name, obj in src.items():
        path = obj.name
        if path in skip:
            continue
        if path in ancestors and isinstance(obj, h5py.Group):
            _copy_tree(obj, dst.create_group(name), skip, ancestors)
        else:
            src.copy(obj, dst, name=name)


def _prepare(result: TrialResults):
    attrs = dict(result.attrs or {})
    clash = [k for k in RESERVED_ATTRS if k in attrs]
    if clash:
        raise UsageError(f"attribute {clash[0]!r} is set by write_results/write_stage itself")
    arrays = {name: _as_array(name, value) for name, value in result.datasets.items()}
    try:
        params_json = json.dumps(result.parameters or {}, sort_keys=True,
                                 default=_json_default)
    except (TypeError, ValueError) as err:
        raise UsageError(f"parameters: {err}") from None
    return arrays, {k: _attr_value(k, v) for k, v in attrs.items()}, params_json


def _write_stage_groups(dst: h5py.File, stage: str, prepared: dict, *,
                        replace: bool = False) -> None:
    """``results/<stage>`` of every prepared trial; ``replace``: delete an old one first
    (its freed space is reused by the new results).  Each trial's group is looked up
    once and its members by link name (path lookups cost several times more)."""
    trials = dst["trials"]
    results, name = spec.RESULTS.encode(), stage.encode()
    for tid, (arrays, attrs, params_json) in prepared.items():
        trial = trials[tid]
        if trial.id.links.exists(results):
            group = trial[spec.RESULTS]
            if not isinstance(group, h5py.Group):
                raise TypeError(f"/trials/{tid}/{spec.RESULTS} is a "
                                f"{type(group).__name__.lower()}, not a group")
            if replace and group.id.links.exists(name):
                del group[stage]
        else:
            group = trial.create_group(spec.RESULTS)
        _write_group(group.create_group(stage), arrays, attrs, params_json)


def _write_group(group: h5py.Group, arrays: dict, attrs: dict, params_json: str) -> None:
    for name, arr in arrays.items():
        parent, _, leaf = name.rpartition("/")
        create_dataset(group.require_group(parent) if parent else group, leaf, arr)
    for key, value in {**attrs, "created": utc_now(), "software_version": __version__,
                       "parameters": params_json}.items():
        if isinstance(value, str):
            _new_string_attr(group.id, key, value)
        else:
            group.attrs[key] = value


@functools.cache
def _string_types():
    """HDF5's variable-length UTF-8 string type (file and memory) and a scalar space."""
    dtype = h5py.string_dtype()
    return (dtype, h5py.h5t.py_create(dtype, logical=True), h5py.h5t.py_create(dtype),
            h5py.h5s.create(h5py.h5s.SCALAR))


def _new_string_attr(gid, name: str, value: str) -> None:
    """A scalar string attribute on an object that has none of that name: what
    ``obj.attrs[name] = value`` stores, through HDF5's own calls (a third of the time;
    a stage writes several per trial)."""
    dtype, file_type, mem_type, scalar = _string_types()
    attr = h5py.h5a.create(gid, name.encode(), file_type, scalar)
    attr.write(np.array(value, dtype=dtype), mtype=mem_type)


def create_dataset(group: h5py.Group, name: str, arr: np.ndarray) -> h5py.Dataset:
    """One results dataset: contiguous and uncompressed below :data:`CONTIGUOUS_BYTES`,
    else chunked and compressed like the measurements."""
    if arr.nbytes < CONTIGUOUS_BYTES:
        if arr.dtype.kind in "biuf" and arr.dtype.isnative:
            return h5py.Dataset(_contiguous(group.id, name, np.require(arr, requirements="C")))
        return group.create_dataset(name, data=arr)
    return writer.create_dataset(group, name, arr, chunk_rows=None)


@functools.cache
def _dcpl():
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_obj_track_times(False)      # as create_dataset: the same bytes on every run
    return dcpl


def _contiguous(gid, name: str, arr: np.ndarray):
    """A contiguous numeric dataset through HDF5's own calls: what ``create_dataset``
    makes for such an array, without its keyword handling (a stage writes several
    per trial, so this is the results write's per-dataset cost)."""
    space = h5py.h5s.create(h5py.h5s.SCALAR) if arr.ndim == 0 else \
        h5py.h5s.create_simple(arr.shape)
    dsid = h5py.h5d.create(gid, name.encode(), h5py.h5t.py_create(arr.dtype), space,
                           dcpl=_dcpl())
    if arr.size:
        dsid.write(h5py.h5s.ALL, h5py.h5s.ALL, arr)
    return dsid


def _as_array(name: str, value) -> np.ndarray:
    if not name or name.startswith("/") or "//" in name or name.endswith("/"):
        raise UsageError(f"results dataset name {name!r} is not a relative HDF5 path")
    arr = np.asarray(value)
    if arr.dtype.kind in "UO":
        if not all(isinstance(v, str) for v in arr.ravel().tolist()):
            raise UsageError(f"results dataset {name!r} holds objects that are not strings")
        return arr.astype(spec.STRING_DTYPE)
    if arr.dtype.kind not in "biufcSV":
        raise UsageError(f"results dataset {name!r} has unsupported dtype {arr.dtype}")
    return arr


def _attr_value(key: str, value):
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, str) for v in value):
        return spec.string_array(value)
    if isinstance(value, (dict, type(None))):
        raise UsageError(f"results attribute {key!r}: store dicts and None in parameters")
    return value


def _json_default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"parameters value of type {type(obj).__name__} is not JSON-serialisable")
