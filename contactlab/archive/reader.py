"""Reading archives: :func:`open_archive` -> :class:`Archive` -> :class:`Trial`.

::

    with open_archive("runs.h5") as archive:
        for trial in archive:
            print(trial.id, trial.rate_hz, trial.wrench.shape, trial.label_names)

Arrays are read on first access and cached; the archive must stay open while
they are read. Absent optional datasets read as None.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import re
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np
import pandas as pd

from contactlab.archive import spec
from contactlab.errors import DataError


def open_h5(path: str | os.PathLike, mode: str = "r") -> h5py.File:
    """Open ``path`` as an HDF5 file, or raise a DataError saying why it cannot be."""
    path = Path(path)
    if not path.exists():
        raise DataError("no such file", file=str(path))
    if path.is_dir():
        raise DataError("is a directory, not an archive", file=str(path))
    if not h5py.is_hdf5(path):
        raise DataError("not an HDF5 file", file=str(path))
    try:
        return h5py.File(path, mode)
    except OSError as err:
        raise DataError(h5_reason(err), file=str(path)) from None


def h5_reason(err: Exception) -> str:
    """A short reason for an HDF5 error (truncated, corrupt, locked)."""
    text = str(err)
    if "truncated" in text:
        return "truncated HDF5 file (it ends before its stored end of file)"
    if re.search(r"\bunable to lock file\b|\bfile locking\b|\block(ed)? by\b", text):
        return "cannot be opened: the file is locked by another process"
    if "superblock" in text or "file signature" in text:
        return f"corrupt HDF5 file: its superblock cannot be read ({text.splitlines()[0]})"
    return f"unreadable HDF5 file ({text.splitlines()[0] if text else type(err).__name__})"


def archive_version_problem(h5: h5py.File) -> str | None:
    """Why an open HDF5 file is not a readable contactlab archive (None if it is)."""
    fmt = spec.to_plain(h5.attrs.get("format"))
    if fmt != spec.FORMAT:
        return (f"not a contactlab archive (root attribute format is {fmt!r}, "
                f"expected {spec.FORMAT!r})" if fmt is not None else
                "not a contactlab archive (no root attribute 'format')")
    version = str(spec.to_plain(h5.attrs.get("format_version", "")))
    if version.split(".")[0] != spec.FORMAT_VERSION.split(".")[0]:
        return f"unsupported format_version {version!r} (this contactlab reads 1.x)"
    return None


def open_archive(path: str | os.PathLike) -> Archive:
    """Open an archive read-only; use the result as a context manager.

    Raises DataError naming the file when it is missing, not HDF5, truncated,
    or not a contactlab archive.
    """
    h5 = open_h5(path)
    problem = archive_version_problem(h5)
    if problem:
        h5.close()
        raise DataError(problem, file=str(path))
    try:
        with unreadable_as_data_error(path, "/trials"):
            if not isinstance(h5.get("trials"), h5py.Group):
                raise DataError("missing group", file=str(path), field="/trials")
            return Archive(Path(path), h5)
    except DataError:
        h5.close()
        raise


@contextlib.contextmanager
def unreadable_as_data_error(path, field: str):
    """Turn HDF5 read failures (corrupt chunks, bad headers) into a one-line DataError."""
    try:
        yield
    except (OSError, KeyError, RuntimeError) as err:
        raise DataError(f"cannot be read: {h5_reason(err)}", file=str(path), field=field) \
            from None


class Archive:
    """A read-only archive (see :func:`open_archive`)."""

    def __init__(self, path: Path, h5: h5py.File):
        self.path = path
        self._h5 = h5
        self.attrs: dict = {k: spec.to_plain(v) for k, v in h5.attrs.items()}
        self.trial_ids: list[str] = sorted(h5["trials"].keys())

    def trial(self, trial_id: str) -> Trial:
        """The trial ``trial_id`` (DataError when there is none)."""
        field = f"/trials/{trial_id}"
        if trial_id not in self.trial_ids:
            raise DataError("no such trial", file=str(self.path), field=field)
        with unreadable_as_data_error(self.path, field):
            return Trial(self, self._h5["trials"][trial_id])

    def select(self, trial_ids=None) -> list[str]:
        """``trial_ids`` checked against the archive (every trial when None or empty);
        DataError naming the first one it does not hold."""
        ids = list(trial_ids) if trial_ids else list(self.trial_ids)
        for tid in ids:
            if tid not in self.trial_ids:
                raise DataError("no such trial", file=str(self.path), field=f"/trials/{tid}")
        return ids

    def __iter__(self) -> Iterator[Trial]:
        return (self.trial(tid) for tid in self.trial_ids)

    def __len__(self) -> int:
        return len(self.trial_ids)

    def __contains__(self, trial_id: object) -> bool:
        return trial_id in self.trial_ids

    def close(self) -> None:
        self._h5.close()

    def __enter__(self) -> Archive:
        return self

    def __exit__(self, *exc) -> bool:
        self.close()
        return False

    def __repr__(self) -> str:
        return f"<Archive {self.path} ({len(self.trial_ids)} trials)>"


class Results(dict):
    """A stage's results: dataset path (relative to the stage) -> array.

    ``attrs`` holds the stage group's attributes; ``parameters`` the decoded
    ``parameters`` JSON.
    """

    def __init__(self, data: dict, attrs: dict):
        super().__init__(data)
        self.attrs = attrs
        self.parameters = json.loads(attrs.get("parameters") or "{}")


class Trial:
    """One trial of an open :class:`Archive`; arrays load lazily and are cached."""

    def __init__(self, archive: Archive, group: h5py.Group):
        self._archive = archive
        self._group = group
        self.id: str = group.name.rsplit("/", 1)[-1]
        self.attrs: dict = {k: spec.to_plain(v) for k, v in group.attrs.items()}

    # -- metadata ---------------------------------------------------------------
    @property
    def h5_group(self) -> h5py.Group:
        """The trial's HDF5 group (read-only; valid while the archive is open)."""
        return self._group

    @property
    def rate_hz(self) -> float:
        if "rate_hz" not in self.attrs:
            raise self._error("missing attribute 'rate_hz'", self._group.name)
        return float(self.attrs["rate_hz"])

    @property
    def n_samples(self) -> int:
        return int(self._dataset(spec.MEASUREMENTS, "time", required=True).shape[0])

    @property
    def duration_s(self) -> float:
        """Span of the time base plus one sample period (n / rate_hz when uniform)."""
        t = self.time
        return 0.0 if len(t) == 0 else float(t[-1] - t[0]) + 1.0 / self.rate_hz

    # -- measurements -----------------------------------------------------------
    @functools.cached_property
    def time(self) -> np.ndarray:
        return self._read(spec.MEASUREMENTS, "time", required=True)

    @functools.cached_property
    def strain(self) -> np.ndarray | None:
        return self._read(spec.MEASUREMENTS, "strain")

    @functools.cached_property
    def wrench(self) -> np.ndarray | None:
        return self._read(spec.MEASUREMENTS, "wrench")

    @functools.cached_property
    def position(self) -> np.ndarray | None:
        return self._read(spec.MEASUREMENTS, "position")

    @functools.cached_property
    def velocity(self) -> np.ndarray | None:
        return self._read(spec.MEASUREMENTS, "velocity")

    @functools.cached_property
    def orientation(self) -> np.ndarray | None:
        """(n, 4) unit quaternions w x y z rotating tool-frame vectors into the base frame."""
        return self._read(spec.MEASUREMENTS, "orientation")

    @property
    def wrench_frame(self) -> str:
        """Axes of :attr:`wrench`: ``"sensor"`` (as measured) or ``"base"``."""
        return str(self.dataset_attrs("wrench").get("frame", "sensor"))

    @functools.cached_property
    def action(self) -> np.ndarray | None:
        return self._read(spec.MEASUREMENTS, "action")

    @functools.cached_property
    def command(self) -> np.ndarray | None:
        return self._read(spec.MEASUREMENTS, "command")

    @functools.cached_property
    def calibration(self) -> np.ndarray | None:
        """The 6 x c matrix with wrench = calibration @ strain, or None."""
        ds = self._dataset(spec.MEASUREMENTS, "strain")
        return None if ds is None or "calibration" not in ds.attrs else \
            np.asarray(ds.attrs["calibration"], dtype=np.float64)

    def channels(self) -> dict[str, int]:
        """Measurement dataset present (time aside) -> its width (shape[1], or 1)."""
        out = {}
        for name in spec.MEASUREMENT_FIELDS[1:]:
            ds = self._dataset(spec.MEASUREMENTS, name)
            if ds is not None:
                out[name] = int(ds.shape[1]) if ds.ndim > 1 else 1
        return out

    def dataset_attrs(self, name: str, group: str = spec.MEASUREMENTS) -> dict:
        """Attributes (units, columns, names, ...) of one dataset ({} when absent)."""
        ds = self._dataset(group, name)
        return {} if ds is None else {k: spec.to_plain(v) for k, v in ds.attrs.items()}

    # -- ground truth -----------------------------------------------------------
    @functools.cached_property
    def labels(self) -> np.ndarray | None:
        """Per-sample label codes (names in :attr:`label_names`, -1 unlabelled)."""
        return self._read(spec.GROUND_TRUTH, "labels")

    @functools.cached_property
    def label_names(self) -> list[str] | None:
        for name in ("labels", "segments"):
            ds = self._dataset(spec.GROUND_TRUTH, name)
            if ds is not None and "names" in ds.attrs:
                return [str(n) for n in spec.to_plain(ds.attrs["names"])]
        return None

    @functools.cached_property
    def segments(self) -> pd.DataFrame | None:
        """Columns start_s, end_s, label (the name; None when unlabelled), code."""
        table = self._read(spec.GROUND_TRUTH, "segments")
        if table is None:
            return None
        names = self.dataset_attrs("segments", spec.GROUND_TRUTH).get("names", [])
        codes = table["label"].astype(int)
        return pd.DataFrame({
            "start_s": table["start_s"].astype(float),
            "end_s": table["end_s"].astype(float),
            "label": [names[c] if 0 <= c < len(names) else None for c in codes],
            "code": codes,
        })

    def truth_names(self) -> list[str]:
        """Names of the ground-truth datasets this trial holds (labels, contact, ...)."""
        group = self._group.get(spec.GROUND_TRUTH)
        return sorted(group.keys()) if isinstance(group, h5py.Group) else []

    def truth(self, name: str) -> np.ndarray | None:
        """Ground-truth dataset ``name`` (``contact``, ``contact_normals``, ``moving``,
        ``impact``, ``impact_intervals``, ``texture``, ``labels``, ...), or None when absent.

        ``contact``, ``moving`` and ``impact`` come back as bool arrays; the
        names that go with ``contact`` and ``texture`` are in
        ``dataset_attrs(name, "ground_truth")`` (``surfaces``, ``names``).
        """
        data = self._read(spec.GROUND_TRUTH, name)
        if data is not None and name in ("contact", "moving", "impact"):
            data = data.astype(bool)
        return data

    # -- results ----------------------------------------------------------------
    def result_stages(self) -> list[str]:
        group = self._group.get(spec.RESULTS)
        return sorted(group.keys()) if isinstance(group, h5py.Group) else []

    def results(self, stage: str) -> Results:
        """The datasets of ``results/<stage>`` (nested paths joined with '/') and its attrs."""
        group = self._group.get(f"{spec.RESULTS}/{stage}")
        if not isinstance(group, h5py.Group):
            raise self._error("no such results stage", f"{self._group.name}/{spec.RESULTS}/{stage}")
        data: dict[str, np.ndarray] = {}

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                data[name] = (obj.asstr()[()] if h5py.check_string_dtype(obj.dtype)
                              else obj[()])

        with unreadable_as_data_error(self._archive.path, group.name):
            group.visititems(visit)
            return Results(data, {k: spec.to_plain(v) for k, v in group.attrs.items()})

    # -- helpers ----------------------------------------------------------------
    def _dataset(self, group: str, name: str, *, required: bool = False) -> h5py.Dataset | None:
        field = f"{self._group.name}/{group}/{name}"
        with unreadable_as_data_error(self._archive.path, field):
            obj = self._group.get(f"{group}/{name}")
        if obj is None and required:
            raise self._error("missing dataset", field)
        return obj if isinstance(obj, h5py.Dataset) else None

    def _read(self, group: str, name: str, *, required: bool = False) -> np.ndarray | None:
        ds = self._dataset(group, name, required=required)
        if ds is None:
            return None
        from contactlab.archive.validate import dataset_size_problem

        too_big = dataset_size_problem(ds, os.path.getsize(self._archive.path))
        if too_big:
            raise self._error(too_big, ds.name)
        with unreadable_as_data_error(self._archive.path, ds.name):
            return ds[()]

    def _error(self, message: str, field: str) -> DataError:
        return DataError(message, file=str(self._archive.path), field=field)

    def __repr__(self) -> str:
        return f"<Trial {self.id} of {self._archive.path.name}>"
