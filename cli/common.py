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


class ContactlabGroup(click.Group):
    """A click group that turns library errors into one line and an exit status.

    Data errors exit 1, usage errors 2; any other exception is reported in one
    line too, and shows its traceback only under ``contactlab --debug``.
    """

    def main(self, *args, **kwargs):
        """Run the CLI; usage errors become one line on stderr and exit status 2."""
        kwargs["standalone_mode"] = False
        try:
            with interrupt.signals_as_interrupt():
                rv = super().main(*args, **kwargs)
                signum = interrupt.received()
                if signum:  # the interrupt was swallowed on the way (e.g. in a finaliser)
                    _exit_interrupted(signum)
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


def _exit_interrupted(signum: int) -> None:
    """One line and exit status 128 + signal number (130 for SIGINT, 143 for SIGTERM)."""
    import signal

    name = signal.Signals(signum).name
    what = "terminated" if signum == signal.SIGTERM else "interrupted"
    click.echo(f"{PROG}: {what} ({name})", err=True)
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


def echo_json(obj) -> None:
    """Print ``obj`` as exactly one JSON object on stdout."""
    sys.stdout.write(json.dumps(to_jsonable(obj), sort_keys=False) + "\n")
    sys.stdout.flush()


def not_available(verb: str, issue: str):
    """A verb whose implementation lands with a later issue."""

    @click.command(name=verb, context_settings={"ignore_unknown_options": True},
                   help=f"Not available yet: lands with the {issue} issue.\n\n"
                        f"Example: contactlab {verb} --help")
    @click.argument("args", nargs=-1, type=click.UNPROCESSED)
    def cmd(args):
        click.echo(f"{PROG}: {verb}: not available yet (lands with the {issue} issue)", err=True)
        sys.exit(2)

    return cmd
