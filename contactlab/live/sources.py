"""Live sources for ``contactlab watch``: ``sim:SPEC``, ``netft:HOST[:PORT]``, ``phantom``,
and CSV lines (``-`` for standard input, ``csv:PATH`` for a file or a named pipe).

Every source is a :class:`LiveSource`: ``fields`` (the raw measurements it gives),
``reconnects`` (whether a fault starts a new recording instead of ending the run) and
``trials()``, which yields the acquire drivers' trial streams
(:class:`~contactlab.acquire.base.TrialStream`: ``info``, ``chunks()``, and after
the chunks ``ground_truth()``, ``final_attrs()``).  The simulator and the hardware
come through the acquire drivers unchanged; the simulator computes a trial ahead and
releases its rows at the recorded pace (``realtime``) or as fast as they are taken.

CSV lines are read as they come: a header line, then one row per line, columns
mapped by a column map as ``contactlab import`` maps them (:func:`parse_column_map`;
time from the data, the rate from the median step of the first rows unless given).
A malformed line (a wrong number of fields, a value that is not a number, a time
that does not increase) is skipped with one line on stderr naming the line; a
stream that stalls for ``stall_s`` says so once on stderr and is waited for.
"""

from __future__ import annotations

import fnmatch
import os
import select
import sys
import time as _time
from collections.abc import Iterator

import numpy as np

from contactlab.acquire.base import TrialInfo
from contactlab.errors import DataError, UsageError

__all__ = ["LiveSource", "open_source", "CsvLines", "warn"]

#: rows the CSV source uses to find the rate (median step) before its first chunk
RATE_ROWS = 20


def warn(message: str) -> None:
    """One line on stderr, flushed."""
    print(f"contactlab watch: {message}", file=sys.stderr, flush=True)


class LiveSource:
    """A source of live recordings (see the module notes)."""

    def __init__(self, name: str, fields, trials, *, reconnects: bool = False):
        self.name = name
        self.fields = tuple(fields)
        self._trials = trials
        self.reconnects = reconnects

    def trials(self) -> Iterator:
        return self._trials()


class _Paced:
    """A simulated trial whose rows are released in ``chunk``-row pieces, at the recorded
    pace when ``realtime``."""

    def __init__(self, trial, *, chunk: int, realtime: bool):
        self._trial, self.info = trial, trial.info
        self.chunk, self.realtime = chunk, realtime

    def chunks(self):
        rows = list(self._trial.chunks())          # the simulator runs the whole trial here
        whole = {k: np.concatenate([r[k] for r in rows]) for k in rows[0]}
        t = whole["time"]
        start = _time.monotonic()
        for a in range(0, len(t), self.chunk):
            b = min(a + self.chunk, len(t))
            if self.realtime:
                wait = start + (t[b - 1] - t[0]) - _time.monotonic()
                if wait > 0:
                    _time.sleep(wait)
            yield {k: v[a:b] for k, v in whole.items()}

    def __getattr__(self, name):
        return getattr(self._trial, name)


def open_source(text: str, *, chunk: int = 40, realtime: bool = True, trials: int | None = None,
                seed: int = 1, duration_s: float = 3600.0, rate_hz: float | None = None,
                columns: dict | None = None, timeout_s: float = 1.0,
                stall_s: float = 2.0, stdin=None) -> LiveSource:
    """The :class:`LiveSource` ``text`` names (``sim:SPEC``, ``netft:HOST[:PORT]``,
    ``phantom``, ``-``, ``csv:PATH``); UsageError for an unknown form."""
    if text.startswith("sim:"):
        from contactlab.acquire.sim import SimSource
        from contactlab.acquire.spec import load_spec

        spec = load_spec(text[4:])
        sim = SimSource(spec)
        n = spec.n_trials if trials is None else trials
        fields = ["strain", "wrench", "position", "velocity", "command"]
        if spec.action_names:
            fields.append("action")
        return LiveSource(text, fields, lambda: (_Paced(t, chunk=chunk, realtime=realtime)
                                                 for t in sim.trials(n_trials=n, seed=seed)))
    if text.startswith("netft:"):
        from contactlab.acquire.netft import RDT_PORT, NetFTSource

        host, _, port = text[6:].rpartition(":") if text.count(":") == 2 else (text[6:], "", "")
        if port and not port.isdigit():
            raise UsageError(f"--source {text}: the port must be a number")
        src = NetFTSource(host=host, port=int(port) if port else RDT_PORT,
                          duration_s=duration_s, rate_hz=rate_hz or 1000.0,
                          timeout_s=timeout_s)
        n = trials or 1000
        return LiveSource(text, ["wrench"], lambda: src.trials(n_trials=n, seed=-1),
                          reconnects=True)
    if text == "phantom":
        from contactlab.acquire.phantom import PhantomSource

        src = PhantomSource(duration_s=duration_s, rate_hz=rate_hz or 1000.0)
        return LiveSource(text, ["position", "velocity"],
                          lambda: src.trials(n_trials=trials or 1, seed=-1))
    if text == "-" or text.startswith("csv:"):
        if columns is None:
            raise UsageError("--columns is required with a CSV source (--source - or csv:PATH)")
        name = "stdin" if text == "-" else text[4:]
        csv = CsvLines(name, columns, rate_hz=rate_hz, chunk=chunk, stall_s=stall_s,
                       stream=stdin if text == "-" else None)
        return LiveSource(text, csv.fields, lambda: iter([csv]))
    raise UsageError(f"--source {text!r}: expected sim:SPEC, netft:HOST[:PORT], phantom, - "
                     "(CSV on standard input) or csv:PATH")


class CsvLines:
    """One recording from CSV lines as they arrive (a trial stream; module notes)."""

    def __init__(self, name: str, columns: dict, *, rate_hz: float | None = None,
                 chunk: int = 40, stall_s: float = 2.0, stream=None):
        self.name = name
        self.columns = columns
        if "time" not in columns:
            raise UsageError("--columns must map time (time=COLUMN): watch takes time from "
                             "the data")
        self.fields = tuple(f for f in ("strain", "wrench", "position", "velocity", "action")
                            if f in columns)
        self.rate_hz = rate_hz
        self.chunk = max(1, int(chunk))
        self.stall_s = stall_s
        self._stream = stream
        self.skipped = 0
        self.info = None
        self._line = 0

    # -- the trial-stream protocol ----------------------------------------------------
    def ground_truth(self):
        return None

    def final_attrs(self) -> dict:
        return {"skipped_lines": self.skipped}

    def chunks(self):
        if self._stream is not None:
            fd, close = self._stream.fileno(), False
        else:
            try:
                fd, close = os.open(self.name, os.O_RDONLY), True
            except OSError as err:
                raise DataError(f"cannot be read ({err.strerror})", file=self.name) from None
        try:
            yield from self._rows(fd)
        finally:
            if close:
                os.close(fd)

    # -- internals ----------------------------------------------------------------------
    def _lines(self, fd) -> Iterator[list[str]]:
        """Complete lines as they arrive, in batches (never waiting while some are read)."""
        partial = b""
        stalled = False
        last = _time.monotonic()
        while True:
            ready = select.select([fd], [], [], 0.2)[0]
            from contactlab import interrupt
            interrupt.checkpoint()
            if not ready:
                if not stalled and _time.monotonic() - last > self.stall_s:
                    warn(f"{self.name}: no data for {self.stall_s:g} s (stream stalled; "
                         "waiting)")
                    stalled = True
                continue
            data = os.read(fd, 1 << 16)
            if not data:
                if partial.strip():
                    yield [partial.decode("utf-8", "replace")]
                return
            if stalled:
                warn(f"{self.name}: data again after a stall")
            stalled, last = False, _time.monotonic()
            lines = (partial + data).split(b"\n")
            partial = lines.pop()
            if lines:
                yield [ln.decode("utf-8", "replace").rstrip("\r") for ln in lines]

    def _header(self, line: str) -> None:
        delim = max((",", ";", "\t", "|"), key=line.count)
        if line.count(delim) == 0:
            delim = None
        self._delim = delim
        head = [h.strip() for h in (line.split(delim) if delim else line.split())]
        cols: dict[str, list[int]] = {}
        for field, names in self.columns.items():
            idx = []
            for n in names:
                hits = [i for i, h in enumerate(head) if fnmatch.fnmatchcase(h, n)] \
                    if any(c in n for c in "*?[") else ([head.index(n)] if n in head else [])
                if not hits:
                    raise DataError(f"no column {n!r} (for {field}) in the header",
                                    file=self.name, field=n)
                idx += hits
            cols[field] = idx
        self._cols = {f: c for f, c in cols.items() if f in ("time",) + self.fields}
        self._width = len(head)
        self._use = sorted({i for c in self._cols.values() for i in c})

    def _parse(self, lines: list[str]) -> np.ndarray:
        """(n, width) float rows of the well-formed lines (the mapped columns as numbers,
        the others NaN); malformed lines are skipped with a line on stderr."""
        first = self._line
        self._line += len(lines)
        split = [(k, ln.split(self._delim) if self._delim else ln.split())
                 for k, ln in enumerate(lines) if ln.strip()]
        use = self._use
        try:
            a = np.array([p for _, p in split], dtype=str)
            if a.ndim == 2 and a.shape[1] == self._width:
                out = np.full(a.shape, np.nan)
                out[:, use] = a[:, use].astype(np.float64)
                if np.isfinite(out[:, use]).all():
                    return out
        except ValueError:
            pass
        good = []           # the slow path: only for a batch holding a bad line
        for k, parts in split:
            why = f"expected {self._width} fields, got {len(parts)}"
            if len(parts) == self._width:
                try:
                    v = np.full(self._width, np.nan)
                    v[use] = np.array([parts[i] for i in use], dtype=np.float64)
                    if np.isfinite(v[use]).all():
                        good.append(v)
                        continue
                    why = "a value is not finite"
                except ValueError:
                    why = "a value is not a number"
            self._skip(first + k + 1, why)
        return np.array(good).reshape(-1, self._width)

    def _skip(self, line: int, why: str) -> None:
        self.skipped += 1
        warn(f"{self.name}: line {line}: malformed ({why}); skipped")

    def _rows(self, fd):
        pending: list[np.ndarray] = []
        last_t = -np.inf
        for lines in self._lines(fd):
            if self.info is None and not hasattr(self, "_cols"):
                self._line += 1
                self._header(lines[0])
                lines = lines[1:]
            a = self._parse(lines)
            if not len(a):
                continue
            t = a[:, self._cols["time"][0]]
            bad = np.diff(np.r_[last_t, t]) <= 0
            if bad.any():             # the slow path, only for a batch with a bad time
                keep = np.ones(len(t), bool)
                prev = last_t
                for i in range(len(t)):
                    keep[i] = t[i] > prev
                    prev = t[i] if keep[i] else prev
                for _ in range(int((~keep).sum())):
                    self._skip(self._line, "time does not increase")
                a, t = a[keep], t[keep]
                if not len(a):
                    continue
            last_t = t[-1]
            pending.append(a)
            if self.info is None:
                rows = np.concatenate(pending)
                if self.rate_hz is None and len(rows) < RATE_ROWS:
                    continue
                rate = self.rate_hz or float(1.0 / np.median(np.diff(rows[:, self._cols["time"][0]])))
                self.info = TrialInfo(trial_id=_trial_id(self.name), rate_hz=rate, source="csv",
                                      description=f"CSV lines from {self.name}")
                pending = [rows]
            rows = np.concatenate(pending)
            pending = []
            for s in range(0, len(rows), self.chunk):
                yield self._chunk(rows[s:s + self.chunk])
        if pending and self.info is None:
            rows = np.concatenate(pending)
            if len(rows) < 2:
                raise DataError("fewer than 2 rows: no rate (give --rate)", file=self.name)
            rate = self.rate_hz or float(1.0 / np.median(np.diff(rows[:, self._cols["time"][0]])))
            self.info = TrialInfo(trial_id=_trial_id(self.name), rate_hz=rate, source="csv",
                                  description=f"CSV lines from {self.name}")
            yield self._chunk(rows)
        if self.info is None:
            raise DataError("no data rows", file=self.name)

    def _chunk(self, rows: np.ndarray) -> dict:
        out = {f: rows[:, c] for f, c in self._cols.items()}
        out["time"] = out["time"][:, 0]
        if "action" in out:
            out["action"] = out["action"][:, 0].astype(np.int16)
        return out


def _trial_id(name: str) -> str:
    stem = os.path.splitext(os.path.basename(name))[0] if name != "stdin" else "stdin"
    return "".join(c if c.isalnum() or c in "-_" else "-" for c in stem) or "live"
