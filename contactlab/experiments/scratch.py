"""The experiments' scratch folder: the archives and models an experiment simulates and
trains on its way to its page, deleted when it is done."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["scratch_dir"]


@contextmanager
def scratch_dir(out_dir) -> Iterator[Path]:
    """``out_dir/tmp``, created for the ``with`` block and deleted with all it holds when the
    block ends, also on an error or an interrupt."""
    tmp = Path(out_dir) / "tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    try:
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
