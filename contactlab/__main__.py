"""``python -m contactlab`` and the ``contactlab`` command: run the CLI.

A signal that comes while the CLI is still loading (nothing is written yet) ends
the run at once with the line and status of any interrupted run, not with a
traceback of whatever module was being imported; the CLI's own handling
(:func:`contactlab.interrupt.signals_as_interrupt`) takes over when it starts.

An interrupted run, once the CLI has said so and chosen its status, ends the process at
once (as a second signal's quit does).  Left to the interpreter's normal exit, about one
interrupted run in ten under load ended killed by SIGINT (status -2, not 130): strace
showed the exit set SIGINT back to its default, after the line and with SIGINT ignored,
and send it to itself -- CPython's ending for a KeyboardInterrupt it counts as unhandled.
"""

import os
import signal
import sys

from contactlab.interrupt import received, signal_line


def _while_loading(signum, frame):
    os.write(2, f"contactlab: {signal_line(signum)}\n".encode())
    os._exit(128 + signum)


def run() -> None:
    """The ``contactlab`` command."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _while_loading)
    from contactlab.cli import main

    try:
        main(prog_name="contactlab")
    except SystemExit as exc:
        if not received():
            raise
        code = exc.code if isinstance(exc.code, int) else 1
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)


if __name__ == "__main__":
    run()
