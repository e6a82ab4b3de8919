"""Progress bars on stderr for long work; ``quiet=True`` silences them."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")


def progress(iterable: Iterable[T], *, total: int | None = None, desc: str = "",
             quiet: bool = False, unit: str = "it") -> Iterator[T]:
    """Iterate over ``iterable`` showing a bar on stderr unless ``quiet``."""
    return iter(tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr,
                     disable=quiet, leave=False, dynamic_ncols=True, mininterval=_interval()))


def bar(*, total: int, desc: str = "", quiet: bool = False, unit: str = "it") -> tqdm:
    """A manually advanced bar (``.update(n)``, ``.close()``) on stderr."""
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=quiet,
                leave=False, dynamic_ncols=True, mininterval=_interval())


def _interval() -> float:
    """Redraw often on a terminal, rarely into a log file."""
    return 0.1 if sys.stderr.isatty() else 5.0
