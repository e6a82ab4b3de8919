"""``python -m contactlab`` and the ``contactlab`` command: run the CLI.

A signal that comes while the CLI is still loading (nothing is written yet) ends
the run at once with the line and status of any interrupted run, not with a
traceback of whatever module was being imported; the CLI's own handling
(:func:`contactlab.interrupt.signals_as_interrupt`) takes over when it starts.
"""

import os
import signal

from contactlab.interrupt import signal_line


def _while_loading(signum, frame):
    os.write(2, f"contactlab: {signal_line(signum)}\n".encode())
    os._exit(128 + signum)


def run() -> None:
    """The ``contactlab`` command."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _while_loading)
    from contactlab.cli import main

    main(prog_name="contactlab")


if __name__ == "__main__":
    run()
