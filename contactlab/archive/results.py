"""Analysis stages store their output under ``/trials/<id>/results/<stage>``.

:func:`write_results` rebuilds the archive into a temporary file beside it --
copying every HDF5 object unchanged except the one stage group it replaces --
and renames it over the original. A crash at any point leaves the original
archive as it was, measurements are copied chunk for chunk, and replaced
stages leave no dead space behind.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import numpy as np

from contactlab import __version__
from contactlab.archive import spec
from contactlab.archive.reader import open_archive
from contactlab.archive.writer import check_name, create_dataset, utc_now
from contactlab.errors import DataError, UsageError
from contactlab.fileio import atomic_path

#: Attributes write_results sets itself on every stage group.
RESERVED_ATTRS = ("created", "software_version", "parameters")


def write_results(path: str | os.PathLike, trial_id: str, stage: str, *, datasets: dict,
                  attrs: dict | None = None, parameters: dict | None = None) -> None:
    """Replace ``results/<stage>`` of trial ``trial_id`` with ``datasets`` and ``attrs``.

    ``datasets`` maps names to arrays (a name with '/' makes subgroups; string
    arrays are stored as UTF-8). ``parameters`` (JSON-serialisable) are stored
    as the stage's ``parameters`` attribute. Measurements are never touched.
    """
    path = Path(path)
    check_name(stage, "results stage")
    attrs = dict(attrs or {})
    clash = [k for k in RESERVED_ATTRS if k in attrs]
    if clash:
        raise UsageError(f"attribute {clash[0]!r} is set by write_results itself")
    arrays = {name: _as_array(name, value) for name, value in datasets.items()}
    try:
        params_json = json.dumps(parameters or {}, sort_keys=True, default=_json_default)
    except (TypeError, ValueError) as err:
        raise UsageError(f"parameters: {err}") from None
    with open_archive(path) as archive:
        if trial_id not in archive:
            raise DataError("no such trial", file=str(path), field=f"/trials/{trial_id}")
    target = f"/trials/{trial_id}/{spec.RESULTS}/{stage}"
    with atomic_path(path, force=True) as tmp:
        with h5py.File(path, "r") as src, h5py.File(tmp, "w") as dst:
            copy_tree(src, dst, skip={target})
            group = dst.require_group(f"/trials/{trial_id}/{spec.RESULTS}").create_group(stage)
            for name, arr in arrays.items():
                parent, _, leaf = name.rpartition("/")
                create_dataset(group.require_group(parent) if parent else group, leaf, arr,
                               chunk_rows=None)
            for key, value in attrs.items():
                group.attrs[key] = _attr_value(key, value)
            group.attrs["created"] = utc_now()
            group.attrs["software_version"] = __version__
            group.attrs["parameters"] = params_json


def copy_tree(src: h5py.Group, dst: h5py.Group, *, skip: set[str]) -> None:
    """Copy attributes and members of ``src`` into ``dst``, leaving out paths in ``skip``.

    Groups on the way to a skipped path are rebuilt; everything else is copied
    whole with HDF5's object copy (data, chunking, filters and attributes).
    """
    for key, value in src.attrs.items():
        dst.attrs[key] = value
    for name, obj in src.items():
        path = obj.name
        if path in skip:
            continue
        if isinstance(obj, h5py.Group) and any(s.startswith(path + "/") for s in skip):
            copy_tree(obj, dst.create_group(name), skip=skip)
        else:
            src.copy(obj, dst, name=name)


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
