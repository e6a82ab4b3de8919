"""Writing archives: atomic by default, incremental for acquisition.

One module on purpose: :class:`ArchiveWriter` and its :class:`TrialWriter`
share one file, its space reserve and one abort path (a failed trial write
releases the reserve and returns the file to its last finished trial); split,
each would reach into the other's state.

::

    with create_archive("runs.h5", title="strokes") as archive:
        with archive.add_trial("t01", rate_hz=1000.0, source="simulator", seed=3) as trial:
            for block in blocks:                      # append as the data arrive
                trial.append(time=block.t, strain=block.strain, wrench=block.w)
            trial.set_ground_truth(labels=codes, names=["free", "contact"])

Everything goes to a temporary file beside the target (``.runs.h5.XXXX.tmp``)
that is renamed into place when the ``with`` block ends cleanly. An exception
removes the temporary file, so no half-written archive ever carries the
final name.

With ``incremental=True`` (acquisition, import) each finished trial is
committed (:meth:`ArchiveWriter.commit`): the first commit renames the file
into place, later trials are written in place behind a rollback journal
(:mod:`contactlab.journal`), so the archive under its final name always holds
every finished trial, at a write cost linear in trials. An exception (Ctrl-C
included) returns the file to its last commit, byte for byte, and says which
trials it kept; a second signal does the same from the signal handler and
quits at once; after a SIGKILL the next run on the archive plays the journal
back. Until the first trial is finished only the temporary file exists (an
archive replaced with ``force`` or appended to stays as it was).

A full disk must not strand the finished trials either: an incremental writer
keeps a small reserve file (:data:`RESERVE_BYTES`) beside the archive and
deletes it when a write fails, so that there is room to close the file and
play the journal back. The failure is then reported in one line naming the
archive and the trials it kept.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import sys
import zlib
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np

from contactlab import __version__, interrupt
from contactlab.archive import spec
from contactlab.errors import DataError, UsageError
from contactlab.fileio import atomic_path, temp_beside, write_error
from contactlab.journal import JournaledFile, journal_path_for, rollback

#: Rows per HDF5 chunk of the per-sample datasets.
CHUNK_ROWS = 1024
#: gzip (deflate) is readable by every HDF5 tool, unlike lzf.
COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True}
#: A numeric dataset is compressed only if :data:`COMPRESSION` stores
#: :data:`PROBE_CHUNKS` chunks spread over it (:func:`probe_rows`) in at most this
#: fraction of their bytes.
#: Inflating costs about 3 ns a byte, as long as reading the bytes from a disk at
#: 300 MB/s; data that deflate barely shrinks read 10-20x faster stored as they are:
#: noisy floats printed to six digits, as most CSV recordings are (0.8-0.85 of their
#: bytes), and a robot's pose (0.67 on the HIRO recordings: an hour of 200 Hz position
#: and orientation inflated in 0.15 s, read raw in 0.02 s), for at most 1.7x the room.
#: Quantised strains (about 0.16), time bases and labels (0.01-0.2) stay compressed.
COMPRESS_BELOW = 0.6
#: How many chunks :func:`probe_rows` takes (about 1 ms of deflate each).
PROBE_CHUNKS = 16
#: Uncompressed chunks carry HDF5's Fletcher-32 checksum, so a damaged chunk is still
#: an error on reading, as a damaged deflate stream is (0.2 ms per 640 kB to check).
CHECKSUM = {"fletcher32": True}

#: Ground-truth datasets with one row per sample.
PER_SAMPLE_TRUTH = ("labels", "contact", "contact_normals", "moving", "impact", "texture")

SEGMENT_DTYPE = np.dtype([("start_s", "<f8"), ("end_s", "<f8"), ("label", "<i2")])


def label_segments(codes, time, rate_hz: float) -> np.ndarray:
    """Ground-truth segments from per-sample label codes: one row per run of equal
    labelled codes, ``(start_s, end_s, label)``; unlabelled (-1) runs are left out.

    A run from sample i to j (inclusive) spans ``[time[i], time[j + 1])``, the
    last run ending one sample period after the last sample.
    """
    codes = np.asarray(codes)
    time = np.asarray(time, dtype=np.float64)
    if len(codes) == 0:
        return np.zeros(0, dtype=SEGMENT_DTYPE)
    starts = np.flatnonzero(np.r_[True, codes[1:] != codes[:-1]])
    ends = np.r_[starts[1:], len(codes)]
    edges = np.r_[time, time[-1] + 1.0 / rate_hz]
    keep = codes[starts] >= 0
    table = np.zeros(int(keep.sum()), dtype=SEGMENT_DTYPE)
    table["start_s"] = edges[starts[keep]]
    table["end_s"] = edges[ends[keep]]
    table["label"] = codes[starts[keep]]
    return table



#: Room kept free for closing an incremental archive after a write failure: the
#: metadata HDF5 writes on close plus one chunk cache (1 MiB) to spare.
RESERVE_BYTES = 4 << 20
#: Free space an append needs beyond its own bytes (dirty chunk caches, metadata);
#: with less, the writer stops with ENOSPC before HDF5 runs into the full disk.
SPACE_MARGIN = 2 << 20


def utc_now() -> str:
    """The current UTC time as ISO-8601 with a Z suffix."""
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def check_name(name: str, what: str) -> str:
    """An HDF5 member name: non-empty, no '/', not '.'."""
    if not isinstance(name, str) or not name or "/" in name or name == ".":
        raise UsageError(f"{what} {name!r} is not a valid name (non-empty, no '/')")
    return name


def create_dataset(group: h5py.Group, name: str, data: np.ndarray, *,
                   chunk_rows: int | None = CHUNK_ROWS) -> h5py.Dataset:
    """A chunked dataset appendable along axis 0, holding ``data``, compressed with
    :data:`COMPRESSION` where that pays (:func:`compresses`, judged on the first chunk),
    else stored as it is with :data:`CHECKSUM`.

    ``chunk_rows=None`` lets h5py choose the chunk shape; 0-d data is stored
    contiguous (it cannot be chunked).
    """
    if data.ndim == 0:
        return group.create_dataset(name, data=data)
    chunks = True if chunk_rows is None else (chunk_rows,) + data.shape[1:]
    filters = COMPRESSION if compresses(probe_rows(data, chunk_rows or CHUNK_ROWS)) else CHECKSUM
    return group.create_dataset(name, data=data, maxshape=(None,) + data.shape[1:],
                                chunks=chunks, **filters)


def probe_rows(data: np.ndarray, rows: int, chunks: int = PROBE_CHUNKS) -> np.ndarray:
    """The rows :func:`create_dataset` judges compression on: ``chunks`` blocks of
    ``rows`` spread evenly from the first to the last (a recording's first chunk is often
    the robot at rest, which deflates far better than the rest of it, and single
    chunks of a pose vary from 0.54 to 0.77 of their bytes along an hour of HIRO
    recordings, so three judged it 0.59 against 0.68 for the whole)."""
    n = len(data)
    if n <= chunks * rows:
        return data
    starts = np.linspace(0, n - rows, chunks).astype(np.int64)
    return np.concatenate([data[a:a + rows] for a in starts])


def compresses(block: np.ndarray) -> bool:
    """Whether :data:`COMPRESSION` (shuffle, then deflate) stores ``block`` in at most
    :data:`COMPRESS_BELOW` of its bytes; non-numeric data are always compressed."""
    arr = np.ascontiguousarray(block)
    if arr.dtype.kind not in "biuf" or arr.nbytes < 256:
        return True
    shuffled = arr.reshape(-1).view(np.uint8).reshape(-1, arr.dtype.itemsize).T.tobytes()
    packed = zlib.compress(shuffled, COMPRESSION["compression_opts"])
    return len(packed) <= COMPRESS_BELOW * arr.nbytes


def create_archive(path: str | os.PathLike, *, force: bool = False, title: str = "",
                   incremental: bool = False) -> ArchiveWriter:
    """Start writing the archive ``path``; use the result as a context manager.

    ``force`` allows replacing an existing file; ``incremental`` keeps closed
    trials when the writing is interrupted (see the module docstring).
    """
    return ArchiveWriter(path, force=force, title=title, incremental=incremental)


class ArchiveWriter:
    """An archive being written (see :func:`create_archive`).

    ``path`` is the final name, ``tmp_path`` the file being written. Close it
    with :meth:`close` (commit) or use it as a context manager.
    """

    def __init__(self, path: str | os.PathLike, *, force: bool = False, title: str = "",
                 incremental: bool = False):
        self.path = Path(path)
        self.incremental = incremental
        self._stack = contextlib.ExitStack()
        # a signal must not surface inside h5py: it is raised at the next check_space
        self._stack.enter_context(interrupt.deferred())
        self._io: JournaledFile | None = None
        self._placed = False         # incremental: the file is in place under self.path
        self._committed: list[str] = []
        self._trials: dict[str, TrialWriter] = {}
        self._copied: list[str] = []
        self._closed = False
        if incremental:
            _, self.tmp_path = self._stack.enter_context(temp_beside(self.path, force=force))
            self._stack.enter_context(interrupt.on_quit(self._quit))
        else:
            self.tmp_path = self._stack.enter_context(atomic_path(self.path, force=force))
        self._reserve: Path | None = None
        self._failures = _FinaliserFailures()
        self._failures.install()
        try:
            if incremental:
                self._reserve = self.tmp_path.with_name(self.tmp_path.name[:-4] + "_reserve.tmp")
                _reserve_space(self._reserve, RESERVE_BYTES, self.path)
                self._io = JournaledFile(self.tmp_path)
                self._file = h5py.File(self._io, "w")
            else:
                self._file = h5py.File(self.tmp_path, "w")
            self._file.attrs["format"] = spec.FORMAT
            self._file.attrs["format_version"] = spec.FORMAT_VERSION
            self._file.attrs["software_version"] = __version__
            self._file.attrs["created"] = utc_now()
            if title:
                self._file.attrs["title"] = title
            self._trials_group = self._file.create_group("trials")
        except BaseException as err:
            self._release_reserve()
            self._failures.uninstall()
            if self._io is not None:
                self._io.close()
            self._stack.__exit__(type(err), err, err.__traceback__)
            raise

    # -- trials -----------------------------------------------------------------
    def add_trial(self, trial_id: str, *, rate_hz: float, controller: str = "",
                  environment: str = "", seed: int = -1, source: str = "", description: str = "",
                  strain_channels: int | None = None, calibration=None,
                  command_columns: list[str] | None = None, action_names: list[str] | None = None,
                  strain_units: str | None = None, command_units: str | None = None,
                  position_columns: list[str] | None = None,
                  wrench_frame: str | None = None) -> TrialWriter:
        """Start trial ``trial_id``; returns its :class:`TrialWriter`.

        ``strain_channels`` fixes the strain width (else the first append or
        ``calibration``, a 6 x c matrix with wrench = calibration @ strain, does).
        ``wrench_frame`` (``"sensor"`` or ``"base"``) is written as the wrench's ``frame``
        attribute (absent: sensor). ``position_columns`` renames the position columns (default x y z; a
        planar trace uses x y theta, theta in rad, for the polygon models).
        ``command_columns`` names the command columns; ``command_units`` is
        required when commands are appended. ``strain_units`` defaults to the
        schema's default (V).
        """
        self._check_open()
        self.check_space(0)  # the safe point of a signal received between trials
        check_name(trial_id, "trial id")
        if trial_id in self._trials or trial_id in self._copied:
            raise UsageError(f"trial {trial_id!r} added twice")
        if not (isinstance(rate_hz, (int, float, np.number)) and math.isfinite(rate_hz)
                and rate_hz > 0):
            raise UsageError(f"trial {trial_id!r}: rate_hz must be a positive number, "
                             f"not {rate_hz!r}")
        group = self._trials_group.create_group(trial_id)
        group.attrs["rate_hz"] = float(rate_hz)
        group.attrs["controller"] = str(controller)
        group.attrs["environment"] = str(environment)
        group.attrs["seed"] = int(seed)
        group.attrs["source"] = str(source)
        if description:
            group.attrs["description"] = str(description)
        group.attrs["complete"] = False
        try:
            trial = TrialWriter(self, group, strain_channels=strain_channels,
                                calibration=calibration, command_columns=command_columns,
                                action_names=action_names, strain_units=strain_units,
                                command_units=command_units,
                                position_columns=position_columns,
                                wrench_frame=wrench_frame)
        except BaseException:
            del self._trials_group[trial_id]
            raise
        self._trials[trial_id] = trial
        return trial

    def copy_trials_from(self, path: str | os.PathLike) -> list[str]:
        """Copy every trial of the archive at ``path`` into this one (for appending).

        HDF5 object copies, so chunks are copied as they are; the file's title
        is kept unless this archive has one. Returns the copied trial ids.
        """
        self._check_open()
        self.check_space(os.path.getsize(path))
        copied = []
        with h5py.File(path, "r") as src:
            if "title" in src.attrs and "title" not in self._file.attrs:
                self._file.attrs["title"] = src.attrs["title"]
            for tid in src.get("trials", {}):
                if tid in self._trials or tid in self._trials_group:
                    raise UsageError(f"trial {tid!r} added twice")
                src.copy(src["trials"][tid], self._trials_group, name=tid)
                copied.append(tid)
        self._copied.extend(copied)
        return copied

    @property
    def trial_ids(self) -> list[str]:
        """Ids of the trials added so far (copied ones first), in order."""
        return self._copied + list(self._trials)

    def flush(self) -> None:
        """Push everything written so far to the file (not a commit: see :meth:`commit`)."""
        self._check_open()
        self.check_space(0)
        self._file.flush()
        self.check_space(0)

    def check_space(self, nbytes: int) -> None:
        """Raise ENOSPC (OSError) before writing ``nbytes`` more would fill the disk,
        or when a finaliser already met a failed write; raise the interrupt of a
        SIGINT/SIGTERM received since the last call (the writer's safe point)."""
        interrupt.checkpoint()
        if self._failures.first is not None:
            raise self._failures.first
        try:
            st = os.statvfs(self.tmp_path.parent)
        except OSError:
            return
        if st.f_bavail * st.f_frsize < nbytes + SPACE_MARGIN:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.tmp_path))

    # -- ending -----------------------------------------------------------------
    def commit(self, trial_id: str) -> None:
        """Incremental: keep everything written so far, whatever happens next (the
        finished trial ``trial_id`` is then one the archive keeps).

        The first commit moves the file into place; later ones write in place
        behind the rollback journal (:mod:`contactlab.journal`), so a kill, even
        SIGKILL, loses at most what came after the last commit.
        """
        self.check_space(0)  # a signal before the commit drops the trial
        self._file.flush()
        self.check_space(0)
        self._io.sync()
        with interrupt.held():  # the move, the journal and the record of it go together
            if not self._placed:
                os.replace(self.tmp_path, self.path)
                _sync_directory(self.path.parent)
                self._placed = True
                self._io.start_journal(journal_path_for(self.tmp_path))
            else:
                self._io.commit()
            self._committed.append(trial_id)

    def close(self) -> Path:
        """Close every open trial and rename the file into place; return its path."""
        self._check_open()
        try:
            for trial in self._trials.values():
                if not trial.complete:
                    trial.close()
        except BaseException as err:
            self.abort(err)
            raise
        self._closed = True
        try:
            self._file.close()
            self._failures.uninstall()
            if self._failures.first is not None:
                raise self._failures.first
            if self._io is not None:
                with interrupt.held():
                    if not self._placed:
                        self._io.sync()
                        os.replace(self.tmp_path, self.path)
                        self._placed = True
                    self._io.finish()
        except BaseException as err:
            self._release_reserve()
            self._roll_back()
            self._stack.__exit__(type(err), err, err.__traceback__)
            raise
        self._release_reserve()
        self._stack.close()  # normal mode: renames tmp_path over path
        interrupt.checkpoint()  # a signal during the last steps: the archive is in place
        return self.path

    def abort(self, error: BaseException | None = None) -> Path | None:
        """End after a failure.

        Normal mode: remove the temporary file and return None. Incremental
        mode: return the archive to its last commit, in place when a trial was
        committed (return its path), else remove it.
        """
        if self._closed:
            return None
        self._closed = True
        self._release_reserve()  # room for HDF5 to close the file after a full disk
        error = error or RuntimeError("archive writing aborted")
        with contextlib.suppress(Exception):  # the rollback undoes what closing writes
            self._file.close()
        self._failures.uninstall()
        self._roll_back()
        if self._placed:
            self._stack.close()
            return self.path
        self._stack.__exit__(type(error), error, error.__traceback__)
        return None

    def kept_line(self) -> str:
        """What an interrupted incremental writer keeps, in one line."""
        new = [t for t in self._trials if t not in self._committed]
        dropped = f"; the unfinished trial {new[-1]} is dropped" if new else ""
        if not self._placed:
            what = ("left as it was" if self.path.exists() else "not written")
            return f"{self.path}: {what}: no trial was finished{dropped}"
        n = len(self._committed)
        return (f"{self.path}: {n} finished trial{'' if n == 1 else 's'} kept "
                f"({', '.join(self._committed)}){dropped}")

    def _roll_back(self) -> None:
        """Incremental: back to the last commit (in place), or nothing (temporary)."""
        if self._io is None:
            return
        journal = self._io.journal
        self._io.close()
        if self._placed and journal is not None:
            rollback(self.path, journal)

    def _quit(self) -> str:
        """The second signal's action (inside the handler: plain os calls only)."""
        if self._io is not None and self._io.journal is not None and self._placed:
            rollback(self.path, self._io.journal)
        elif not self._placed:
            with contextlib.suppress(FileNotFoundError):
                self.tmp_path.unlink()
        if self._reserve is not None:
            with contextlib.suppress(FileNotFoundError):
                self._reserve.unlink()
        return self.kept_line()

    def _release_reserve(self) -> None:
        if self._reserve is not None:
            with contextlib.suppress(OSError):
                self._reserve.unlink()
            self._reserve = None

    def __enter__(self) -> ArchiveWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc is None:
            self.close()
            return False
        failure = write_error(exc, self.path) if isinstance(exc, Exception) else None
        kept = self.abort(exc)
        if failure is not None:
            n = len(self._committed)
            note = (f"; the {n} finished trial{'' if n == 1 else 's'} "
                    f"{'is' if n == 1 else 'are'} kept in it ({', '.join(self._committed)})"
                    if kept else "; nothing was written")
            raise DataError(failure.message + note, file=str(self.path)) from None
        if self.incremental and isinstance(exc, KeyboardInterrupt):
            print(f"contactlab: {self.kept_line()}", file=sys.stderr, flush=True)
        return False

    def _check_open(self) -> None:
        if self._closed:
            raise UsageError(f"archive {self.path} is already closed")


def _sync_directory(folder: Path) -> None:
    """Push a rename in ``folder`` to the disk (where the file system allows it)."""
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _reserve_space(path: Path, size: int, target: Path) -> None:
    """Create ``path`` holding ``size`` allocated bytes (a DataError naming ``target``,
    the archive it is for, when there is no room)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as err:
        raise (write_error(err, target) or err) from None
    try:
        try:
            os.posix_fallocate(fd, 0, size)
        except OSError as err:
            if err.errno not in (errno.EOPNOTSUPP, errno.EINVAL):
                raise
            os.write(fd, bytes(size))  # a file system without fallocate
    except OSError as err:
        os.close(fd)
        with contextlib.suppress(OSError):
            path.unlink()
        raise (write_error(err, target) or err) from None
    os.close(fd)


class _FinaliserFailures:
    """h5py meets a failed write (a full disk) inside finalisers too, where it prints
    "Exception ignored in ... ObjectID.__dealloc__" and nobody sees it. While a
    writer is open such failures are recorded here (and kept off stderr) so the
    writer raises the first of them at its next step instead of going on."""

    def __init__(self):
        self.first: BaseException | None = None
        self._previous = None

    def install(self) -> None:
        self._previous = sys.unraisablehook
        sys.unraisablehook = self._hook

    def _hook(self, unraisable) -> None:
        if self.first is None and write_error(unraisable.exc_value, "") is not None:
            self.first = unraisable.exc_value
        elif self.first is None:
            self._previous(unraisable)
        # after a failed write, what follows from it is the same failure: not printed

    def uninstall(self) -> None:
        import gc

        gc.collect()  # finalise what the failure left behind while the hook still listens
        if sys.unraisablehook == self._hook:
            sys.unraisablehook = self._previous


class TrialWriter:
    """One trial being written: :meth:`append` rows, then :meth:`close`.

    Use it as a context manager to close it on a clean exit.
    """

    def __init__(self, archive: ArchiveWriter, group: h5py.Group, *, strain_channels=None,
                 calibration=None, command_columns=None, action_names=None, strain_units=None,
                 command_units=None, position_columns=None, wrench_frame=None):
        self._archive = archive
        self._group = group
        self.id = group.name.rsplit("/", 1)[-1]
        self._widths: dict[str, int] = {}
        if calibration is not None:
            calibration = np.asarray(calibration, dtype=np.float64)
            if calibration.ndim != 2 or calibration.shape[0] != 6:
                raise self._error(f"calibration has shape {calibration.shape}, expected (6, c)",
                                  "strain")
            if strain_channels is not None and calibration.shape[1] != strain_channels:
                raise self._error(f"calibration has {calibration.shape[1]} columns but "
                                  f"strain_channels={strain_channels}", "strain")
            strain_channels = calibration.shape[1]
        if strain_channels is not None:
            self._widths["strain"] = int(strain_channels)
        if command_columns is not None:
            self._widths["command"] = len(command_columns)
        self._calibration = calibration
        self._command_columns = None if command_columns is None else list(command_columns)
        if position_columns is not None and len(position_columns) != 3:
            raise self._error(f"position_columns has {len(position_columns)} names, expected 3",
                              "position")
        self._position_columns = None if position_columns is None else list(position_columns)
        if wrench_frame not in (None, "sensor", "base"):
            raise self._error(f"wrench_frame {wrench_frame!r} is not 'sensor' or 'base'",
                              "wrench")
        self._wrench_frame = wrench_frame
        self._action_names = None if action_names is None else list(action_names)
        self._strain_units = strain_units or spec.default_attr(spec.MEASUREMENTS, "strain", "units")
        self._command_units = command_units
        self._fields: tuple[str, ...] | None = None
        self._last_time: float | None = None
        self.n_samples = 0
        self.complete = False
        self._meas = group.create_group(spec.MEASUREMENTS)

    def append(self, *, time, strain=None, wrench=None, position=None, velocity=None,
               orientation=None, action=None, command=None) -> None:
        """Append rows to each given dataset; every call must give the same datasets.

        ``time`` is (r,) seconds, strictly after the previous rows; the others
        have r rows: strain (r, c), wrench (r, 6), position and velocity
        (r, 3), orientation (r, 4) unit quaternions w x y z (tool to base frame),
        action (r,) integer codes, command (r, k).
        """
        self._check_writable()
        given = {"time": time, "strain": strain, "wrench": wrench, "position": position,
                 "velocity": velocity, "orientation": orientation, "action": action,
                 "command": command}
        given = {k: v for k, v in given.items() if v is not None}
        fields = tuple(k for k in spec.MEASUREMENT_FIELDS if k in given)
        if self._fields is None:
            if not {"strain", "wrench", "position"} & set(given):
                raise self._error("the first append needs strain, wrench or position", "strain")
        elif fields != self._fields:
            missing = sorted(set(self._fields) - set(fields))
            extra = sorted(set(fields) - set(self._fields))
            what = (f"missing {', '.join(missing)}" if missing else
                    f"{', '.join(extra)} not given in the first append")
            raise self._error(f"every append must give the same datasets ({what})",
                              (missing or extra)[0])
        arrays = {k: self._coerce(k, v) for k, v in given.items()}
        self._archive.check_space(sum(a.nbytes for a in arrays.values()))
        rows = len(arrays["time"])
        for name, arr in arrays.items():
            if len(arr) != rows:
                raise self._error(f"{len(arr)} rows, but time has {rows}", name)
        if "orientation" in arrays and len(arrays["orientation"]):
            o = arrays["orientation"]
            norm = np.sqrt(np.einsum("ij,ij->i", o, o))
            if np.any(np.abs(norm - 1.0) > spec.UNIT_NORM_TOLERANCE):
                raise self._error("rows must be unit quaternions (normalise them first)",
                                  "orientation")
        t = arrays["time"]
        if rows and (np.any(np.diff(t) <= 0) or
                     (self._last_time is not None and t[0] <= self._last_time)):
            raise self._error("time must be strictly increasing across appends", "time")
        for name, arr in arrays.items():
            if self._fields is None:
                self._create(name, arr)
            else:
                ds = self._meas[name]
                ds.resize(self.n_samples + rows, axis=0)
                ds[self.n_samples:] = arr
        self._fields = fields
        self.n_samples += rows
        if rows:
            self._last_time = float(t[-1])

    def set_ground_truth(self, *, labels, names, segments=None) -> None:
        """Store per-sample label codes (``names[code]``, -1 unlabelled) and segments.

        ``segments`` is a table of (start_s, end_s, label) rows -- a DataFrame,
        a structured array or a list of tuples -- whose label is a name or code.
        """
        self._check_writable()
        if "labels" in self._group.get(spec.GROUND_TRUTH, {}) or \
                "segments" in self._group.get(spec.GROUND_TRUTH, {}):
            raise self._error("ground truth already set", "labels", spec.GROUND_TRUTH)
        names = [str(n) for n in names]
        codes = np.asarray(labels)
        if codes.ndim != 1 or (codes.size and (not np.issubdtype(codes.dtype, np.integer) or
                                               codes.min() < -1 or codes.max() >= len(names))):
            raise self._error(f"labels must be a 1-D array of integer codes in [-1, {len(names)})",
                              "labels", spec.GROUND_TRUTH)
        table = None if segments is None else self._segment_table(segments, names)
        gt = self._group.require_group(spec.GROUND_TRUTH)
        for name, data in (("labels", codes.astype(np.int16)), ("segments", table)):
            if data is not None:
                create_dataset(gt, name, data).attrs["names"] = spec.string_array(names)

    def set_attrs(self, attrs: dict) -> None:
        """Extra trial attributes (e.g. ``dropped_packets``, the spec a trial came from).

        The schema's own trial attributes are set by :meth:`ArchiveWriter.add_trial`.
        """
        self._check_writable()
        reserved = {"rate_hz", "controller", "environment", "seed", "source", "description",
                    "complete"}
        for key, value in attrs.items():
            if key in reserved:
                raise UsageError(f"trial {self.id!r}: attribute {key!r} is set by add_trial")
            self._group.attrs[check_name(str(key), "attribute")] = value

    def set_extra(self, name: str, data, *, attrs: dict | None = None) -> None:
        """An extra per-sample measurement the schema does not name (e.g. a Net F/T's
        ``rdt_sequence``): ``measurements/NAME`` with one row per sample, written
        after the appends; the validator leaves its values alone."""
        self._check_writable()
        name = check_name(str(name), "dataset")
        if name in spec.MEASUREMENT_FIELDS or name in self._meas:
            raise self._error("is a schema field or already written", name)
        arr = np.asarray(data)
        if arr.ndim == 0 or len(arr) != self.n_samples:
            raise self._error(f"{0 if arr.ndim == 0 else len(arr)} rows, but time has "
                              f"{self.n_samples} samples", name)
        ds = create_dataset(self._meas, name, arr)
        for key, value in (attrs or {}).items():
            ds.attrs[key] = value

    def set_truth(self, *, contact=None, surfaces=None, contact_normals=None, moving=None,
                  impact=None, impact_intervals=None, texture=None, texture_names=None) -> None:
        """Store per-sample simulator truth under ``ground_truth/`` (each optional, once).

        ``contact`` (n, S) bool with the ``surfaces`` names; ``contact_normals``
        (n, S, 3); ``moving`` and ``impact`` (n,) bool; ``impact_intervals``
        (k, 2) seconds; ``texture`` (n,) codes into ``texture_names`` (-1: none).
        Lengths are checked against ``time`` when the trial is closed.
        """
        self._check_writable()
        gt = self._group.require_group(spec.GROUND_TRUTH)
        given = {"contact": contact, "contact_normals": contact_normals, "moving": moving,
                 "impact": impact, "impact_intervals": impact_intervals, "texture": texture}
        for name, value in given.items():
            if value is None:
                continue
            if name in gt:
                raise self._error("already set", name, spec.GROUND_TRUTH)
            arr = np.asarray(value)
            rule = spec.dataset_spec(spec.GROUND_TRUTH, name)["shape"]
            fixed_ok = all(not isinstance(d, int) or d == s for d, s in zip(rule, arr.shape))
            if arr.ndim != len(rule) or not fixed_ok:
                raise self._error(f"shape {arr.shape}, expected {spec.shape_text(rule)}", name,
                                  spec.GROUND_TRUTH)
            if name in ("contact", "moving", "impact"):
                arr = arr.astype(np.int8)
            elif name == "texture":
                if arr.size and (not np.issubdtype(arr.dtype, np.integer) or arr.min() < -1 or
                                 texture_names is None or arr.max() >= len(texture_names)):
                    raise self._error("texture must hold integer codes in [-1, len(texture_names))",
                                      name, spec.GROUND_TRUTH)
                arr = arr.astype(np.int16)
            else:
                arr = arr.astype(np.float64)
            if name == "contact" and (surfaces is None or len(surfaces) != arr.shape[1]):
                raise self._error("contact needs one surface name per column", name,
                                  spec.GROUND_TRUTH)
            if 0 in arr.shape[1:]:  # no surfaces (free space): HDF5 cannot chunk it
                ds = gt.create_dataset(name, data=arr)
            else:
                ds = create_dataset(gt, name, arr)
            if name == "contact":
                ds.attrs["surfaces"] = spec.string_array(surfaces)
            elif name == "texture":
                ds.attrs["names"] = spec.string_array(texture_names)
            elif name == "impact_intervals":
                ds.attrs["units"] = "s"

    def close(self) -> None:
        """Check the trial is whole, mark it complete (and flush when incremental)."""
        self._check_writable()
        if self._fields is None:
            raise self._error("no samples appended", "time")
        if self._calibration is not None and "strain" not in self._fields:
            raise self._error("calibration given but no strain appended", "strain")
        if "command" in self._fields and not self._command_units:
            raise self._error("command_units is required when commands are appended", "command")
        gt = self._group.get(spec.GROUND_TRUTH)
        for name in PER_SAMPLE_TRUTH:
            if gt is not None and name in gt and len(gt[name]) != self.n_samples:
                noun = 'labels' if name == 'labels' else 'rows'
                raise self._error(f"{len(gt[name])} {noun}, but time has {self.n_samples} "
                                  "samples", name, spec.GROUND_TRUTH)
        if "command" in self._meas:
            self._meas["command"].attrs["units"] = self._command_units
        self._group.attrs["complete"] = True
        if self._archive.incremental:
            self._archive.commit(self.id)
        self.complete = True

    def __enter__(self) -> TrialWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc is None and not self.complete:
            self.close()
        return False

    # -- helpers ----------------------------------------------------------------
    def _coerce(self, name: str, value) -> np.ndarray:
        dtype = np.int16 if name == "action" else np.float64
        arr = np.asarray(value)
        if name == "action":
            if arr.size and (not np.issubdtype(arr.dtype, np.integer) or
                             arr.min() < np.iinfo(np.int16).min or
                             arr.max() > np.iinfo(np.int16).max):
                raise self._error("action codes must be integers that fit in int16", name)
        else:
            try:
                arr = arr.astype(np.float64)
            except (TypeError, ValueError):
                raise self._error(f"cannot be converted to float64 ({arr.dtype})", name) from None
        rule = spec.dataset_spec(spec.MEASUREMENTS, name)["shape"]
        expected = [None] + [self._widths.get(name) if isinstance(d, str) else d
                             for d in rule[1:]]
        if arr.ndim != len(rule) or any(e is not None and e != s
                                        for e, s in zip(expected[1:], arr.shape[1:])):
            shown = spec.shape_text(["rows"] + [e if e is not None else d
                                                for e, d in zip(expected[1:], rule[1:])])
            raise self._error(f"shape {arr.shape}, expected {shown}", name)
        return arr.astype(dtype, copy=False)

    def _create(self, name: str, arr: np.ndarray) -> None:
        ds = create_dataset(self._meas, name, arr)
        units = (spec.fixed_units(spec.MEASUREMENTS, name) or
                 {"strain": self._strain_units}.get(name))
        if units:
            ds.attrs["units"] = units
        columns = spec.default_attr(spec.MEASUREMENTS, name, "columns")
        if name == "command":
            columns = self._command_columns or [f"c{i}" for i in range(arr.shape[1])]
        if name == "position" and self._position_columns is not None:
            columns = self._position_columns
        if name == "wrench" and self._wrench_frame is not None:
            ds.attrs["frame"] = self._wrench_frame
        if name == "orientation":
            ds.attrs["convention"] = spec.default_attr(spec.MEASUREMENTS, name, "convention")
        if columns is not None:
            ds.attrs["columns"] = spec.string_array(columns)
        if name == "strain" and self._calibration is not None:
            ds.attrs["calibration"] = self._calibration
        if name == "action" and self._action_names is not None:
            ds.attrs["names"] = spec.string_array(self._action_names)
        if arr.ndim == 2:
            self._widths[name] = arr.shape[1]

    def _segment_table(self, segments, names: list[str]) -> np.ndarray:
        if hasattr(segments, "to_records"):  # a DataFrame
            rows = list(segments[["start_s", "end_s", "label"]].itertuples(index=False))
        elif isinstance(segments, np.ndarray) and segments.dtype.names:
            rows = [tuple(r) for r in segments[["start_s", "end_s", "label"]]]
        else:
            rows = [tuple(r) for r in segments]
        table = np.zeros(len(rows), dtype=SEGMENT_DTYPE)
        for i, (start, end, label) in enumerate(rows):
            if isinstance(label, str):
                if label not in names:
                    raise self._error(f"segment label {label!r} is not one of the names",
                                      "segments", spec.GROUND_TRUTH)
                label = names.index(label)
            if not -1 <= int(label) < len(names):
                raise self._error(f"segment label code {label} is not in [-1, {len(names)})",
                                  "segments", spec.GROUND_TRUTH)
            table[i] = (float(start), float(end), int(label))
        return table

    def _error(self, message: str, dataset: str, group: str = spec.MEASUREMENTS) -> DataError:
        return DataError(message, file=str(self._archive.path),
                         field=f"{self._group.name}/{group}/{dataset}")

    def _check_writable(self) -> None:
        self._archive._check_open()
        if self.complete:
            raise UsageError(f"trial {self.id!r} is already closed")
