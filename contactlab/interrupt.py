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

A second signal quits at once, whatever runs: the actions registered with
:func:`on_quit` (plain ``os`` calls that leave the files on disk whole: an
archive being recorded is rolled back to its last finished trial, a temporary
file is removed) run from the handler, each says in a line what it kept, and
the process exits with 128 + the first signal's number. No exception is raised
into the code that was running, so no ``with`` block is left half done.
:func:`held` keeps a quit from splitting the few steps that must happen
together (a commit and its bookkeeping): it waits for the block's end.

The signal is also recorded for :func:`received`, so that a caller still exits
with 128 + the signal number when the exception was swallowed on the way (an
interrupt inside a finaliser is printed as "Exception ignored" and lost) or
wrapped (numba's dispatcher turns it into a SystemError).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Callable

_received: list[int] = []
_state = {"active": 0, "deferred": 0, "raised": False, "held": 0, "quit": False,
          "quitting": False, "child": False, "reported": False}
_quit_actions: list[Callable[[], str | None]] = []


def _forked() -> None:
    """A forked worker inherits the handlers, not the files its parent is writing."""
    _quit_actions.clear()
    _state["child"] = True


os.register_at_fork(after_in_child=_forked)


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


@contextlib.contextmanager
def on_quit(action: Callable[[], str | None]):
    """While active, a second signal runs ``action()`` before the process quits.

    ``action`` runs inside the signal handler, between any two steps of the
    code it interrupts: it must only make the files on disk whole with plain
    ``os`` calls, and returns a line saying what was kept (or None).
    """
    _quit_actions.append(action)
    try:
        yield
    finally:
        _quit_actions.remove(action)


@contextlib.contextmanager
def held():
    """A quit (a second signal) waits for the end of this block."""
    _state["held"] += 1
    try:
        yield
    finally:
        _state["held"] -= 1
        if not _state["held"] and _state["quit"]:
            _quit()


def reported() -> None:
    """The run has said how it ends (its last line): a later signal quits silently."""
    _state["reported"] = True


def signal_line(signum: int) -> str:
    """``"interrupted (SIGINT)"``, ``"terminated (SIGTERM)"``: what the run ends with."""
    name = signal.Signals(signum).name
    return f"{'terminated' if signum == signal.SIGTERM else 'interrupted'} ({name})"


def _quit() -> None:
    """Run the quit actions, say what they kept and exit with 128 + the first signal
    (a forked worker only exits: its parent says what was kept)."""
    _state["quitting"] = True
    if _state["child"] or _state["reported"]:  # nothing left to say
        os._exit(128 + int(_received[0]))
    lines = []
    for action in reversed(_quit_actions):
        try:
            line = action()
        except Exception as err:  # noqa: BLE001 - the others must run all the same
            line = f"{err}"
        if line:
            lines.append(line)
    signum = _received[0]
    lines.append(signal_line(signum))
    with contextlib.suppress(OSError):
        os.write(2, "".join(f"contactlab: {line}\n" for line in lines).encode())
    os._exit(128 + int(signum))


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
    if _state["quitting"]:
        return
    _received.append(signum)
    if len(_received) > 1:  # the second signal: quit at once
        if _state["held"]:
            _state["quit"] = True  # at the end of the held block
            return
        _quit()
    if _state["deferred"]:
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
def signals_as_interrupt(*, exiting: bool = False):
    """While active (main thread only), SIGINT and SIGTERM raise KeyboardInterrupt
    (Terminated for SIGTERM) and are recorded for :func:`received`. Nested uses
    share the outermost one's record.

    ``exiting``: the process ends with the block (the CLI): later signals are
    ignored instead of restoring the previous handlers, so that one during the
    exit does not replace its status and line (the work is done by then)."""
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
    _state.update(active=1, raised=False, quit=False, quitting=False, reported=False)
    previous = {s: signal.signal(s, _handler) for s in (signal.SIGINT, signal.SIGTERM)}
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable(previous_hook)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, signal.SIG_IGN if exiting else h)
        if sys.unraisablehook is not previous_hook:
            sys.unraisablehook = previous_hook
        _state["active"] = 0
