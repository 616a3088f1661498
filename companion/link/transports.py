"""Transports that carry MAVLink bytes: UDP to a ground station, a TCP server, serial radios.

Each transport creates :class:`~companion.link.endpoint.Link` objects through the
``make_link(name, write)`` factory it is given and feeds them received bytes.

* :class:`UdpTarget` sends to a fixed ``host:port`` (where QGroundControl or a MAVSDK
  script listens) from an ephemeral local port and accepts replies from anyone.
* :class:`TcpServer` listens (MAVProxy ``--master=tcp:...``); every client is its own link
  with its own stream rates, removed when the client leaves.
* :class:`SerialPort` opens a radio with pyserial; when the device vanishes or errors it is
  closed and retried every :data:`SERIAL_RETRY_S` seconds, never fatal.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable

from companion.clock import Clock
from companion.link.endpoint import Link

log = logging.getLogger(__name__)

MakeLink = Callable[[str, Callable[[bytes], None]], Link]
DropLink = Callable[[Link], None]

SERIAL_RETRY_S = 2.0
TCP_MAX_BUFFER_BYTES = 256 * 1024
"""A TCP client that does not read loses frames beyond this much queued data."""


def split_host_port(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    return host, int(port)


class _UdpProtocol(asyncio.DatagramProtocol):
    def __init__(self, on_data: Callable[[bytes, tuple[str, int]], None]) -> None:
        self.on_data = on_data

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.on_data(data, addr)

    def error_received(self, exc: Exception) -> None:
        # ICMP port unreachable while nobody listens yet: normal for a ground station not started.
        log.debug("udp error: %s", exc)


class UdpTarget:
    """Send to one UDP address; replies from the peer come back on the same socket."""

    def __init__(self, target: str, make_link: MakeLink) -> None:
        self.target = split_host_port(target)
        self.make_link = make_link
        self.link: Link | None = None
        self._transport: asyncio.DatagramTransport | None = None

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        host = self.target[0]
        local = "127.0.0.1" if host in ("127.0.0.1", "localhost") else "0.0.0.0"
        transport, _ = await loop.create_datagram_endpoint(
            lambda: _UdpProtocol(self._on_data), local_addr=(local, 0))
        self._transport = transport

        def write(frame: bytes) -> None:
            transport.sendto(frame, self.target)

        self.link = self.make_link(f"udp:{self.target[0]}:{self.target[1]}", write)

    def _on_data(self, data: bytes, addr: tuple[str, int]) -> None:
        if self.link is not None:
            self.link.feed(data, datagram=True)

    @property
    def local_port(self) -> int:
        assert self._transport is not None
        return int(self._transport.get_extra_info("sockname")[1])

    async def stop(self) -> None:
        if self._transport is not None:
            self._transport.close()
        if self.link is not None:
            self.link.close()


class TcpServer:
    """A TCP server; each accepted client becomes a link."""

    def __init__(self, listen: str, make_link: MakeLink, drop_link: DropLink) -> None:
        self.listen = split_host_port(listen)
        self.make_link = make_link
        self.drop_link = drop_link
        self._server: asyncio.Server | None = None
        self._tasks: set[asyncio.Task[None]] = set()

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._client, self.listen[0], self.listen[1])

    @property
    def port(self) -> int:
        assert self._server is not None
        return int(self._server.sockets[0].getsockname()[1])

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        if task is not None:
            self._tasks.add(task)
        peer = writer.get_extra_info("peername")
        name = f"tcp:{peer[0]}:{peer[1]}" if peer else "tcp:?"

        def write(frame: bytes) -> None:
            if writer.is_closing():
                raise ConnectionError("closed")
            if writer.transport.get_write_buffer_size() > TCP_MAX_BUFFER_BYTES:
                return  # slow reader: drop instead of growing without bound
            writer.write(frame)

        link = self.make_link(name, write)
        log.info("TCP client connected: %s", name)
        try:
            while True:
                data = await reader.read(4096)
                if not data:
                    break
                link.feed(data)
        except (ConnectionError, OSError) as exc:
            log.info("TCP client %s: %s", name, exc)
        finally:
            self.drop_link(link)
            link.close()
            writer.close()
            with contextlib.suppress(Exception):
                await writer.wait_closed()
            log.info("TCP client left: %s", name)
            if task is not None:
                self._tasks.discard(task)

    async def stop(self) -> None:
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


class SerialPort:
    """A serial radio (pyserial); reopened after errors, never fatal."""

    def __init__(self, spec: str, make_link: MakeLink, drop_link: DropLink, clock: Clock) -> None:
        device, _, baud = spec.partition(":")
        self.device = device
        self.baud = int(baud) if baud else 57600
        self.make_link = make_link
        self.drop_link = drop_link
        self.clock = clock
        self.link: Link | None = None
        self.open_count = 0
        self._serial: object | None = None

    async def start(self) -> None:
        return None

    async def run(self) -> None:
        """Open, read until an error, close, wait, retry (forever)."""
        import serial  # pyserial

        loop = asyncio.get_running_loop()
        warned = False
        while True:
            try:
                port = serial.Serial(self.device, self.baud, timeout=0, write_timeout=0)
            except (serial.SerialException, OSError, ValueError) as exc:
                if not warned:
                    log.warning("serial %s not available (%s); retrying every %g s", self.device, exc,
                                SERIAL_RETRY_S)
                    warned = True
                await self.clock.sleep(SERIAL_RETRY_S)
                continue
            warned = False
            self.open_count += 1
            self._serial = port
            lost = asyncio.Event()

            def write(frame: bytes, port: serial.Serial = port) -> None:
                with contextlib.suppress(serial.SerialTimeoutException):  # radio buffer full: drop it
                    port.write(frame)

            def readable(port: serial.Serial = port, lost: asyncio.Event = lost) -> None:
                try:
                    data = port.read(4096)
                except (serial.SerialException, OSError, TypeError) as exc:
                    log.warning("serial %s lost: %s", self.device, exc)
                    lost.set()
                    return
                if data and self.link is not None:
                    self.link.feed(data)

            self.link = self.make_link(f"serial:{self.device}", write)
            log.info("serial %s open at %d baud", self.device, self.baud)
            try:
                loop.add_reader(port.fileno(), readable)
                await lost.wait()
            finally:
                with contextlib.suppress(Exception):
                    loop.remove_reader(port.fileno())
                with contextlib.suppress(Exception):
                    port.close()
                self.drop_link(self.link)
                self.link.close()
                self.link = None
                self._serial = None
            await self.clock.sleep(SERIAL_RETRY_S)

    async def stop(self) -> None:
        return None
