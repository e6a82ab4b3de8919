"""SIGINT and SIGTERM: stop the work, clean up, and never let the signal be lost.

While :func:`signals_as_interrupt` is active (main thread only) both signals
raise a :class:`KeyboardInterrupt` (:class:`Terminated` for SIGTERM), so every
``with`` block on the way out runs: temporary files are removed and an
incremental archive keeps its finished trials.

Raising from a signal handler is unsafe while HDF5 writes: the exception can
surface inside h5py's C code or a finaliser and leave the library's state
broken (a segfault at the next flush). Code that writes therefore runs under
:func:`deferred`: the signal is only recorded, and the writer raises it at its
next safe point with :func:`checkpoint`.

The signal is also recorded for :func:`received`, so that a caller still exits
with 128 + the signal number when the exception was swallowed on the way (an
interrupt inside a finaliser is printed as "Exception ignored" and lost) or
wrapped (numba's dispatcher turns it into a SystemError).
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

_received: list[int] = []
_state = {"active": 0, "deferred": 0, "raised": False}


class Terminated(KeyboardInterrupt):
    """SIGTERM received: handled exactly like Ctrl-C."""


def received() -> int | None:
    """The number of the first SIGINT/SIGTERM received while active (None: none)."""
    return _received[0] if _received else None


def _exception(signum: int) -> KeyboardInterrupt:
    _state["raised"] = True
    return Terminated(f"signal {signum}") if signum == signal.SIGTERM else KeyboardInterrupt()


def checkpoint() -> None:
    """Raise the interrupt of a signal received under :func:`deferred` (or one whose
    exception was swallowed); a no-op otherwise, and after it has been raised once."""
    if _received and not _state["raised"]:
        raise _exception(_received[0])


@contextlib.contextmanager
def deferred():
    """While active, a signal is recorded but raised only at the next :func:`checkpoint`."""
    _state["deferred"] += 1
    try:
        yield
    finally:
        _state["deferred"] -= 1


def interrupt_signal(err: BaseException | None) -> int | None:
    """The signal behind ``err``: an interrupt itself, or one in its cause/context
    chain (a SystemError wrapping it); else None."""
    seen = set()
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        if isinstance(err, Terminated):
            return signal.SIGTERM
        if isinstance(err, KeyboardInterrupt):
            return received() or signal.SIGINT
        err = err.__cause__ or err.__context__
    return None


def _handler(signum, frame):
    _received.append(signum)
    if _state["deferred"] and len(_received) == 1:
        return  # raised at the writer's next checkpoint
    raise _exception(signum)


def _unraisable(previous):
    def hook(unraisable):
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            _state["raised"] = False  # swallowed by a finaliser: raise it again at a checkpoint
            return
        previous(unraisable)
    return hook


@contextlib.contextmanager
def signals_as_interrupt():
    """While active (main thread only), SIGINT and SIGTERM raise KeyboardInterrupt
    (Terminated for SIGTERM) and are recorded for :func:`received`. Nested uses
    share the outermost one's record."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if _state["active"]:
        _state["active"] += 1
        try:
            yield
        finally:
            _state["active"] -= 1
        return
    _received.clear()
    _state.update(active=1, raised=False)
    previous = {s: signal.signal(s, _handler) for s in (signal.SIGINT, signal.SIGTERM)}
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable(previous_hook)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        if sys.unraisablehook is not previous_hook:
            sys.unraisablehook = previous_hook
        _state["active"] = 0
