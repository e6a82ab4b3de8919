"""An ATI Net F/T sensor over its UDP RDT protocol.

RDT ("Raw Data Transfer", ATI Net F/T manual, section "UDP interface using
RDT") is small enough to speak directly:

* request, 8 bytes big-endian: header 0x1234 (u16), command (u16), sample
  count (u32). Command 2 starts high-speed real-time streaming of
  ``sample_count`` records (0 = until stopped); command 0 stops it.
* record, 36 bytes big-endian: rdt_sequence (u32), ft_sequence (u32), status
  (u32), Fx Fy Fz Tx Ty Tz (i32 counts). Force = counts / counts_per_force,
  torque = counts / counts_per_torque. The sensor's own "Counts per Force /
  Torque" depend on its configured units; give the values for N and N m (a
  sensor reporting N mm needs counts_per_torque = its value x 1000).

Time base. The RDT output rate is a setting of the Net F/T box (its web page,
"RDT output rate"); the packets do not carry it, so ``rate_hz`` must match it.
Every packet carries ``rdt_sequence``, which the box increments once per
record, so a record is placed at ``(rdt_sequence - first) / rate_hz``: a
uniform time base in which a lost packet is a missing row, not a shifted one.
Received records are kept as they are and nothing is interpolated; the trial
attributes count what was lost:

* ``dropped_packets``: sequence numbers never received (gaps);
* ``out_of_order_packets``: records that arrived after a later one (their
  slot is already past, so they are discarded);
* ``duplicate_packets``: repeats of the previous record (discarded);
* ``status_errors``: kept records whose status word is not zero
  (``status_bits`` is the OR of those words; see the manual's status table).

The 32-bit sequence numbers wrap around; differences are taken modulo 2**32.
The sequence numbers are checked against the wall clock over one second between two
packets the reader was waiting for (so a consumer that falls behind and catches up, or a
box that stops, is not taken for a wrong rate), and a rate more than 10 % away from
``rate_hz`` stops the trial with an error (the archive's time base would be wrong
otherwise).

Besides the wrench, each trial keeps ``rdt_sequence``, ``ft_sequence`` and
``status`` per kept record: :meth:`NetFTTrial.extra_datasets`.
"""

from __future__ import annotations

import math
import select
import socket
import struct
import time as _time
from collections.abc import Iterator
from datetime import datetime, timezone

import numpy as np

from contactlab.acquire.base import TrialInfo
from contactlab.errors import DataError, UsageError

RDT_PORT = 49152
RDT_HEADER = 0x1234
CMD_STOP = 0x0000
CMD_START_REALTIME = 0x0002
REQUEST = struct.Struct(">HHI")
RECORD = struct.Struct(">IIIiiiiii")
RECORD_DTYPE = np.dtype([("rdt_sequence", ">u4"), ("ft_sequence", ">u4"), ("status", ">u4"),
                         ("counts", ">i4", (6,))])
assert RECORD_DTYPE.itemsize == RECORD.size == 36

#: Records per chunk handed to the archive writer (0.1 s at 1 kHz).
CHUNK_RECORDS = 100
#: Wall-clock span between the two caught-up packets the sequence-number rate is judged
#: over, s.
RATE_CHECK_S = 1.0
RATE_CHECK_TOLERANCE = 0.10
#: Kernel receive buffer asked for, bytes (a few seconds of records at 7 kHz).
RECEIVE_BUFFER = 1 << 20
_WRAP = 1 << 32
_HALF = 1 << 31


def rdt_request(command: int, sample_count: int = 0) -> bytes:
    """The 8-byte RDT request."""
    return REQUEST.pack(RDT_HEADER, command, sample_count)


def rdt_record(rdt_sequence: int, ft_sequence: int, status: int, counts) -> bytes:
    """One 36-byte RDT record (what the sensor sends; used by test fakes)."""
    return RECORD.pack(rdt_sequence % _WRAP, ft_sequence % _WRAP, status, *(int(c) for c in counts))


class NetFTSource:
    """Trials recorded from an ATI Net F/T box at ``host``:``port``.

    Parameters
    ----------
    host, port : the box's address and RDT port (49152 on every Net F/T)
    duration_s : length of each trial, s (in sensor time: sequence span / rate)
    rate_hz : the box's configured RDT output rate, Hz (see the module text)
    counts_per_force, counts_per_torque : counts per N and per N m
    timeout_s : longest wait for a packet before the trial fails, s
    sample_count : records requested per trial (0 = stream until stopped);
        when positive the trial ends after that many sequence numbers
    trial_prefix : trial ids are ``<prefix>01``, ``<prefix>02``, ...
    """

    name = "netft"

    def __init__(self, *, host: str, port: int = RDT_PORT, duration_s: float,
                 rate_hz: float = 1000.0, counts_per_force: float = 1_000_000,
                 counts_per_torque: float = 1_000_000, timeout_s: float = 1.0,
                 sample_count: int = 0, trial_prefix: str = "netft"):
        if not isinstance(host, str) or not host:
            raise UsageError(f"host must be a host name or address, not {host!r}")
        if not (isinstance(port, int) and 0 < port < 65536):
            raise UsageError(f"port must be an integer in 1..65535, not {port!r}")
        for pname, value in (("duration_s", duration_s), ("rate_hz", rate_hz),
                             ("counts_per_force", counts_per_force),
                             ("counts_per_torque", counts_per_torque), ("timeout_s", timeout_s)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise UsageError(f"{pname} must be a positive number, not {value!r}")
        if not (isinstance(sample_count, int) and 0 <= sample_count < _WRAP):
            raise UsageError(f"sample_count must be an integer >= 0, not {sample_count!r}")
        self.host = host
        self.port = port
        self.duration_s = float(duration_s)
        self.rate_hz = float(rate_hz)
        self.counts_per_force = float(counts_per_force)
        self.counts_per_torque = float(counts_per_torque)
        self.timeout_s = float(timeout_s)
        self.sample_count = sample_count
        self.trial_prefix = trial_prefix

    def trials(self, *, n_trials: int, seed: int) -> Iterator[NetFTTrial]:
        """``n_trials`` recordings, one after the other (``seed`` is only stored)."""
        for i in range(n_trials):
            yield NetFTTrial(self, f"{self.trial_prefix}{i + 1:02d}", seed=seed)


class NetFTTrial:
    """One recording: iterate :meth:`chunks`, then read :meth:`final_attrs`."""

    def __init__(self, source: NetFTSource, trial_id: str, *, seed: int = -1):
        self.source = source
        where = f"{source.host}:{source.port}"
        self.info = TrialInfo(
            trial_id=trial_id, rate_hz=source.rate_hz, seed=seed, source="netft",
            description=f"ATI Net F/T at {where}, UDP RDT real-time streaming",
            attrs={"netft_host": source.host, "netft_port": source.port,
                   "counts_per_force": source.counts_per_force,
                   "counts_per_torque": source.counts_per_torque})
        self._where = where
        self._stats = {"received_packets": 0, "dropped_packets": 0, "out_of_order_packets": 0,
                       "duplicate_packets": 0, "status_errors": 0, "status_bits": 0}
        self._extra: dict[str, list[np.ndarray]] = {"rdt_sequence": [], "ft_sequence": [],
                                                    "status": []}
        self._started_utc = ""
        self._measured_rate_hz = float("nan")
        self.stop_sent = False

    # -- the TrialStream protocol ------------------------------------------------

    def chunks(self) -> Iterator[dict[str, np.ndarray]]:
        """Start streaming, yield ``{"time", "wrench"}`` chunks, send stop at the end.

        The stop request is sent however the loop ends: normally, on an
        error, on KeyboardInterrupt, or when the consumer closes the generator.
        """
        src = self.source
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
            except OSError:
                pass
            sock.settimeout(src.timeout_s)
            try:
                sock.connect((src.host, src.port))
                sock.send(rdt_request(CMD_START_REALTIME, src.sample_count))
            except OSError as err:
                raise self._error(f"cannot reach {self._where}: {err.strerror or err}") from None
            self._started_utc = datetime.now(timezone.utc).isoformat(timespec="milliseconds")
            try:
                yield from self._stream(sock)
            finally:
                self._send_stop(sock)
        finally:
            sock.close()

    def ground_truth(self) -> None:
        """Hardware has no ground truth."""
        return None

    def final_attrs(self) -> dict:
        """Packet counts, the start time and the measured sequence rate."""
        out = dict(self._stats)
        out["started_utc"] = self._started_utc
        if math.isfinite(self._measured_rate_hz):
            out["measured_rate_hz"] = self._measured_rate_hz
        seq = self._extra["rdt_sequence"]
        if seq:
            out["first_rdt_sequence"] = int(seq[0][0])
            out["last_rdt_sequence"] = int(seq[-1][-1])
        return out

    def extra_datasets(self) -> dict[str, np.ndarray]:
        """Per kept row: raw ``rdt_sequence``, ``ft_sequence`` and ``status`` words (int64)."""
        return {name: (np.concatenate(parts) if parts else np.zeros(0)).astype(np.int64)
                for name, parts in self._extra.items()}

    # -- internals -------------------------------------------------------------

    def _error(self, message: str) -> DataError:
        return DataError(message, field="host")

    def _send_stop(self, sock: socket.socket) -> None:
        try:
            sock.send(rdt_request(CMD_STOP, 0))
            self.stop_sent = True
        except OSError:
            pass   # the box will time the stream out; nothing more to do here

    def _stream(self, sock: socket.socket) -> Iterator[dict[str, np.ndarray]]:
        src = self.source
        n_target = max(1, round(src.duration_s * src.rate_hz))
        if src.sample_count:
            n_target = min(n_target, src.sample_count)
        stats = self._stats
        first = None        # raw sequence number of the first record (offset 0)
        last = -1           # offset of the last kept record
        wall0 = None
        rate_checked = False
        buffer: list[bytes] = []
        offsets: list[int] = []
        anchor = None       # (offset, time) of the first packet the reader was waiting for
        while last < n_target - 1:
            asked = _time.monotonic()
            try:
                packet = sock.recv(RECORD.size + 64)
            except socket.timeout:
                if first is None:
                    raise self._error(f"no packets from {self._where} within "
                                      f"{src.timeout_s:g} s") from None
                if src.sample_count:          # the box sent what was asked; the tail is lost
                    stats["dropped_packets"] += n_target - 1 - last
                    break
                if buffer:                    # what arrived before the stall is kept
                    yield self._decode(buffer, offsets)
                    buffer, offsets = [], []
                raise self._error(f"packets from {self._where} stopped after {last + 1} "
                                  f"sequence numbers (none within {src.timeout_s:g} s)") from None
            except ConnectionRefusedError:
                raise self._error(f"{self._where} refused the RDT request "
                                  "(no Net F/T listening there)") from None
            if len(packet) != RECORD.size:
                raise self._error(f"malformed RDT packet from {self._where}: {len(packet)} "
                                  f"bytes, expected {RECORD.size}")
            stats["received_packets"] += 1
            seq = int.from_bytes(packet[:4], "big")
            if first is None:
                first, wall0 = seq, _time.monotonic()
                offset = 0
            else:
                delta = (seq - first - last) % _WRAP
                if delta >= _HALF:
                    stats["out_of_order_packets"] += 1
                    continue
                if delta == 0:
                    stats["duplicate_packets"] += 1
                    continue
                offset = last + delta
                if offset >= n_target:        # past the end of the trial
                    stats["dropped_packets"] += n_target - 1 - last
                    break
                stats["dropped_packets"] += delta - 1
            last = offset
            buffer.append(packet)
            offsets.append(offset)
            # the rate is judged between two packets that each arrived while the reader
            # waited for it -- the recv waited, and the receive buffer is empty after it --
            # so each came just as the box sent it, and the count between them measures the
            # box and not a slow consumer's lag.  Either sign alone misleads: a loaded
            # machine delays a ready recv too, and the buffer also empties on the last
            # packets of a box that has stopped sending.
            if not rate_checked and _time.monotonic() - asked > 0.5 / src.rate_hz \
                    and not select.select([sock], [], [], 0)[0]:
                now = _time.monotonic()
                if anchor is None:
                    anchor = (last, now)
                elif now - anchor[1] >= RATE_CHECK_S:
                    rate_checked = True
                    self._check_rate(last - anchor[0], now - anchor[1])
            if len(buffer) >= CHUNK_RECORDS:
                yield self._decode(buffer, offsets)
                buffer, offsets = [], []
        if buffer:
            yield self._decode(buffer, offsets)
        if wall0 is not None and not rate_checked:
            span = _time.monotonic() - wall0
            if span > 0 and last > 0:
                self._measured_rate_hz = last / span

    def _check_rate(self, n_offsets: int, wall_span: float) -> None:
        measured = n_offsets / wall_span
        self._measured_rate_hz = measured
        rate = self.source.rate_hz
        if abs(measured / rate - 1.0) > RATE_CHECK_TOLERANCE:
            raise self._error(f"{self._where} streams at about {measured:.4g} Hz by its RDT "
                              f"sequence numbers, not rate_hz={rate:g}: set rate_hz to the "
                              "box's RDT output rate")

    def _decode(self, buffer: list[bytes], offsets: list[int]) -> dict[str, np.ndarray]:
        src = self.source
        records = np.frombuffer(b"".join(buffer), dtype=RECORD_DTYPE)
        status = records["status"].astype(np.uint32)
        bad = status != 0
        self._stats["status_errors"] += int(bad.sum())
        if bad.any():
            self._stats["status_bits"] |= int(np.bitwise_or.reduce(status[bad]))
        for name in ("rdt_sequence", "ft_sequence"):
            self._extra[name].append(records[name].astype(np.uint32))
        self._extra["status"].append(status)
        counts = records["counts"].astype(np.float64)
        wrench = np.empty_like(counts)
        wrench[:, :3] = counts[:, :3] / src.counts_per_force
        wrench[:, 3:] = counts[:, 3:] / src.counts_per_torque
        time = np.asarray(offsets, dtype=np.float64) / src.rate_hz
        return {"time": time, "wrench": wrench}
