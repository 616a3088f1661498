"""The one byte-transport stack: every byte link of the product, to the hardware and to ground stations.

Every transport is push-based: :meth:`ByteLink.set_receiver` installs a callback that gets
each chunk of received bytes; :meth:`ByteLink.write` sends bytes without blocking and never
raises (failures are counted in :class:`LinkStats`).

* :func:`memory_pipe`: two connected in-memory ends; a write is delivered to the peer's
  receiver synchronously (the lockstep fast path: one simulator step runs the parser,
  the control loop and the servo answer without an event-loop switch).
* :class:`SerialLink`: a serial device or pseudo-terminal through pyserial, read with
  ``loop.add_reader``; when it cannot be opened, or vanishes (pyserial raises once the pty
  peer closes or the USB adapter is unplugged), it is closed, and reopened every ``retry_s``
  of clock time.  ``on_open`` / ``on_lost`` tell the owner (the MAVLink layer starts a new
  link per connection).
* :class:`UdpLink`: datagrams; listens on ``local`` and sends to ``remote``, or to the first
  sender when no remote is given.  A link with only a remote binds an ephemeral port on
  loopback when the remote is on loopback, else on every interface.
* :class:`TcpServer`: a listening socket; every accepted client is a :class:`TcpClient` byte
  link handed to ``on_connect`` (and to ``on_disconnect`` when it leaves).

:func:`open_link` builds a hardware link from a config string: ``/dev/ttyUSB0[:BAUD]``,
``udp:HOST:PORT`` (listen) or ``udpout:HOST:PORT`` (send to); the strings are parsed by
:func:`companion.config.parse_serial` and :func:`companion.config.parse_host_port`, the one
``HOST:PORT`` parser.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from companion.clock import Clock
from companion.config import ConfigError, parse_host_port, parse_serial

log = logging.getLogger(__name__)

Receiver = Callable[[bytes], None]
Address = tuple[str, int]

TCP_MAX_BUFFER_BYTES = 256 * 1024
"""A TCP client that does not read loses writes beyond this much queued data."""


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


LinkEvent = Callable[["SerialLink"], None]


class SerialLink:
    """A serial port or pty via pyserial, non-blocking, reopened whenever it is missing."""

    def __init__(self, device: str, baud: int, clock: Clock, retry_s: float = 1.0, *,
                 on_open: LinkEvent | None = None, on_lost: LinkEvent | None = None) -> None:
        self.name = f"serial:{device}"
        self.device, self.baud, self.clock, self.retry_s = device, baud, clock, retry_s
        self.on_open, self.on_lost = on_open, on_lost
        self.stats = LinkStats()
        self.open_count = 0
        """Successful opens so far (the first one and every reconnection)."""
        self._receiver: Receiver | None = None
        self._ser: Any = None
        self._retry_task: asyncio.Task[None] | None = None
        self._closed = False
        self._warned = False

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
        except (serial.SerialException, OSError, ValueError) as exc:
            if not self._warned:  # once per outage, not on every retry
                log.warning("%s: cannot open (%s); retrying every %g s", self.name, exc, self.retry_s)
                self._warned = True
            return False
        self._warned = False
        self._ser = ser
        self.open_count += 1
        asyncio.get_running_loop().add_reader(ser.fileno(), self._on_readable)
        log.info("%s open at %d baud", self.name, self.baud)
        if self.on_open is not None:
            self.on_open(self)
        return True

    def _on_readable(self) -> None:
        import serial

        ser = self._ser
        if ser is None:
            return
        try:
            data = ser.read(max(1, ser.in_waiting))
        except (serial.SerialException, OSError, TypeError) as exc:
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
            self._ser.write(data)  # a full radio buffer (write timeout 0) drops the frame
            self.stats.bytes_out += len(data)
        except (serial.SerialException, OSError):
            self.stats.write_errors += 1

    def _drop(self) -> None:
        ser, self._ser = self._ser, None
        if ser is None:
            return
        with contextlib.suppress(Exception):
            asyncio.get_running_loop().remove_reader(ser.fileno())
        with contextlib.suppress(Exception):
            ser.close()
        if self.on_lost is not None:
            self.on_lost(self)

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

    def datagram_received(self, data: bytes, addr: Address) -> None:
        self.link._on_datagram(data, addr)

    def error_received(self, exc: Exception) -> None:
        # ICMP port unreachable while nobody listens yet: normal for a ground station not started.
        log.debug("%s: %s", self.link.name, exc)


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class UdpLink:
    """Datagram transport; listens on ``local`` and sends to ``remote`` or the first sender."""

    def __init__(self, local: Address | None, remote: Address | None) -> None:
        self.name = f"udp:{local or ''}>{remote or ''}"
        self.local, self.remote = local, remote
        self.stats = LinkStats()
        self._receiver: Receiver | None = None
        self._transport: asyncio.DatagramTransport | None = None

    def set_receiver(self, receiver: Receiver) -> None:
        self._receiver = receiver

    async def open(self) -> None:
        local = self.local
        if local is None:
            local = ("127.0.0.1" if self.remote is None or _is_loopback(self.remote[0]) else "0.0.0.0", 0)
        loop = asyncio.get_running_loop()
        transport, _ = await loop.create_datagram_endpoint(lambda: _UdpProtocol(self), local_addr=local)
        self._transport = transport

    @property
    def local_address(self) -> Address:
        assert self._transport is not None
        addr = self._transport.get_extra_info("sockname")
        return (str(addr[0]), int(addr[1]))

    def _on_datagram(self, data: bytes, addr: Address) -> None:
        if self.remote is None:
            self.remote = addr
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


class TcpClient:
    """One accepted TCP connection as a byte link; a client that does not read loses writes."""

    def __init__(self, name: str, writer: asyncio.StreamWriter, max_buffer_bytes: int) -> None:
        self.name = name
        self.stats = LinkStats()
        self._writer = writer
        self._max_buffer_bytes = max_buffer_bytes
        self._receiver: Receiver | None = None

    def set_receiver(self, receiver: Receiver) -> None:
        self._receiver = receiver

    def _deliver(self, data: bytes) -> None:
        self.stats.bytes_in += len(data)
        if self._receiver is not None:
            self._receiver(data)

    def write(self, data: bytes) -> None:
        writer = self._writer
        if writer.is_closing() or writer.transport.get_write_buffer_size() > self._max_buffer_bytes:
            self.stats.write_errors += 1  # closed, or a slow reader: drop instead of queueing without bound
            return
        writer.write(data)
        self.stats.bytes_out += len(data)

    async def open(self) -> None:
        return None

    async def close(self) -> None:
        self._writer.close()
        with contextlib.suppress(Exception):
            await self._writer.wait_closed()


ClientEvent = Callable[[TcpClient], None]


class TcpServer:
    """A TCP server; each accepted client becomes a :class:`TcpClient` until it leaves."""

    def __init__(self, local: Address, on_connect: ClientEvent, on_disconnect: ClientEvent, *,
                 max_buffer_bytes: int = TCP_MAX_BUFFER_BYTES) -> None:
        self.name = f"tcp:{local[0]}:{local[1]}"
        self.local = local
        self.on_connect, self.on_disconnect = on_connect, on_disconnect
        self.max_buffer_bytes = max_buffer_bytes
        self._server: asyncio.Server | None = None
        self._tasks: set[asyncio.Task[None]] = set()

    async def open(self) -> None:
        self._server = await asyncio.start_server(self._client, self.local[0], self.local[1])

    @property
    def port(self) -> int:
        assert self._server is not None
        return int(self._server.sockets[0].getsockname()[1])

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
        peer = writer.get_extra_info("peername")
        client = TcpClient(f"tcp:{peer[0]}:{peer[1]}" if peer else "tcp:?", writer, self.max_buffer_bytes)
        self.on_connect(client)
        log.info("TCP client connected: %s", client.name)
        try:
            while data := await reader.read(4096):
                client._deliver(data)
        except (ConnectionError, OSError) as exc:
            log.info("TCP client %s: %s", client.name, exc)
        finally:
            self.on_disconnect(client)
            await client.close()
            log.info("TCP client left: %s", client.name)
            if task is not None:
                self._tasks.discard(task)

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        if self._server is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._server.wait_closed(), 1.0)


def open_link(spec: str, clock: Clock, default_baud: int = 115200, what: str = "link") -> ByteLink:
    """Build (not yet open) a link from ``DEVICE[:BAUD]``, ``udp:HOST:PORT`` or ``udpout:HOST:PORT``."""
    accepted = "accepted: 'DEVICE[:BAUD]', 'udp:HOST:PORT' or 'udpout:HOST:PORT'"
    for prefix in ("udp:", "udpout:"):
        if spec.startswith(prefix):
            try:
                address = parse_host_port(spec[len(prefix):])
            except ValueError as exc:
                raise ConfigError(f"{what}: invalid address {spec!r} ({exc}); {accepted}") from None
            return UdpLink(address, None) if prefix == "udp:" else UdpLink(None, address)
    try:
        device, baud = parse_serial(spec, default_baud)
    except ValueError as exc:
        raise ConfigError(f"{what}: invalid value {spec!r} ({exc}); {accepted}") from None
    return SerialLink(device, baud, clock)
