"""Shared CLI machinery: error handling, --json/--quiet/--seed options, JSON output.

Commands stay thin: parse options, call one library function, format the result.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import click
import numpy as np

from contactlab import interrupt
from contactlab.errors import ContactlabError

PROG = "contactlab"


class _ClosingBars(click.Group):
    """Clears live progress bars when a command fails, so its error starts a line."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except BaseException:
            from contactlab.progress import close_bars

            close_bars()
            raise


class ContactlabGroup(_ClosingBars):
    """A click group that turns library errors into one line and an exit status.

    Data errors exit 1, usage errors 2; any other exception is reported in one
    line too, and shows its traceback only under ``contactlab --debug``.
    """

    def main(self, *args, **kwargs):
        """Run the CLI; usage errors become one line on stderr and exit status 2."""
        kwargs["standalone_mode"] = False
        try:
            with interrupt.signals_as_interrupt(exiting=True):
                rv = super().main(*args, **kwargs)
                signum = interrupt.received()
                if signum:  # the interrupt was swallowed on the way (e.g. in a finaliser)
                    _exit_interrupted(signum)
                sys.stdout.flush()
        except BrokenPipeError:
            _exit_broken_pipe()
        except click.UsageError as err:
            where = err.ctx.command_path if err.ctx is not None else PROG
            click.echo(f"{where}: error: {err.format_message()} (see '{where} --help')", err=True)
            sys.exit(err.exit_code)
        except click.ClickException as err:
            click.echo(f"{PROG}: error: {err.format_message()}", err=True)
            sys.exit(err.exit_code)
        except click.exceptions.Abort:
            click.echo(f"{PROG}: aborted", err=True)
            sys.exit(1)
        sys.exit(rv if isinstance(rv, int) else 0)

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except ContactlabError as err:
            if _debug(ctx):
                raise
            click.echo(f"{PROG}: error: {err}", err=True)
            ctx.exit(err.exit_code)
        except KeyboardInterrupt as err:
            if _debug(ctx):
                raise
            _exit_interrupted(interrupt.interrupt_signal(err))
        except (click.exceptions.Exit, click.ClickException, click.exceptions.Abort):
            raise
        except BrokenPipeError:
            _exit_broken_pipe()
        except Exception as err:  # noqa: BLE001 - the one place that reports the unexpected
            if _debug(ctx):
                raise
            signum = interrupt.interrupt_signal(err)
            if signum:  # an interrupt wrapped on its way out (numba: SystemError)
                _exit_interrupted(signum)
            msg = str(err).splitlines()[0] if str(err) else ""
            click.echo(f"{PROG}: internal error: {type(err).__name__}: {msg} "
                       f"(run '{PROG} --debug ...' for the traceback)", err=True)
            ctx.exit(1)


def _exit_broken_pipe() -> None:
    """The reader of stdout went away (``contactlab ... | head``): stop without a word, with
    the status a process killed by SIGPIPE has (128 + 13); stdout goes to /dev/null so that
    Python's final flush does not fail again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass
    sys.exit(141)


def _exit_interrupted(signum: int) -> None:
    """One line and exit status 128 + signal number (130 for SIGINT, 143 for SIGTERM)."""
    with interrupt.held():  # a signal now finds the line said (and says it once)
        click.echo(f"{PROG}: {interrupt.signal_line(signum)}", err=True)
        interrupt.reported()
    sys.exit(128 + int(signum))


def _debug(ctx: click.Context) -> bool:
    return bool(ctx.params.get("debug"))


def json_option(f):
    """``--json``: print exactly one JSON object on stdout."""
    return click.option("--json", "as_json", is_flag=True,
                        help="Print one JSON object on stdout instead of text.")(f)


def quiet_option(f):
    """``--quiet``: no progress bar on stderr."""
    return click.option("--quiet", "-q", is_flag=True, help="Hide progress bars.")(f)


def seed_option(f):
    """``--seed``: the seed of every random draw the command makes."""
    return click.option("--seed", type=int, default=1, show_default=True,
                        help="Random seed; the same seed gives the same run.")(f)


def archive_argument(f):
    """An existing archive file argument."""
    return click.argument("archive", type=click.Path(dir_okay=False, path_type=Path))(f)


def archives_argument(f):
    """One or more archive file arguments (``contactlab segment runs/*.h5``)."""
    return click.argument("archives", nargs=-1, required=True,
                          type=click.Path(dir_okay=False, path_type=Path))(f)


def parallel_options(unit: str):
    """``--workers N`` (local processes) and ``--scheduler ADDRESS`` (a Dask cluster),
    each running ``unit`` (trials, archives, experiments) in parallel."""

    def decorate(f):
        f = click.option("--scheduler", default=None, metavar="ADDRESS",
                         help=f"Run the {unit} on an existing Dask distributed cluster (e.g. "
                              "tcp://host:8786) whose workers see the same files at the "
                              "same paths.")(f)
        return click.option("--workers", type=click.IntRange(min=1), default=1,
                            show_default=True,
                            help=f"Run the {unit} in this many local processes (1: in this "
                                 "process, quickest for a few).")(f)

    return decorate


def echo_summaries(summaries: dict, echo_one) -> None:
    """Print each archive's summary with ``echo_one(path, summary)``; a heading per
    archive when there are several."""
    for path, summary in summaries.items():
        if len(summaries) > 1:
            click.echo(f"== {path}")
        echo_one(path, summary)


def json_summaries(summaries: dict) -> None:
    """One archive: its summary; several: ``{"archives": {path: summary}}``."""
    if len(summaries) == 1:
        echo_json(next(iter(summaries.values())))
    else:
        echo_json({"archives": {str(p): s for p, s in summaries.items()}})


def to_jsonable(obj):
    """Convert numpy scalars/arrays and paths to plain JSON types; NaN -> null."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def count(n: int, noun: str, plural: str | None = None) -> str:
    """``"1 trial"``, ``"3 trials"``: a count with its noun in the right number
    (``plural`` for a noun whose plural is not ``noun + "s"``)."""
    return f"{n} {noun if n == 1 else (plural or noun + 's')}"


def echo_json(obj) -> None:
    """Print ``obj`` as exactly one JSON object on stdout."""
    sys.stdout.write(json.dumps(to_jsonable(obj), sort_keys=False) + "\n")
    sys.stdout.flush()
