"""The bad-input corpus: malformed archives, made from a valid one in the test run.

Each case is ``(id, mutate(path), field, fragment)``: ``mutate`` breaks the
archive at ``path`` in place (with h5py, or by editing bytes), ``field`` is the
HDF5 path (or None for a whole-file defect) every command must name, and
``fragment`` a piece of the message. No binary is committed: everything is
generated from the fixture archive of ``conftest.write_archive``.
"""

from __future__ import annotations

import h5py
import numpy as np

T = "/trials/t01"
M = f"{T}/measurements"
G = f"{T}/ground_truth"


def with_h5(change):
    """A mutation that opens the archive read-write and calls ``change(f)``."""
    def mutate(path):
        with h5py.File(path, "r+") as f:
            change(f)
    return mutate


def replace(f, path, data, **attrs):
    """Replace dataset ``path`` by ``data`` (an array, or a group when data is None)."""
    old = dict(f[path].attrs)
    del f[path]
    if data is None:
        obj = f.create_group(path)
    else:
        obj = f.create_dataset(path, data=data)
    for k, v in {**old, **attrs}.items():
        obj.attrs[k] = v


def set_rate(value):
    return with_h5(lambda f: f[T].attrs.__setitem__("rate_hz", value))


def set_time(transform):
    return with_h5(lambda f: replace(f, f"{M}/time", transform(f[f"{M}/time"][()])))


def _declare_huge(f):
    """A time dataset declaring 10^12 rows while the file stores a few chunks."""
    old = f[f"{M}/time"]
    attrs = dict(old.attrs)
    del f[f"{M}/time"]
    ds = f.create_dataset(f"{M}/time", shape=(10**12,), maxshape=(None,), dtype="<f8",
                          chunks=(1024,))
    for k, v in attrs.items():
        ds.attrs[k] = v


def _truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _bad_superblock(path):
    data = bytearray(path.read_bytes())
    data[8] = 99  # superblock version 99 after the 8-byte signature
    path.write_bytes(bytes(data))


def _empty_trial(f):
    for name in list(f[M]):
        ds = f[f"{M}/{name}"]
        replace(f, ds.name, ds[()][:0])
    del f[G]


ARCHIVE_CASES = [
    ("rate 0", set_rate(0.0), T, "rate_hz"),
    ("rate negative", set_rate(-1000.0), T, "rate_hz"),
    ("rate NaN", set_rate(np.nan), T, "rate_hz"),
    ("rate Inf", set_rate(np.inf), T, "rate_hz"),
    ("rate string", set_rate("1000"), T, "rate_hz"),
    ("rate array", set_rate(np.array([1000.0, 1000.0])), T, "rate_hz"),
    ("rate True", set_rate(True), T, "rate_hz"),
    ("rate 1e300", set_rate(1e300), f"{M}/time", "rate_hz"),
    ("rate missing", with_h5(lambda f: f[T].attrs.__delitem__("rate_hz")), T, "rate_hz"),
    ("time a group", with_h5(lambda f: replace(f, f"{M}/time", None)), f"{M}/time",
     "expected a dataset"),
    ("time scalar", set_time(lambda t: t[0]), f"{M}/time", "dimensions"),
    ("time 2-D", set_time(lambda t: np.column_stack([t, t])), f"{M}/time", "dimensions"),
    ("time strings", set_time(lambda t: np.array([str(v) for v in t], dtype="S")),
     f"{M}/time", "expected float"),
    ("time float32", set_time(lambda t: t.astype(np.float32)), f"{M}/time", "float64"),
    ("NaN in time", set_time(lambda t: np.where(np.arange(len(t)) == 5, np.nan, t)),
     f"{M}/time", "non-finite"),
    ("reversed time", set_time(lambda t: t[::-1].copy()), f"{M}/time",
     "not strictly increasing"),
    ("non-monotonic time", set_time(lambda t: np.concatenate([t[:300], t[250:550], t[600:]])
                                    if len(t) >= 600 else t[::-1].copy()),
     f"{M}/time", "not strictly increasing"),
    ("strain longer than time",
     with_h5(lambda f: replace(f, f"{M}/strain", np.vstack([f[f"{M}/strain"][()]] * 2))),
     f"{M}/strain", "samples"),
    ("wrench 100 rows short",
     with_h5(lambda f: replace(f, f"{M}/wrench", f[f"{M}/wrench"][:-100])),
     f"{M}/wrench", "samples"),
    ("NaN strain", with_h5(lambda f: f[f"{M}/strain"].__setitem__((10, 3), np.nan)),
     f"{M}/strain", "non-finite"),
    ("Inf wrench", with_h5(lambda f: f[f"{M}/wrench"].__setitem__((3, 0), -np.inf)),
     f"{M}/wrench", "non-finite"),
    ("complex strain",
     with_h5(lambda f: replace(f, f"{M}/strain", f[f"{M}/strain"][()].astype(np.complex128))),
     f"{M}/strain", "expected float"),
    ("integer wrench",
     with_h5(lambda f: replace(f, f"{M}/wrench", f[f"{M}/wrench"][()].astype(np.int32))),
     f"{M}/wrench", "expected float"),
    ("empty trial", with_h5(_empty_trial), f"{M}/time", "no samples"),
    ("complete false", with_h5(lambda f: f[T].attrs.__setitem__("complete", False)), T,
     "interrupted"),
    ("results a dataset", with_h5(lambda f: f[T].create_dataset("results", data=[1, 2])),
     f"{T}/results", "expected a group"),
    ("stage results a dataset",
     with_h5(lambda f: f.create_dataset(f"{T}/results/segment", data=[1.0])),
     f"{T}/results/segment", "expected a group"),
    ("segments not compound",
     with_h5(lambda f: replace(f, f"{G}/segments", np.zeros((3, 3)))), f"{G}/segments",
     "compound"),
    ("label code out of range",
     with_h5(lambda f: f[f"{G}/labels"].__setitem__(7, 40)), f"{G}/labels", "label code"),
    ("dangling soft link",
     with_h5(lambda f: (f[M].__delitem__("wrench"),
                        f[M].__setitem__("wrench", h5py.SoftLink("/nowhere/wrench")))),
     f"{M}/wrench", "dangling"),
    ("external link",
     with_h5(lambda f: (f[M].__delitem__("strain"),
                        f[M].__setitem__("strain", h5py.ExternalLink("gone.h5", "/s")))),
     f"{M}/strain", "external link"),
    ("declared 10^12 rows", with_h5(_declare_huge), f"{M}/time", "declares"),
    ("no trials group", with_h5(lambda f: f.__delitem__("trials")), "/trials", "missing"),
    ("not an archive", with_h5(lambda f: f.attrs.__setitem__("format", "other")), None,
     "not a contactlab archive"),
    ("truncated", _truncate, None, "truncated"),
    ("bad superblock", _bad_superblock, None, "superblock"),
    ("not HDF5", lambda p: p.write_bytes(b"time,fx\n0,1\n"), None, "not an HDF5 file"),
    ("empty file", lambda p: p.write_bytes(b""), None, "not an HDF5 file"),
]
