"""Output files: refused when they would replace an input, written atomically.

Every output goes to a temporary sibling ``.NAME.PID-XXXXXXXX.tmp`` that is
renamed over ``NAME`` only when it is complete, so a crash or interrupt never
leaves a half-written file under the final name, and an existing file is
replaced only when ``force`` is true. A temporary file whose writer died
without cleaning up (SIGKILL, power loss) is found by the next write of the
same file, or the next command that reads it, and removed with a note.

Write failures (read-only target, full disk, no permission) become one-line
:class:`~contactlab.errors.DataError` messages naming the target.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import shutil
import stat
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from contactlab import interrupt
from contactlab.errors import DataError, UsageError

#: errno values that mean "this target cannot be written" (not a bug of ours).
WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                errno.EFBIG}
#: A temporary file without a writer's pid in its name is stale after this long.
STALE_AFTER_S = 3600.0

_WRITE_ERRNO_TEXT = re.compile(r"errno = (\d+)|\[Errno (\d+)\]")


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether ``a`` and ``b`` name the same file (links and ``..`` resolved)."""
    a, b = Path(a), Path(b)
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def check_not_input(out: str | os.PathLike, inputs: Iterable, *, option: str = "--out") -> None:
    """Refuse an output that is one of the command's inputs (``--force`` or not)."""
    for src in inputs:
        if src is not None and same_file(out, src):
            raise UsageError(f"{option} {out} is also an input of this command "
                             f"({src}); write the output to another file")


def read_only_reason(path: str | os.PathLike) -> str | None:
    """Why ``path`` (a file or directory) must not be written, by its mode bits.

    The mode bits are consulted rather than ``os.access`` because the super-user
    may write anything: a file someone made read-only is still refused then.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if not mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH):
        what = "directory" if stat.S_ISDIR(mode) else "file"
        return f"{what} is read-only (mode {stat.S_IMODE(mode):04o}); refusing to write it"
    return None


def check_writable(path: str | os.PathLike, *, force: bool,
                   inputs: Iterable = ()) -> Path:
    """Refuse to overwrite ``path`` unless ``force``, to write into a read-only
    file or directory, or to replace one of ``inputs``; return it as a Path."""
    path = Path(path)
    check_not_input(path, inputs)
    refuse_while_recorded(path)
    if path.is_dir():
        raise DataError("is a directory, not a file", file=str(path))
    if path.exists() and not force:
        raise DataError("exists; pass --force to overwrite", file=str(path))
    parent = path.parent
    if not parent.exists():
        raise DataError("directory does not exist", file=str(parent))
    for target in ((path,) if path.exists() else ()) + (parent,):
        reason = read_only_reason(target)
        if reason:
            raise DataError(reason, file=str(target))
    return path


def write_error(err: BaseException, target: str | os.PathLike) -> DataError | None:
    """The one-line DataError for a failed write of ``target`` (None if ``err`` is
    not a write failure: full disk, quota, read-only file system, permission)."""
    code = getattr(err, "errno", None)
    if code is None and isinstance(err, (OSError, RuntimeError)):
        match = _WRITE_ERRNO_TEXT.search(str(err))
        if match:
            code = int(match.group(1) or match.group(2))
    if code not in WRITE_ERRNOS:
        return None
    reason = {errno.ENOSPC: "no space left on the device",
              errno.EDQUOT: "disk quota exceeded"}.get(code, os.strerror(code).lower())
    return DataError(f"cannot be written: {reason}", file=str(target))


# -- temporary files ------------------------------------------------------------------

def _temp_pattern(final: Path) -> re.Pattern:
    return re.compile(r"\." + re.escape(final.name) + r"\.(?:(\d+)-)?[A-Za-z0-9_]+\.tmp")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def stale_temp_files(path: str | os.PathLike) -> list[Path]:
    """Temporary siblings of ``path`` whose writer is gone (a killed run's leftovers).

    A name with a writer's pid is stale when that process no longer exists;
    an older name without one when it is more than :data:`STALE_AFTER_S` old.
    """
    final = Path(path)
    pattern = _temp_pattern(final)
    stale = []
    try:
        entries = list(os.scandir(final.parent if str(final.parent) else "."))
    except OSError:
        return []
    for entry in entries:
        match = pattern.fullmatch(entry.name)
        if not match:
            continue
        if match.group(1) is not None:
            pid = int(match.group(1))
            if pid == os.getpid() or _alive(pid):
                continue
        else:
            with contextlib.suppress(OSError):
                if time.time() - entry.stat().st_mtime < STALE_AFTER_S:
                    continue
        stale.append(Path(entry.path))
    return sorted(stale)


def _note(message: str) -> None:
    print(f"contactlab: note: {message}", file=sys.stderr, flush=True)


def remove_stale_temp_files(path: str | os.PathLike,
                            notify: Callable[[str], None] | None = _note) -> list[Path]:
    """Remove the stale temporary siblings of ``path``; say so through ``notify``.

    The journal of a recording that was killed (:mod:`contactlab.journal`) is
    first played back: ``path`` returns to its last finished trial.
    """
    from contactlab.journal import SUFFIX, rollback

    removed = []
    stale = stale_temp_files(path)
    for tmp in sorted(stale, key=lambda p: not p.name.endswith(SUFFIX)):  # journals first
        played = False
        try:
            if tmp.name.endswith(SUFFIX):
                played = rollback(path, tmp)
            elif tmp.is_dir() and not tmp.is_symlink():  # a report written aside
                shutil.rmtree(tmp)
            else:
                tmp.unlink()
        except OSError as err:
            if notify:
                notify(f"{tmp}: stale temporary file left by an interrupted run "
                       f"cannot be {'played back' if tmp.name.endswith(SUFFIX) else 'removed'}"
                       f" ({err.strerror})")
            continue
        removed.append(tmp)
        if notify and played:
            notify(f"{path}: returned to its last finished trial: the run writing it was "
                   f"killed (its journal {tmp.name} is played back and removed)")
        elif notify:
            notify(f"removed {tmp}, a temporary file left by an interrupted run")
    return removed


def recording_pid(path: str | os.PathLike) -> int | None:
    """The pid of a live process recording into ``path`` in place (None: none)."""
    from contactlab.journal import SUFFIX

    final = Path(path)
    pattern = _temp_pattern(final)
    try:
        names = os.listdir(final.parent if str(final.parent) else ".")
    except OSError:
        return None
    for name in names:
        match = pattern.fullmatch(name)
        if match and name.endswith(SUFFIX) and match.group(1) is not None:
            pid = int(match.group(1))
            if pid != os.getpid() and _alive(pid):
                return pid
    return None


def refuse_while_recorded(path: str | os.PathLike) -> None:
    """DataError when a live process is recording into ``path`` (its last trial is
    being written in place: neither read nor rewrite it until the run ends)."""
    pid = recording_pid(path)
    if pid is not None:
        raise DataError(f"is being recorded by a running process (pid {pid}); "
                        "wait for it to end", file=str(path))


@contextlib.contextmanager
def temp_beside(path: str | os.PathLike, *, force: bool = False) -> Iterator[tuple[Path, Path]]:
    """Yield ``(path, tmp)``: a new temporary file beside ``path`` that the caller
    moves into place itself (:func:`atomic_path` at its end; an incremental
    archive at its first finished trial).

    On an exception the temporary file is removed (unless it was moved) and a
    write failure (full disk, read-only, permission) is re-raised as a one-line
    DataError naming ``path``; a second signal removes it before quitting.
    """
    final = check_writable(path, force=force)
    remove_stale_temp_files(final)
    # A SIGINT/SIGTERM while the file is written is raised only at a checkpoint, never
    # inside h5py or between creating the temporary file and the block that removes it.
    with interrupt.deferred():
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.{os.getpid()}-", suffix=".tmp",
                                       dir=final.parent)
        except OSError as err:
            raise (write_error(err, final) or err) from None
        tmp_path = Path(tmp)
        try:
            with interrupt.on_quit(lambda: _unlink(tmp_path)):
                os.close(fd)
                os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are ordinary files
                yield final, tmp_path
        except BaseException as err:
            _unlink(tmp_path)
            failure = write_error(err, final) if isinstance(err, Exception) else None
            if failure is not None:
                raise failure from None
            raise


def _unlink(path: Path) -> None:
    with contextlib.suppress(FileNotFoundError):
        path.unlink()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, force: bool = False,
                interruptible: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` on success.

    On an exception the temporary file is removed and ``path`` is untouched;
    a write failure (full disk, read-only, permission) is re-raised as a
    one-line DataError naming ``path``. Under
    :func:`contactlab.interrupt.signals_as_interrupt` a signal received during
    the block is raised when it ends, before the rename (``interruptible=False``:
    the file is renamed all the same and the caller raises it).
    """
    with temp_beside(path, force=force) as (final, tmp_path):
        yield tmp_path
        if interruptible:
            interrupt.checkpoint()
        os.replace(tmp_path, final)


def make_directory(path: str | os.PathLike) -> Path:
    """Create the directory ``path`` (and its parents) to write outputs into; refuse
    a read-only one (by its mode bits, as :func:`check_writable`) or a file there.
    A failure is a one-line DataError naming ``path``."""
    path = Path(path)
    existing = next((p for p in (path, *path.parents) if p.exists()), Path("."))
    if not existing.is_dir():
        raise DataError("is not a directory", file=str(existing))
    reason = read_only_reason(existing)
    if reason:
        raise DataError(reason, file=str(existing))
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        failure = write_error(err, path)
        if failure is None:
            raise DataError(f"cannot be created ({err.strerror or err})", file=str(path)) from None
        raise failure from None
    return path


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a new temporary directory beside ``path``; when the block ends cleanly,
    move what it holds into ``path`` whole: the directory is renamed to ``path`` when
    there is none yet, else each file is renamed into it (files of other names in
    ``path`` are left as they are).

    On an exception (a full disk, an interrupt) the temporary directory is removed
    and ``path`` is untouched; a write failure becomes a DataError naming the file
    that was being written. A second signal removes it before quitting.
    """
    final = Path(path)
    if final.exists() and not final.is_dir():
        raise DataError("is not a directory", file=str(final))
    make_directory(final.parent)
    if final.exists():
        reason = read_only_reason(final)
        if reason:
            raise DataError(reason, file=str(final))
    remove_stale_temp_files(final)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.{os.getpid()}-", suffix=".tmp",
                                    dir=final.parent))
    except OSError as err:
        raise (write_error(err, final) or err) from None
    try:
        with interrupt.on_quit(lambda: _remove_tree(tmp)):
            os.chmod(tmp, 0o777 & ~_umask())
            yield tmp
            with interrupt.held():  # a second signal waits for the moves (renames only)
                if not final.exists():
                    os.rename(tmp, final)
                else:
                    for entry in sorted(os.listdir(tmp)):
                        os.replace(tmp / entry, final / entry)
                    os.rmdir(tmp)
    except BaseException as err:
        _remove_tree(tmp)
        if isinstance(err, DataError) and err.file and err.file.startswith(str(tmp)):
            # name the file as it was to be called, not its temporary place
            raise DataError(err.message, file=str(final) + err.file[len(str(tmp)):],
                            field=err.field) from None
        failure = write_error(err, final) if isinstance(err, Exception) else None
        if failure is not None:
            raise failure from None
        raise


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _remove_tree(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically (replacing it: reports are derived)."""
    with atomic_path(path, force=True) as tmp:
        tmp.write_text(text, encoding="utf-8")


def sha256_file(path) -> str:
    """Hex SHA-256 of the file at ``path`` (read in 1 MiB chunks): training provenance."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()
