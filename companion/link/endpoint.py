"""One MAVLink link: a codec with its own sequence numbers, stream rates and telemetry log.

A :class:`Link` does not know its transport: the transport gives it a ``write(bytes)``
function and feeds it received bytes with :meth:`Link.feed`.  Decoded messages addressed to
this vehicle (target system 0 or ours, target component 0 or ours) and admitted by the link's
:class:`~companion.link.signing.LinkSecurity` (signing, allowed ground stations) go to the
:class:`Dispatcher`, which calls the handlers registered for the message type.  Nothing a
peer sends can raise out of :meth:`Link.feed`.
"""

from __future__ import annotations

import contextlib
import logging
from collections import defaultdict
from collections.abc import Callable
from typing import Any

from companion.clock import Clock, WallClock
from companion.link.dialect import mav
from companion.link.gcs_presence import GcsPresence
from companion.link.signing import LinkSecurity, Verdict, new_link_codec
from companion.link.streams import StreamRates
from companion.link.tlog import TlogWriter

log = logging.getLogger(__name__)

MAV_TYPE_GCS = mav.MAV_TYPE_GCS
_MIN_FRAME = 8  # pymavlink's HEADER_LEN_V1 + 2: what the parser expects before it has a header

Handler = Callable[["Link", Any], None]
SIGNATURE_REFUSED = "Invalid signature"
"""pymavlink's reason for a frame its ``allow_unsigned_callback`` refused."""


class Dispatcher:
    """Message type name -> handlers; every handler failure is contained and logged."""

    def __init__(self) -> None:
        self._handlers: dict[str, list[Handler]] = defaultdict(list)
        self._any: list[Handler] = []
        self.errors = 0

    def on(self, msg_type: str, handler: Handler) -> None:
        """Call ``handler(link, msg)`` for every received message of type ``msg_type`` ("*" = all)."""
        if msg_type == "*":
            self._any.append(handler)
        else:
            self._handlers[msg_type].append(handler)

    def handles(self, msg_type: str) -> bool:
        """Some handler acts on ``msg_type`` (not counting the catch-all ones)."""
        return bool(self._handlers.get(msg_type))

    def dispatch(self, link: Link, msg: Any) -> None:
        for handler in (*self._any, *self._handlers.get(msg.get_type(), ())):
            try:
                handler(link, msg)
            except Exception:
                self.errors += 1
                log.exception("handler %s failed on %s from %s", handler, msg.get_type(), link.name)


class Link:
    """One MAVLink connection (a UDP peer, a TCP client, a serial radio)."""

    def __init__(self, name: str, write: Callable[[bytes], None], *, clock: Clock, dispatcher: Dispatcher,
                 system_id: int = 1, component_id: int = 1, tlog: TlogWriter | None = None,
                 rates: StreamRates | None = None, wall: Clock | None = None,
                 security: LinkSecurity | None = None) -> None:
        self.name = name
        self._write = write
        self.clock = clock
        self.dispatcher = dispatcher
        self.system_id = system_id
        self.component_id = component_id
        self.codec = new_link_codec(system_id, component_id)
        self.security = security
        self.rx_dropped = 0
        """Frames refused by the signing policy (unsigned, wrong key, replayed)."""
        self.tlog = tlog
        self.rates = rates if rates is not None else StreamRates()
        self.closed = False
        self.rx_frames = 0
        self.tx_frames = 0
        self.rx_errors = 0
        self.last_rx_s: float | None = None
        self.gcs = GcsPresence(clock, wall if wall is not None else WallClock())
        """The ground station's heartbeats on this link (GCS failsafe, :mod:`.gcs_presence`)."""
        self.peer: tuple[int, int] | None = None
        if security is not None:
            security.attach(self)

    # -- sending -------------------------------------------------------------------------
    def send(self, msg: Any) -> None:
        """Encode ``msg`` with this link's sequence number and write it (errors are logged)."""
        if self.closed:
            return
        try:
            frame = msg.pack(self.codec)
        except Exception:
            log.exception("cannot encode %s", msg.get_type())
            return
        self.codec.seq = (self.codec.seq + 1) % 256
        self.send_frame(frame)

    def send_frame(self, frame: bytes) -> None:
        if self.closed:
            return
        try:
            self._write(frame)
        except Exception as exc:  # transport errors never reach the caller
            log.debug("%s: write failed: %s", self.name, exc)
            return
        self.tx_frames += 1
        if self.tlog is not None:
            self.tlog.write(self.clock_unix_s(), frame)

    def clock_unix_s(self) -> float:
        return self.clock.unix_time_s()

    # -- receiving -----------------------------------------------------------------------
    def feed(self, data: bytes, *, datagram: bool = False) -> None:
        """Parse received bytes and dispatch every complete message.

        ``datagram``: the bytes are one UDP datagram, which holds whole frames only, so a
        partial frame left by earlier garbage is discarded first.  On byte streams a frame
        with a bad checksum is re-scanned from its second byte (resynchronisation), so a
        corrupted length byte cannot swallow the good frames that follow it.
        """
        if datagram:
            self._reset_parser()
        try:
            msgs = self._parse(data)
        except Exception as exc:
            self.rx_errors += 1
            log.debug("%s: parse error %s", self.name, exc)
            msgs = []
            self._reset_parser()
        for msg in msgs:
            self.rx_frames += 1
            if self.tlog is not None:
                with contextlib.suppress(Exception):
                    self.tlog.write(self.clock_unix_s(), bytes(msg.get_msgbuf()), received=True)
            self._receive(msg)

    def _reset_parser(self) -> None:
        codec = self.codec
        if codec.buf_len() or codec.buf_index:
            codec.buf = bytearray()
            codec.buf_index = 0
            codec.expected_length = _MIN_FRAME

    def _parse(self, data: bytes) -> list[Any]:
        codec = self.codec
        out: list[Any] = []
        msg = codec.parse_char(data)
        while msg is not None:
            if msg.get_type() == "BAD_DATA" and msg.reason == SIGNATURE_REFUSED:
                self.rx_dropped += 1  # a whole, well-formed frame the signing policy refused
                if self.security is not None:
                    self.security.dropped_frame(self, bytes(msg.data))
            elif msg.get_type() == "BAD_DATA":
                self.rx_errors += 1
                bad = bytes(msg.data)
                if len(bad) > 1 and msg.reason != "Bad prefix":
                    codec.buf = bytearray(bad[1:]) + codec.buf[codec.buf_index:]
                    codec.buf_index = 0
                    codec.expected_length = _MIN_FRAME
            else:
                out.append(msg)
            msg = codec.parse_char(b"")
        return out

    def _receive(self, msg: Any) -> None:
        now_s = self.clock.now_s()
        self.last_rx_s = now_s
        # With signing required only signed frames show the ground station is there (GCS failsafe).
        authentic = self.security is None or self.security.authentic(msg)
        if msg.get_type() == "HEARTBEAT" and getattr(msg, "type", None) == MAV_TYPE_GCS and authentic:
            self.gcs.heard(heartbeat=True)
            self.peer = (msg.get_srcSystem(), msg.get_srcComponent())
        elif authentic and self.peer == (msg.get_srcSystem(), msg.get_srcComponent()):
            self.gcs.heard(heartbeat=False)  # a command or request from the ground station: it is there
        target_system = getattr(msg, "target_system", 0)
        if target_system not in (0, self.system_id):
            return
        target_component = getattr(msg, "target_component", 0)
        if target_component not in (0, self.component_id):
            return
        if self.security is not None:
            verdict = self.security.admit(self, msg)
            if verdict is Verdict.DROP:
                self.rx_dropped += 1
            if verdict is not Verdict.ACCEPT:
                return
        self.dispatcher.dispatch(self, msg)

    def close(self) -> None:
        self.closed = True
        if self.security is not None:
            self.security.detach(self)
        if self.tlog is not None:
            self.tlog.close()

    def __repr__(self) -> str:
        return f"<Link {self.name}>"
