"""Where numba keeps the package's compiled kernels: one folder per state of the source.

numba's on-disk cache (``cache=True``) is invalidated when the file of the cached
function changes, not when a function it calls from another file does: the observer's
compiled core (``observer/engine.py``) inlines the models' steps (``models/*.py``), so an
edited model step would run in its old form from the cache until ``engine.py`` itself
changed (numba's documentation, "Cache invalidation").  :func:`cache_dir` names a folder
by a digest of every source file's path, size and modification time, and
:func:`configure` points ``NUMBA_CACHE_DIR`` at it before numba is imported, so any edit
of the package compiles afresh and an unchanged package reuses its kernels.  Folders not
used for :data:`UNUSED_DAYS` are removed when a new one is made (several checkouts each
keep their own while in use).  A ``NUMBA_CACHE_DIR`` set by the user is left alone, and
where no cache folder can be made numba keeps its default.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
from pathlib import Path

__all__ = ["source_digest", "cache_dir", "configure"]

PACKAGE = Path(__file__).resolve().parent


#: a folder not used for this long is removed when a new state's folder is made (other
#: checkouts of the package, each with its own folder, keep theirs while they are used)
UNUSED_DAYS = 7.0
#: the file whose time records a folder's last use
STAMP = ".last-used"


def _remove_unused(parent: Path, keep: Path) -> None:
    limit = time.time() - UNUSED_DAYS * 86400.0
    for old in parent.iterdir():
        if old == keep or not old.is_dir():
            continue
        stamp = old / STAMP
        when = stamp.stat().st_mtime if stamp.exists() else old.stat().st_mtime
        if when < limit:
            shutil.rmtree(old, ignore_errors=True)


def source_digest(root: Path = PACKAGE) -> str:
    """16 hex digits over every ``.py`` file under ``root``: relative path, size and
    modification time (a stat each, no reading: well under a millisecond)."""
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        st = p.stat()
        h.update(f"{p.relative_to(root).as_posix()}\0{st.st_size}\0{st.st_mtime_ns}\n".encode())
    return h.hexdigest()[:16]


def cache_dir(root: Path = PACKAGE, base: Path | None = None) -> Path:
    """The kernel cache folder of the source under ``root``: ``base`` (default
    ``$XDG_CACHE_HOME/contactlab/numba``, else ``~/.cache/contactlab/numba``) / digest."""
    if base is None:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (Path(xdg) if xdg else Path.home() / ".cache") / "contactlab" / "numba"
    return Path(base) / source_digest(root)


def configure(root: Path = PACKAGE, base: Path | None = None) -> Path | None:
    """Set ``NUMBA_CACHE_DIR`` to :func:`cache_dir` (made if needed; folders unused for
    :data:`UNUSED_DAYS` removed) unless the user set it; the folder, or None where nothing was set."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    try:
        d = cache_dir(root, base)
        fresh = not d.is_dir()
        d.mkdir(parents=True, exist_ok=True)
        (d / STAMP).touch()                 # writable, and the time it was last used
        if fresh:
            _remove_unused(d.parent, keep=d)
    except OSError:
        return None
    os.environ["NUMBA_CACHE_DIR"] = str(d)
    return d
