"""SIGINT and SIGTERM: stop the work, clean up, and never let the signal be lost.

While :func:`signals_as_interrupt` is active (main thread only) both signals
raise a :class:`KeyboardInterrupt` (:class:`Terminated` for SIGTERM), so every
``with`` block on the way out runs: temporary files are removed and an
incremental archive keeps its finished trials. The signal is also recorded,
so that :func:`received` still reports it when the exception was swallowed on
the way (an interrupt inside a finaliser prints "Exception ignored" and is
lost) or wrapped (numba's dispatcher turns it into a SystemError): the caller
then exits with 128 + the signal number all the same.
"""

from __future__ import annotations

import contextlib
import signal
import threading

_received: list[int] = []


class Terminated(KeyboardInterrupt):
    """SIGTERM received: handled exactly like Ctrl-C."""


def received() -> int | None:
    """The number of the first SIGINT/SIGTERM received while active (None: none)."""
    return _received[0] if _received else None


def interrupt_signal(err: BaseException | None) -> int | None:
    """The signal behind ``err``: an interrupt itself, or one in its cause/context
    chain (a SystemError wrapping it); else the recorded one, else None."""
    seen = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        if isinstance(err, Terminated):
            return signal.SIGTERM
        if isinstance(err, KeyboardInterrupt):
            return received() or signal.SIGINT
        err = err.__cause__ or err.__context__
    return None


@contextlib.contextmanager
def signals_as_interrupt():
    """While active (main thread only), SIGINT and SIGTERM raise KeyboardInterrupt
    (Terminated for SIGTERM) and are recorded for :func:`received`."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()

    def handler(signum, frame):
        _received.append(signum)
        if signum == signal.SIGTERM:
            raise Terminated(f"signal {signum}")
        raise KeyboardInterrupt

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
