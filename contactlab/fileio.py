"""Atomic output files: write to a temporary sibling, then rename.

A crash or interrupt never leaves a half-written file under the final name,
and an existing file is replaced only when ``force`` is true.
"""

from __future__ import annotations

import hashlib

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from contactlab.errors import DataError


def check_writable(path: str | os.PathLike, *, force: bool) -> Path:
    """Refuse to overwrite ``path`` unless ``force``; return it as a Path."""
    path = Path(path)
    if path.exists() and not force:
        raise DataError("exists; pass --force to overwrite", file=str(path))
    if not path.parent.exists():
        raise DataError("directory does not exist", file=str(path.parent))
    return path


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, force: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` on success.

    On an exception the temporary file is removed and ``path`` is untouched.
    """
    final = check_writable(path, force=force)
    fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp_path, 0o666 & ~umask)  # mkstemp makes 0600; outputs are ordinary files
    try:
        yield tmp_path
        os.replace(tmp_path, final)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


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
