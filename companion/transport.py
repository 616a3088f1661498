"""Byte-stream transports between the companion and its hardware (or the simulator).

Every transport is push-based: :meth:`ByteLink.set_receiver` installs a callback that gets
each chunk of received bytes; :meth:`ByteLink.write` sends bytes without blocking.

* :func:`memory_pipe`: two connected in-memory ends; a write is delivered to the peer's
  receiver synchronously (the lockstep fast path: one simulator step runs the parser,
  the control loop and the servo answer without an event-loop switch).
* :class:`SerialLink`: a serial device or pseudo-terminal through pyserial, read with
  ``loop.add_reader``; when the device vanishes (pyserial raises ``SerialException`` once
  the pty peer closes) the link closes, waits ``retry_s`` of clock time and reopens.
* :class:`UdpLink`: datagrams on loopback/LAN; replies go to the last sender unless a
  fixed remote is given.

:func:`open_link` builds one from a config string: ``/dev/ttyUSB0[:baud]`` or
``udp:HOST:PORT`` (listen) or ``udpout:HOST:PORT`` (send to).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from companion.clock import Clock
from companion.config import ConfigError

log = logging.getLogger(__name__)

Receiver = Callable[[bytes], None]


@dataclass(slots=True)
class LinkStats:
    bytes_in: int = 0
    bytes_out: int = 0
    write_errors: int = 0
    reconnects: int = 0


class ByteLink(Protocol):
    name: str
    stats: LinkStats

    def set_receiver(self, receiver: Receiver) -> None: ...

    def write(self, data: bytes) -> None: ...

    async def open(self) -> None: ...

    async def close(self) -> None: ...


class MemoryEnd:
    """One end of an in-memory pipe; bytes written before the peer has a receiver are kept."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.stats = LinkStats()
        self.peer: MemoryEnd | None = None
        self._receiver: Receiver | None = None
        self._pending: list[bytes] = []

    def set_receiver(self, receiver: Receiver) -> None:
        self._receiver = receiver
        pending, self._pending = self._pending, []
        for chunk in pending:
            receiver(chunk)

    def _deliver(self, data: bytes) -> None:
        self.stats.bytes_in += len(data)
        if self._receiver is None:
            self._pending.append(data)
        else:
            self._receiver(data)

    def write(self, data: bytes) -> None:
        self.stats.bytes_out += len(data)
        if self.peer is not None:
            self.peer._deliver(data)

    async def open(self) -> None:
        return None

    async def close(self) -> None:
        self._receiver = None


def memory_pipe(name_a: str = "a", name_b: str = "b") -> tuple[MemoryEnd, MemoryEnd]:
    """Two connected ends: what one writes, the other receives (synchronously)."""
    a, b = MemoryEnd(name_a), MemoryEnd(name_b)
    a.peer, b.peer = b, a
    return a, b


class SerialLink:
    """A serial port or pty via pyserial, non-blocking, reconnecting when it vanishes."""

    def __init__(self, device: str, baud: int, clock: Clock, retry_s: float = 1.0) -> None:
        self.name = f"serial:{device}"
        self.device, self.baud, self.clock, self.retry_s = device, baud, clock, retry_s
        self.stats = LinkStats()
        self._receiver: Receiver | None = None
        self._ser: Any = None
        self._retry_task: asyncio.Task[None] | None = None
        self._closed = False

    def set_receiver(self, receiver: Receiver) -> None:
        self._receiver = receiver

    @property
    def is_open(self) -> bool:
        return self._ser is not None

    async def open(self) -> None:
        self._closed = False
        if not self._try_open():
            self._schedule_retry()

    def _try_open(self) -> bool:
        import serial

        try:
            ser = serial.Serial(self.device, self.baud, timeout=0, write_timeout=0)
        except (serial.SerialException, OSError) as exc:
            log.warning("%s: cannot open (%s); retrying", self.name, exc)
            return False
        self._ser = ser
        asyncio.get_running_loop().add_reader(ser.fileno(), self._on_readable)
        return True

    def _on_readable(self) -> None:
        import serial

        ser = self._ser
        if ser is None:
            return
        try:
            data = ser.read(max(1, ser.in_waiting))
        except (serial.SerialException, OSError) as exc:
            log.warning("%s: device vanished (%s); reconnecting", self.name, exc)
            self._drop()
            self._schedule_retry()
            return
        if data:
            self.stats.bytes_in += len(data)
            if self._receiver is not None:
                self._receiver(data)

    def write(self, data: bytes) -> None:
        import serial

        if self._ser is None:
            self.stats.write_errors += 1
            return
        try:
            self._ser.write(data)
            self.stats.bytes_out += len(data)
        except (serial.SerialException, OSError):
            self.stats.write_errors += 1

    def _drop(self) -> None:
        ser, self._ser = self._ser, None
        if ser is not None:
            with contextlib.suppress(Exception):
                asyncio.get_running_loop().remove_reader(ser.fileno())
            with contextlib.suppress(Exception):
                ser.close()

    def _schedule_retry(self) -> None:
        if self._closed or (self._retry_task is not None and not self._retry_task.done()):
            return
        self._retry_task = asyncio.get_running_loop().create_task(self._retry(), name=f"{self.name}-retry")

    async def _retry(self) -> None:
        while not self._closed and self._ser is None:
            await self.clock.sleep(self.retry_s)
            if not self._closed and self._try_open():
                self.stats.reconnects += 1

    async def close(self) -> None:
        self._closed = True
        if self._retry_task is not None:
            self._retry_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._retry_task
        self._drop()


class _UdpProtocol(asyncio.DatagramProtocol):
    def __init__(self, link: UdpLink) -> None:
        self.link = link

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.link._on_datagram(data, addr)


class UdpLink:
    """Datagram transport; listens on ``local`` and sends to ``remote`` or the last sender."""

    def __init__(self, local: tuple[str, int] | None, remote: tuple[str, int] | None) -> None:
        self.name = f"udp:{local or ''}>{remote or ''}"
        self.local, self.remote = local, remote
        self.stats = LinkStats()
        self._receiver: Receiver | None = None
        self._transport: asyncio.DatagramTransport | None = None

    def set_receiver(self, receiver: Receiver) -> None:
        self._receiver = receiver

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        transport, _ = await loop.create_datagram_endpoint(
            lambda: _UdpProtocol(self), local_addr=self.local or ("127.0.0.1", 0))
        self._transport = transport

    @property
    def local_address(self) -> tuple[str, int]:
        assert self._transport is not None
        addr = self._transport.get_extra_info("sockname")
        return (str(addr[0]), int(addr[1]))

    def _on_datagram(self, data: bytes, addr: tuple[str, int]) -> None:
        if self.remote is None or self.local is not None:
            self.remote = self.remote or addr
        self.stats.bytes_in += len(data)
        if self._receiver is not None:
            self._receiver(data)

    def write(self, data: bytes) -> None:
        if self._transport is None or self.remote is None:
            self.stats.write_errors += 1
            return
        self._transport.sendto(data, self.remote)
        self.stats.bytes_out += len(data)

    async def close(self) -> None:
        if self._transport is not None:
            self._transport.close()
            self._transport = None


def _host_port(text: str, what: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ConfigError(f"{what}: invalid address {text!r}; accepted: 'udp:HOST:PORT', "
                          "'udpout:HOST:PORT' or 'DEVICE[:BAUD]'")
    return host, int(port)


def open_link(spec: str, clock: Clock, default_baud: int = 115200, what: str = "link") -> ByteLink:
    """Build (not yet open) a link from ``DEVICE[:BAUD]``, ``udp:HOST:PORT`` or ``udpout:HOST:PORT``."""
    if spec.startswith("udp:"):
        return UdpLink(_host_port(spec[4:], what), None)
    if spec.startswith("udpout:"):
        return UdpLink(None, _host_port(spec[7:], what))
    device, sep, baud = spec.partition(":")
    if not device or (sep and not baud.isdigit()):
        raise ConfigError(f"{what}: invalid value {spec!r}; accepted: 'DEVICE[:BAUD]', 'udp:HOST:PORT' "
                          "or 'udpout:HOST:PORT'")
    return SerialLink(device, int(baud) if sep else default_baud, clock)
