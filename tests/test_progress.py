"""Progress bars: drawn only on a terminal, silenced by quiet, cleared before errors."""

from __future__ import annotations

import io
import sys

import pytest

from contactlab.errors import DataError
from contactlab.progress import bar, close_bars, progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture
def terminal(monkeypatch):
    """A stand-in terminal as stderr (set in the test body: pytest's capture resets it
    between a fixture's setup and the test)."""
    err = _Terminal()

    def install():
        monkeypatch.setattr(sys, "stderr", err)
        return err
    return install


def test_no_bar_when_stderr_is_not_a_terminal(monkeypatch):
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    assert list(progress(range(5), desc="work", unit="trial")) == list(range(5))
    b = bar(total=None, desc="stream", unit="sample")
    b.update(100)
    b.close()
    assert err.getvalue() == ""


def test_a_terminal_gets_a_bar_and_quiet_silences_it(terminal):
    terminal = terminal()
    assert list(progress(range(3), desc="work", unit="trial")) == [0, 1, 2]
    assert "work" in terminal.getvalue()
    terminal.seek(0)
    terminal.truncate()
    assert list(progress(range(3), desc="work", quiet=True)) == [0, 1, 2]
    assert terminal.getvalue() == ""


def test_close_bars_leaves_the_cursor_at_a_line_start(terminal):
    terminal = terminal()
    it = progress(range(10), desc="import", unit="file")
    next(it)
    assert "import" in terminal.getvalue()
    close_bars()
    # tqdm clears a closed leave=False bar with a carriage return: what follows starts a line
    assert terminal.getvalue().endswith("\r")


_FAILING_CLI = """
import click
from contactlab.cli.common import ContactlabGroup
from contactlab.errors import DataError
from contactlab.progress import progress

@click.group(cls=ContactlabGroup)
def cli():
    pass

@cli.command()
def boom():
    it = progress(range(10), desc="importing", unit="file")
    next(it)
    raise DataError("bad value", file="x.csv", field="fx")

cli(["boom"], prog_name="contactlab")
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs a pseudo-terminal")
def test_a_cli_error_after_a_live_bar_starts_on_its_own_line():
    import os
    import pty
    import subprocess

    import fcntl
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    proc = subprocess.run([sys.executable, "-c", _FAILING_CLI], stderr=slave,
                          stdout=subprocess.DEVNULL, timeout=60)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:
            break
        if not data:
            break
        chunks.append(data)
        if len(data) < 4096:
            break
    os.close(master)
    text = b"".join(chunks).decode()
    assert proc.returncode == 1
    assert "importing" in text                  # a bar was drawn on the terminal
    before, _, after = text.partition("contactlab: error:")
    assert after, text
    assert before.endswith(("\r", "\n")), repr(text)   # the error starts a line
