"""The archive schema (``datasets_spec/archive.schema.json``) as Python data.

The writer takes units, column names and trailing dimensions from here, and
:mod:`contactlab.archive.validate` walks the whole tree, so the JSON file is
the one place the format is stated. ``datasets_spec/ARCHIVE.md`` explains it.
"""

from __future__ import annotations

import functools
import json
from importlib.resources import files

import h5py
import numpy as np

FORMAT = "contactlab-archive"
FORMAT_VERSION = "1.0"

#: HDF5 paths relative to a trial group.
MEASUREMENTS = "measurements"
GROUND_TRUTH = "ground_truth"
RESULTS = "results"

#: Per-sample measurement datasets, in the order the writer and reader list them.
MEASUREMENT_FIELDS = ("time", "strain", "wrench", "position", "velocity", "orientation",
                      "action", "command")

#: Largest relative difference between the median time step and 1 / rate_hz (check
#: ``matches_rate`` of the schema).
RATE_TOLERANCE = 0.01

#: Largest distance of a stored orientation quaternion's norm from 1 (check ``unit_norm``).
UNIT_NORM_TOLERANCE = 1e-6

#: Dtype kinds of the schema -> numpy dtype kind letters.
DTYPE_KINDS = {"float": "f", "int": "i", "string": "OSU", "compound": "V"}

STRING_DTYPE = h5py.string_dtype()


@functools.cache
def schema() -> dict:
    """The parsed ``archive.schema.json`` (cached; do not modify)."""
    text = files("contactlab.datasets_spec").joinpath("archive.schema.json").read_text("utf-8")
    data = json.loads(text)
    if data.get("format") != FORMAT or data.get("format_version") != FORMAT_VERSION:
        raise RuntimeError("archive.schema.json does not describe format "
                           f"{FORMAT} {FORMAT_VERSION}")
    return data


def trial_spec() -> dict:
    """The schema node of one ``/trials/<trial_id>`` group."""
    return schema()["root"]["members"]["trials"]["each"]


def dataset_spec(group: str, name: str) -> dict:
    """The schema node of dataset ``name`` in the trial subgroup ``group``."""
    return trial_spec()["members"][group]["members"][name]


def fixed_units(group: str, name: str) -> str | None:
    """The units a dataset must carry, when the schema fixes them (else None)."""
    units = dataset_spec(group, name).get("attributes", {}).get("units")
    return None if units is None else units["schema"].get("const")


def default_attr(group: str, name: str, attr: str):
    """The schema's default value of an attribute (None when there is none)."""
    return dataset_spec(group, name).get("attributes", {}).get(attr, {}).get("default")


def trailing_shape(group: str, name: str) -> tuple:
    """Shape rule after axis 0: integers are fixed sizes, strings free sizes."""
    return tuple(dataset_spec(group, name)["shape"][1:])


def shape_text(rule) -> str:
    """``["n", 6]`` -> ``"(n, 6)"`` for messages."""
    return "(" + ", ".join(str(d) for d in rule) + ("," if len(rule) == 1 else "") + ")"


def to_plain(value):
    """An HDF5 attribute value as plain Python/JSON data (arrays -> lists, bytes -> str)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.ndarray):
        return [to_plain(v) for v in value.tolist()] if value.ndim else to_plain(value.item())
    if isinstance(value, list):
        return [to_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def string_array(values) -> np.ndarray:
    """A list of str as an HDF5 variable-length UTF-8 string array."""
    return np.array([str(v) for v in values], dtype=STRING_DTYPE)
