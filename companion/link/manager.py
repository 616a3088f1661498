"""The link service: opens every configured transport and keeps the list of live links.

Configuration (``[links]``): ``udp_targets`` (QGroundControl 14550, MAVSDK 14540 by default),
``tcp_listen`` (5760), ``serial`` (radios) and ``tlog`` (one .tlog per link in
``<state_dir>/logs``, rotated and capped by :class:`~companion.link.tlog.TlogDirectory`).
The byte transports are :mod:`companion.transport`'s: a
:class:`~companion.transport.UdpLink` per target (sending to it from an ephemeral port and
accepting replies from anyone), a :class:`~companion.transport.TcpServer` whose every client
is a link of its own (removed when the client leaves), and a
:class:`~companion.transport.SerialLink` per radio (a new link per connection; a vanished
port is retried every :data:`SERIAL_RETRY_S` seconds, never fatal, and found again at the same
path, e.g. a ``/dev/serial/by-id`` symlink after the USB radio re-enumerates; the loss and the
return are logged and told by STATUSTEXT on every link).  Other services register
message handlers on :attr:`LinkManager.dispatcher` and send with :meth:`LinkManager.broadcast`
or a link's own ``send``.  Every link starts with the same telemetry rates: the vehicle's
(:data:`~companion.link.streams.DEFAULT_RATES_HZ`) plus the payloads' status messages
(``extra_streams``).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import re
import time
from collections.abc import Callable
from typing import Any

from companion.app import BaseService, Context
from companion.clock import WallClock
from companion.config import parse_host_port, parse_serial
from companion.link import streams
from companion.link.endpoint import Dispatcher, Link
from companion.link.gcs_presence import Silence
from companion.link.signing import LinkSecurity
from companion.link.tlog import MB, TlogDirectory
from companion.messages import STATUS_TEXT_TOPIC, Severity, StatusText
from companion.transport import ByteLink, SerialLink, TcpServer, UdpLink

log = logging.getLogger(__name__)

TLOG_FLUSH_S = 1.0
SERIAL_RETRY_S = 2.0
"""A radio that cannot be opened (or vanished) is tried again this often (vehicle clock)."""
SERIAL_DEFAULT_BAUD = 57600


class LinkManager(BaseService):
    """Owns the transports and links of the vehicle (service ``mavlink-links``)."""

    name = "mavlink-links"

    def __init__(self, ctx: Context, *, system_id: int | None = None, component_id: int = 1,
                 extra_streams: dict[int, tuple[float, int]] | None = None) -> None:
        """``extra_streams``: message id -> (default rate Hz, REQUEST_DATA_STREAM group)."""
        self.ctx = ctx
        self.stream_rates_hz = dict(streams.DEFAULT_RATES_HZ)
        self.stream_groups = {group: tuple(ids) for group, ids in streams.DATA_STREAM_GROUPS.items()}
        for msg_id, (rate_hz, group) in (extra_streams or {}).items():
            self.stream_rates_hz[msg_id] = rate_hz
            self.stream_groups[group] = (*self.stream_groups.get(group, ()), msg_id)
        self.system_id = int(system_id if system_id is not None else ctx.params.get("SYSID_THISMAV"))
        self.component_id = component_id
        self.dispatcher = Dispatcher()
        self.security = LinkSecurity.from_config(ctx.config, now_s=ctx.clock.now_s, announce=self._announce)
        """MAVLink signing and the ground stations allowed to change state (``[security]``)."""
        self.dispatcher.on("SETUP_SIGNING", self._on_setup_signing)
        self.links: list[Link] = []
        self.udp: list[UdpLink] = []
        self.tcp: TcpServer | None = None
        self.serial: list[SerialLink] = []
        self._link_of: dict[ByteLink, Link] = {}
        self.wall = WallClock()
        """The wall clock next to ``ctx.clock``: ground stations pace their heartbeats by it."""
        self.tlogs: TlogDirectory | None = None
        """The bounded .tlog directory (``None``: links.tlog is off)."""
        self.unavailable: dict[str, str] = {}
        """Configured endpoints that could not be opened -> why (the ready banner says so)."""
        self._session = time.strftime("%Y%m%d-%H%M%S", time.gmtime(ctx.clock.unix_time_s()))

    # -- links ----------------------------------------------------------------------------
    def make_link(self, name: str, write: Callable[[bytes], None]) -> Link:
        tlog = None
        if self.tlogs is not None:
            safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name)
            tlog = self.tlogs.writer(f"{self._session}-{safe}")
        link = Link(name, write, clock=self.ctx.clock, dispatcher=self.dispatcher, system_id=self.system_id,
                    component_id=self.component_id, tlog=tlog, wall=self.wall, security=self.security,
                    rates=streams.StreamRates(self.stream_rates_hz, self.stream_groups))
        self.links.append(link)
        return link

    def drop_link(self, link: Link) -> None:
        if link in self.links:
            self.links.remove(link)

    def _attach(self, transport: ByteLink, name: str, *, datagram: bool = False) -> None:
        """A MAVLink link over ``transport`` (one UDP datagram holds whole frames only)."""
        link = self.make_link(name, transport.write)
        transport.set_receiver(functools.partial(link.feed, datagram=True) if datagram else link.feed)
        self._link_of[transport] = link

    def _detach(self, transport: ByteLink) -> None:
        link = self._link_of.pop(transport, None)
        if link is not None:
            self.drop_link(link)
            link.close()

    def _serial_opened(self, port: SerialLink) -> None:
        self._attach(port, port.name)
        if port.open_count > 1:  # it had vanished (USB radio unplugged, re-enumerated): say it is back
            log.warning("%s reconnected (open #%d)", port.name, port.open_count)
            self._announce(f"Radio {port.device} reconnected", Severity.NOTICE)

    def _serial_lost(self, port: SerialLink) -> None:
        self._detach(port)
        log.warning("%s NOT OPEN (device gone); retrying every %g s", port.name, port.retry_s)
        self._announce(f"Radio {port.device} lost: NOT OPEN, retrying")

    def _announce(self, text: str, severity: Severity = Severity.WARNING) -> None:
        self.ctx.bus.topic(STATUS_TEXT_TOPIC).publish(StatusText(self.ctx.clock.now_s(), severity, text))

    def _on_setup_signing(self, link: Link, msg: Any) -> None:
        """SETUP_SIGNING (a message without an ACK): the outcome is told by STATUSTEXT."""
        refusal = self.security.setup_signing(link, msg)
        if refusal is not None:
            self._announce(refusal)
        else:
            state = "set" if self.security.key is not None else "disabled"
            self._announce(f"Signing key {state} by SETUP_SIGNING on {link.name}", Severity.NOTICE)

    def broadcast(self, msg: Any) -> None:
        """Send one message on every link (each with its own sequence number)."""
        for link in tuple(self.links):
            link.send(msg)

    def gcs_heartbeat_age_s(self) -> float | None:
        """Seconds (vehicle clock) since the last GCS heartbeat on any link (``None``: never heard)."""
        silences = self.gcs_silences()
        return min(s.vehicle_s for s in silences) if silences else None

    def gcs_silences(self) -> list[Silence]:
        """The silence of the ground station on every link that has heard one."""
        return [s for s in (link.gcs.silence() for link in self.links) if s is not None]

    def gcs_lost(self, timeout_s: float) -> bool:
        """Every ground station heard so far is silent for ``timeout_s`` (:mod:`.gcs_presence`'s
        rule: vehicle time, and wall time for stations pacing heartbeats by the wall clock)."""
        silences = self.gcs_silences()
        return bool(silences) and all(s.exceeds(timeout_s) for s in silences)

    # -- life cycle -----------------------------------------------------------------------
    async def start(self) -> None:
        cfg = self.ctx.config
        if cfg["links.tlog"]:
            params = self.ctx.params
            self.tlogs = TlogDirectory(cfg.state_dir() / "logs",
                                       max_total_bytes=lambda: params.get_or("USV_TLOG_MAX_MB", 500.0) * MB,
                                       file_bytes=lambda: params.get_or("USV_TLOG_FILE_MB", 50.0) * MB,
                                       max_files=int(cfg["links.tlog_max_files"]))
            self.tlogs.enforce()  # logs of earlier runs count too
        for target in cfg["links.udp_targets"]:
            host, port = parse_host_port(target)
            udp = UdpLink(None, (host, port))
            await udp.open()
            self._attach(udp, f"udp:{host}:{port}", datagram=True)
            self.udp.append(udp)
        if cfg["links.tcp_listen"]:
            self.tcp = TcpServer(parse_host_port(cfg["links.tcp_listen"]),
                                 on_connect=lambda client: self._attach(client, client.name),
                                 on_disconnect=self._detach)
            try:
                await self.tcp.open()
            except OSError as exc:
                reason = exc.strerror or str(exc)
                log.error("TCP server %s not started: cannot bind (%s)", cfg["links.tcp_listen"], reason)
                self.unavailable[f"TCP server {cfg['links.tcp_listen']}"] = f"cannot bind: {reason}"
                self.tcp = None
        for spec in cfg["links.serial"]:
            device, baud = parse_serial(spec, SERIAL_DEFAULT_BAUD)
            radio = SerialLink(device, baud, self.ctx.clock, SERIAL_RETRY_S,
                               on_open=self._serial_opened, on_lost=self._serial_lost)
            self.serial.append(radio)
            await radio.open()

    async def run(self) -> None:
        """Flush the telemetry logs (the transports run on the event loop's readers)."""
        while True:
            await asyncio.sleep(TLOG_FLUSH_S)  # wall time: disk flushing, not vehicle behaviour
            for link in tuple(self.links):
                if link.tlog is not None:
                    link.tlog.flush()
            if self.tlogs is not None:
                self.tlogs.enforce()

    async def stop(self) -> None:
        for udp in self.udp:
            await udp.close()
        if self.tcp is not None:
            await self.tcp.close()
        for radio in self.serial:
            await radio.close()
        for link in tuple(self.links):
            with contextlib.suppress(Exception):
                link.close()
        self.links.clear()
