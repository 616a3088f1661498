"""A small asyncio ground station built on pymavlink's codec, for tests and benchmarks.

It listens on a UDP port (where the vehicle's ``links.udp_targets`` send), answers to the
address packets come from, and can drop a fraction of packets in both directions to test
the protocols under loss.
"""

from __future__ import annotations

import asyncio
import random
import socket
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from companion.link.dialect import mav, new_codec

FIRST_PICKED_PORT = 20000
"""Ports for :func:`free_port` are picked from here up to the kernel's ephemeral range."""


def _ephemeral_low() -> int:
    """The first port the kernel hands out by itself (Linux ``ip_local_port_range``; 32768 else)."""
    try:
        return int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A loopback port that is free for ``kind`` now, for a process started next to bind.  Picked
    below the kernel's ephemeral range: a port from that range (what ``bind(0)`` gives) can be
    handed to another socket's outgoing connection before that process binds it, and the test
    then finds its port taken ("address already in use")."""
    low = _ephemeral_low()
    rng = random.SystemRandom()
    for _ in range(200):
        port = rng.randrange(FIRST_PICKED_PORT, low) if low > FIRST_PICKED_PORT + 100 else 0
        with socket.socket(socket.AF_INET, kind) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return int(s.getsockname()[1])
    raise OSError("no free loopback port found")


class _Proto(asyncio.DatagramProtocol):
    def __init__(self, gcs: AsyncGcs) -> None:
        self.gcs = gcs

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.gcs._datagram(data, addr)


class AsyncGcs:
    """Ground station (system 255, component 190) on a UDP port."""

    def __init__(self, port: int, *, loss: float = 0.0, seed: int = 1, system_id: int = 255,
                 component_id: int = 190) -> None:
        self.port = port
        self.loss = loss
        self.rng = random.Random(seed)
        self.codec = new_codec(system_id, component_id)
        self.peer: tuple[str, int] | None = None
        self.transport: asyncio.DatagramTransport | None = None
        self.received: list[Any] = []
        self._waiters: list[tuple[Callable[[Any], bool], asyncio.Future[Any]]] = []
        self.dropped = 0

    async def __aenter__(self) -> AsyncGcs:
        loop = asyncio.get_running_loop()
        self.transport, _ = await loop.create_datagram_endpoint(lambda: _Proto(self),
                                                                local_addr=("127.0.0.1", self.port))
        return self

    async def __aexit__(self, *exc: object) -> None:
        if self.transport is not None:
            self.transport.close()
            await asyncio.sleep(0.01)  # let the loop release the socket

    def _datagram(self, data: bytes, addr: tuple[str, int]) -> None:
        self.peer = addr
        for msg in self.codec.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                continue
            if self.loss and self.rng.random() < self.loss:
                self.dropped += 1
                continue
            self.received.append(msg)
            for cond, fut in list(self._waiters):
                if not fut.done() and cond(msg):
                    fut.set_result(msg)
                    self._waiters.remove((cond, fut))

    def send(self, msg: Any) -> None:
        """Encode and send to the vehicle (possibly dropped when ``loss`` > 0)."""
        frame = msg.pack(self.codec)
        self.codec.seq = (self.codec.seq + 1) % 256
        self.send_raw(frame, lossy=True)

    def send_raw(self, data: bytes, *, lossy: bool = False) -> None:
        if lossy and self.loss and self.rng.random() < self.loss:
            self.dropped += 1
            return
        assert self.transport is not None and self.peer is not None, "vehicle not heard yet"
        self.transport.sendto(data, self.peer)

    async def wait(self, msg_type: str | tuple[str, ...], cond: Callable[[Any], bool] | None = None,
                   timeout_s: float = 3.0) -> Any:
        """Wait for the next message of a type (and condition) received from now on."""
        types = (msg_type,) if isinstance(msg_type, str) else msg_type

        def match(m: Any) -> bool:
            return m.get_type() in types and (cond is None or cond(m))

        fut: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self._waiters.append((match, fut))
        try:
            return await asyncio.wait_for(fut, timeout_s)
        finally:
            if (match, fut) in self._waiters:
                self._waiters.remove((match, fut))

    async def connect(self, timeout_s: float = 3.0) -> Any:
        hb = await self.wait("HEARTBEAT", timeout_s=timeout_s)
        self.heartbeat()
        return hb

    def heartbeat(self) -> None:
        self.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))

    async def command(self, command: int, *params: float, timeout_s: float = 3.0, as_int: bool = False,
                      frame: int = 0, retries: int = 0) -> Any:
        """Send COMMAND_LONG (or COMMAND_INT) and return its final COMMAND_ACK."""
        p = list(params) + [0.0] * (7 - len(params))
        for attempt in range(retries + 1):
            if as_int:
                msg = mav.MAVLink_command_int_message(1, 1, frame, command, 0, 0, *p[:4], int(p[4]),
                                                      int(p[5]), p[6])
            else:
                msg = mav.MAVLink_command_long_message(1, 1, command, attempt, *p)
            fut = asyncio.ensure_future(self.wait(
                "COMMAND_ACK", lambda m: m.command == command and m.result != mav.MAV_RESULT_IN_PROGRESS,
                timeout_s))
            await asyncio.sleep(0)
            self.send(msg)
            try:
                return await fut
            except TimeoutError:
                if attempt == retries:
                    raise
        raise AssertionError("unreachable")

    def count(self, msg_type: str, since: int = 0) -> int:
        return sum(1 for m in self.received[since:] if m.get_type() == msg_type)


def wall_s() -> float:
    return time.monotonic()
