"""A fake ATI Net F/T box for tests: real UDP RDT packets on 127.0.0.1.

    with FakeNetFT(script) as fake:
        source = NetFTSource(host="127.0.0.1", port=fake.port, ...)

It waits for a start request (command 2), sends the scripted records to the
requester, then keeps the socket open until it receives the stop request
(command 0) or is closed. ``script`` is a list of ``(rdt_sequence,
ft_sequence, status, counts)`` tuples or raw ``bytes`` (malformed packets);
``pace_hz`` paces the sending (in blocks of 10 packets) instead of sending as
fast as possible.
"""

from __future__ import annotations

import select
import socket
import struct
import threading
import time

from contactlab.acquire.netft import rdt_record

REQUEST = struct.Struct(">HHI")


class FakeNetFT:
    def __init__(self, script, *, pace_hz: float | None = None, respond: bool = True):
        self.script = list(script)
        self.pace_hz = pace_hz
        self.respond = respond
        self.requests: list[tuple[int, int, int]] = []   # (header, command, sample_count)
        self.stopped = threading.Event()
        self.stops = 0
        self.sent = 0
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind(("127.0.0.1", 0))
        self._sock.settimeout(0.05)
        self.port = self._sock.getsockname()[1]
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> FakeNetFT:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self._closing.set()
        self._thread.join(timeout=5)
        self._sock.close()

    @property
    def commands(self) -> list[int]:
        return [command for _, command, _ in self.requests]

    def _receive(self):
        while not self._closing.is_set():
            try:
                data, peer = self._sock.recvfrom(64)
            except socket.timeout:
                continue
            except OSError:
                return None, None
            if len(data) == REQUEST.size:
                request = REQUEST.unpack(data)
                self.requests.append(request)
                return request, peer
        return None, None

    def _run(self) -> None:
        while True:
            request, peer = self._receive()
            if request is None:
                return
            if request[1] == 0:
                self._stop()
                continue
            if request[1] == 2 and self.respond:
                self._send_script(peer)

    def wait_stops(self, n: int, timeout: float = 2.0) -> bool:
        """Wait until ``n`` stop requests have arrived."""
        deadline = time.monotonic() + timeout
        while self.stops < n and time.monotonic() < deadline:
            time.sleep(0.005)
        return self.stops >= n

    def _stop(self) -> None:
        self.stops += 1
        self.stopped.set()

    def _stop_requested(self) -> bool:
        """A stop request waiting in the socket (handled like a real box: stop sending)."""
        while select.select([self._sock], [], [], 0)[0]:
            try:
                data = self._sock.recv(64)
            except OSError:
                return False
            if len(data) == REQUEST.size:
                request = REQUEST.unpack(data)
                self.requests.append(request)
                if request[1] == 0:
                    self._stop()
                    return True
        return False

    def _send_script(self, peer) -> None:
        t0 = time.monotonic()
        for i, item in enumerate(self.script):
            if self._closing.is_set() or self._stop_requested():
                return
            packet = item if isinstance(item, bytes) else rdt_record(*item)
            try:
                self._sock.sendto(packet, peer)
            except OSError:
                return
            self.sent += 1
            if self.pace_hz and (i + 1) % 10 == 0:
                # to a schedule, not a sleep per block: a late wake-up (a loaded machine)
                # is made up by the next blocks, so the box's rate stays pace_hz
                time.sleep(max(0.0, t0 + (i + 1) / self.pace_hz - time.monotonic()))
            elif i % 20 == 19:
                time.sleep(0.001)   # let the receiver drain; loopback UDP can overflow too
