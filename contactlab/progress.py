"""Progress bars on stderr for long work.

A bar is drawn only when stderr is a terminal: logs, pipes and CI output get
none (not even tqdm's one summary line per bar); ``quiet=True`` silences them
on a terminal too.  :func:`close_bars` clears every live bar, so an error
printed after it starts on its own line.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")


def progress(iterable: Iterable[T], *, total: int | None = None, desc: str = "",
             quiet: bool = False, unit: str = "it") -> Iterator[T]:
    """Iterate over ``iterable``, with a bar on stderr when it is a terminal and not ``quiet``."""
    return iter(bar(total=total, desc=desc, quiet=quiet, unit=unit, iterable=iterable))


def bar(*, total: int | None, desc: str = "", quiet: bool = False, unit: str = "it",
        iterable: Iterable | None = None) -> tqdm:
    """A manually advanced bar (``.update(n)``, ``.close()``) on stderr; see :func:`progress`."""
    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr,
                disable=quiet or not stderr_is_terminal(), leave=False, dynamic_ncols=True,
                mininterval=0.1)


def stderr_is_terminal() -> bool:
    """Whether stderr is an interactive terminal (bars are drawn only then)."""
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):  # replaced or closed stream
        return False


def close_bars() -> None:
    """Close every live bar (clearing its line), so the next message starts a line."""
    for b in list(getattr(tqdm, "_instances", ())):
        try:
            b.close()
        except Exception:  # noqa: BLE001 - a broken bar must not hide the error being reported
            pass
