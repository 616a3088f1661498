"""MAVLink 2 message signing (the MAVLink signing spec) and who may change the vehicle's state.

pymavlink does the signing: every link's codec gets the secret key, its own link id, a
timestamp in the spec's units (10 µs since 2015-01-01 UTC, from the wall clock), and
``sign_outgoing`` so every frame the vehicle sends is signed once a key is set.  Received
frames are checked by the codec (:meth:`VehicleCodec.check_signature`).

Policy (:class:`LinkSecurity`), with ``[security] require_signing = true``:

* A frame that changes the vehicle's state -- any message outside :data:`READ_ONLY_MESSAGES`
  (commands, PARAM_SET, mission writes, MANUAL_CONTROL, SET_MODE, position targets, stream-rate
  requests, the dialect's payload commands) -- is accepted only with a valid signature whose
  timestamp is newer than the last one seen on that stream (link id, system, component) on
  *any* link, so a replayed frame is refused on a new TCP connection too.  Other frames are
  dropped, as the spec says (no COMMAND_ACK to a sender that could not be authenticated); for a
  message the vehicle acts on, the operator gets a STATUSTEXT at most every
  :data:`DROP_REPORT_S` per sending system and message type (other vehicles' traffic is dropped
  silently).
* Telemetry still flows to every link, signed or not: a ground station without the key sees
  the boat (position, status, the STATUSTEXT saying why its commands are dropped) and may
  read parameters and download missions (the messages in :data:`READ_ONLY_MESSAGES` and the
  commands in :data:`READ_ONLY_COMMANDS`), but cannot change anything.
* Unsigned HEARTBEATs do not count as the ground station being present, so a listener without
  the key cannot hold off the GCS failsafe.

Without ``require_signing`` a key only signs the outgoing traffic and marks valid incoming
frames as signed; unsigned stations are still obeyed.  ``[security] gcs_sysids`` (signed or
not) limits the systems that may change state; the refusal is answered as each protocol allows
(COMMAND_ACK DENIED, MISSION_ACK MAV_MISSION_DENIED, the unchanged PARAM_VALUE) with a STATUSTEXT
reason.

SETUP_SIGNING is accepted on trusted links only (``[security] trusted_links``, the serial/USB
ports by default), signed or not: physical access is the trust.  It sets the key on every link
and saves it to ``signing_key_file`` or ``<state_dir>/signing.key`` (mode 0600); an all-zero
key with timestamp 0 disables signing (refused while ``require_signing`` is on).

pymavlink's own ``check_signature`` records a stream's timestamp *before* comparing the
signature, so one frame with a wrong key and a timestamp far in the future would lock the real
ground station out (every later frame of that stream looks old).  :class:`VehicleCodec` checks
the signature first and only then the timestamp.
"""

from __future__ import annotations

import enum
import hashlib
import hmac
import logging
import os
import stat
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20 import all as _all

from companion.config import ConfigError
from companion.link.dialect import mav

if TYPE_CHECKING:
    from companion.link.endpoint import Link

log = logging.getLogger(__name__)

KEY_BYTES = 32
SIGNING_EPOCH_UNIX_S = 1_420_070_400
"""2015-01-01 00:00:00 UTC, the zero of MAVLink signing timestamps."""
TIMESTAMP_UNITS_PER_S = 100_000
"""Signing timestamps count 10 µs units."""
NEW_STREAM_WINDOW = 60 * TIMESTAMP_UNITS_PER_S
MAX_AHEAD_TIMESTAMP = 366 * 86_400 * TIMESTAMP_UNITS_PER_S
"""SETUP_SIGNING's initial_timestamp may be at most a year ahead of the vehicle's clock: the
signature carries 48 bits of timestamp, and one near that limit (the fuzzer sent 2**64 - 1)
made every outgoing frame unencodable, silencing the vehicle on every link."""
"""A stream never seen before is accepted if its timestamp is at most one minute behind ours."""
DROP_REPORT_S = 10.0
"""At most one STATUSTEXT about dropped frames per sending system and message type in this many
seconds (MAVProxy's repeated stream requests must not hide its dropped commands)."""
STATE_KEY_NAME = "signing.key"
"""Where a key set by SETUP_SIGNING is kept when no signing_key_file is configured."""

READ_ONLY_MESSAGES: frozenset[str] = frozenset({
    "HEARTBEAT", "RADIO_STATUS", "RADIO", "TIMESYNC", "SYSTEM_TIME", "PING",
    "PARAM_REQUEST_LIST", "PARAM_REQUEST_READ",
    "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK",
    "FILE_TRANSFER_PROTOCOL",  # this vehicle serves no files: every request is NAKed
})
"""Messages that change nothing on the vehicle: accepted unsigned even with signing required."""
READ_ONLY_COMMANDS: frozenset[int] = frozenset({
    mav.MAV_CMD_REQUEST_MESSAGE, mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    mav.MAV_CMD_REQUEST_PROTOCOL_VERSION, mav.MAV_CMD_GET_HOME_POSITION,
})
"""Commands that only ask for a message on the asking link."""
COMMAND_MESSAGES = frozenset({"COMMAND_LONG", "COMMAND_INT"})
MISSION_WRITES = frozenset({"MISSION_COUNT", "MISSION_ITEM", "MISSION_ITEM_INT", "MISSION_CLEAR_ALL",
                            "MISSION_WRITE_PARTIAL_LIST"})
_READ_ONLY_IDS = frozenset(cls.id for cls in _all.mavlink_map.values()
                           if cls.msgname in READ_ONLY_MESSAGES | COMMAND_MESSAGES)


def changes_state(msg: Any) -> bool:
    """Whether ``msg`` can change the vehicle (everything but reads, queries and heartbeats)."""
    name = msg.get_type()
    if name in COMMAND_MESSAGES:
        return int(msg.command) not in READ_ONLY_COMMANDS
    return name not in READ_ONLY_MESSAGES


def timestamp_now(unix_s: float | None = None) -> int:
    """The signing timestamp of ``unix_s`` (default: now on the wall clock)."""
    now = time.time() if unix_s is None else unix_s
    return int(max(0.0, now - SIGNING_EPOCH_UNIX_S) * TIMESTAMP_UNITS_PER_S)


# -- key files --------------------------------------------------------------------------------
def parse_key(text: str, source: str) -> bytes:
    """32 bytes from 64 hex characters (surrounding white space ignored)."""
    hex_text = text.strip()
    try:
        key = bytes.fromhex(hex_text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES or len(hex_text) != 2 * KEY_BYTES:
        raise ConfigError(f"{source}: a signing key is 32 bytes written as 64 hex characters")
    return key


def load_key_file(path: Path) -> bytes:
    """Read a key file; refused unless only its owner may read or write it (mode 0600 or 0400)."""
    try:
        st = path.stat()
        text = path.read_text(encoding="ascii", errors="replace")
    except OSError as exc:
        raise ConfigError(f"security.signing_key_file: cannot read {path}: {exc.strerror or exc}") from None
    mode = stat.S_IMODE(st.st_mode)
    if mode & 0o077:
        raise ConfigError(f"security.signing_key_file: {path} has mode {mode:04o}; a signing key must be "
                          f"readable by its owner only (chmod 600 {path})")
    return parse_key(text, f"security.signing_key_file {path}")


def write_key_file(path: Path, key: bytes) -> None:
    """Save a key atomically with mode 0600 (temporary file, fsync, rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.write(fd, (key.hex() + "\n").encode("ascii"))
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)


# -- the codec --------------------------------------------------------------------------------
class VehicleCodec(_all.MAVLink):
    """pymavlink's MAVLink codec with a signature check that verifies before it trusts.

    Same rules as pymavlink's :meth:`check_signature` (timestamps strictly increasing per
    stream; a new stream at most a minute behind our timestamp) but the stream's timestamp is
    only recorded, and ours advanced, for a frame whose signature is valid.
    """

    def check_signature(self, msgbuf: bytearray, srcSystem: int, srcComponent: int) -> bool:
        signing = self.signing
        key = signing.secret_key
        if key is None:
            return False
        expected = hashlib.sha256(bytes(key) + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(expected, bytes(msgbuf[-6:])):
            return False
        tlow, thigh = self.mav_sign_unpacker.unpack(msgbuf[-12:-6])
        timestamp = tlow + (thigh << 32)
        stream = (msgbuf[-13], srcSystem, srcComponent)
        last = signing.stream_timestamps.get(stream)
        if last is not None:
            if timestamp <= last:
                return False  # replayed (or reordered) frame
        elif timestamp + NEW_STREAM_WINDOW < signing.timestamp:
            return False  # a "new" stream from the past: a replay of an old session
        signing.stream_timestamps[stream] = timestamp
        signing.timestamp = max(signing.timestamp, timestamp)
        return True


def new_link_codec(system_id: int, component_id: int) -> VehicleCodec:
    """A MAVLink 2 codec for one link (robust parsing; signing set by :class:`LinkSecurity`)."""
    codec = VehicleCodec(None, srcSystem=system_id, srcComponent=component_id)
    codec.robust_parsing = True
    return codec


# -- the policy ---------------------------------------------------------------------------------
class Verdict(enum.Enum):
    ACCEPT = "accept"
    DROP = "drop"
    """Not authenticated: dropped without an answer (the spec's behaviour)."""
    DENY = "deny"
    """Authenticated but not allowed: answered with a refusal and a reason."""


Announce = Callable[[str], None]


@dataclass
class SecurityStats:
    accepted_signed: int = 0
    dropped: int = 0
    denied: int = 0
    dropped_by_type: dict[str, int] = field(default_factory=dict)


class LinkSecurity:
    """Signing keys on every link's codec and the admission policy of state-changing frames."""

    def __init__(self, *, key: bytes | None, require_signing: bool, trusted_links: list[str],
                 gcs_sysids: list[int], key_path: Path | None, now_s: Callable[[], float],
                 announce: Announce, key_is_configured: bool = False) -> None:
        if require_signing and key is None:
            raise ConfigError("security.require_signing = true needs a key: set security.signing_key_file "
                              "(or give --signing-key FILE), or set one first with SETUP_SIGNING over a "
                              "trusted link")
        self.key = key
        self.require_signing = require_signing
        self.trusted_links = tuple(trusted_links)
        self.gcs_sysids = frozenset(gcs_sysids)
        self.key_path = key_path
        self.key_is_configured = key_is_configured
        self.now_s = now_s
        self.announce = announce
        self.stats = SecurityStats()
        self.stream_timestamps: dict[tuple[int, int, int], int] = {}
        """Last timestamp per (link id, system, component), shared by every link: replay protection."""
        self._links: list[Link] = []
        self._deny_answers: dict[str, Callable[[Link, Any], None]] = {}
        self._next_link_id = 0
        self._last_report_s: dict[tuple[str, int, str], float] = {}

    @classmethod
    def from_config(cls, config: Any, *, now_s: Callable[[], float], announce: Announce) -> LinkSecurity:
        """The policy of ``[security]``; a bad key file raises :class:`ConfigError`."""
        configured = str(config["security.signing_key_file"])
        state_key = config.state_dir() / STATE_KEY_NAME
        key: bytes | None = None
        if configured:
            key_path = Path(configured).expanduser()
            key = load_key_file(key_path)
        else:
            key_path = state_key
            if state_key.exists():
                key = load_key_file(state_key)
        return cls(key=key, require_signing=bool(config["security.require_signing"]),
                   trusted_links=list(config["security.trusted_links"]),
                   gcs_sysids=list(config["security.gcs_sysids"]), key_path=key_path, now_s=now_s,
                   announce=announce, key_is_configured=bool(configured))

    def on_deny(self, msg_type: str, answer: Callable[[Link, Any], None]) -> None:
        """How the protocol of ``msg_type`` answers a refusal (e.g. PARAM_SET: the unchanged
        PARAM_VALUE); ``answer(link, msg)`` is called for every denied frame of that type."""
        self._deny_answers[msg_type] = answer

    # -- links ------------------------------------------------------------------------------
    def attach(self, link: Link) -> None:
        """Give a new link's codec the key, its own link id and the shared stream timestamps."""
        signing = link.codec.signing
        signing.link_id = self._next_link_id
        self._next_link_id = (self._next_link_id + 1) % 256
        signing.stream_timestamps = self.stream_timestamps
        signing.allow_unsigned_callback = lambda _codec, msg_id: self._allow_unsigned(link, msg_id)
        self._apply_key(link.codec)
        self._links.append(link)

    def detach(self, link: Link) -> None:
        if link in self._links:
            self._links.remove(link)

    def _apply_key(self, codec: Any) -> None:
        signing = codec.signing
        signing.secret_key = self.key
        signing.sign_outgoing = self.key is not None
        signing.timestamp = max(signing.timestamp, timestamp_now())

    def is_trusted(self, link: Link) -> bool:
        name = str(link.name)
        return any(name == entry or name.startswith(entry + ":") for entry in self.trusted_links)

    # -- admission -----------------------------------------------------------------------------
    def _allow_unsigned(self, link: Link, msg_id: int) -> bool:
        """pymavlink's ``allow_unsigned_callback``: called for an unsigned frame and for one whose
        signature or timestamp failed.  With signing required, only read-only message types
        (and commands, judged by their command id once decoded) pass; the rest is dropped."""
        if not self.require_signing or msg_id in _READ_ONLY_IDS:
            return True
        return bool(msg_id == mav.MAVLINK_MSG_ID_SETUP_SIGNING and self.is_trusted(link))

    def authentic(self, msg: Any) -> bool:
        """The frame counts as the ground station's (signed, or signing not required)."""
        return not self.require_signing or bool(msg.get_signed())

    def admit(self, link: Link, msg: Any) -> Verdict:
        """Decide on one decoded frame addressed to this vehicle (refusals are reported/answered)."""
        if msg.get_signed():
            self.stats.accepted_signed += 1
        name = msg.get_type()
        if name == "SETUP_SIGNING":
            if not self.is_trusted(link):
                self._deny(link, msg, f"SETUP_SIGNING refused: untrusted link {link.name}")
                return Verdict.DENY
            return Verdict.ACCEPT
        if not changes_state(msg):
            return Verdict.ACCEPT
        if self.require_signing and not msg.get_signed():
            self.dropped(link, name, msg.get_srcSystem())
            return Verdict.DROP
        if self.gcs_sysids and msg.get_srcSystem() not in self.gcs_sysids:
            self._deny(link, msg, f"sys {msg.get_srcSystem()} not in gcs_sysids: {name} denied")
            return Verdict.DENY
        return Verdict.ACCEPT

    def dropped(self, link: Link, msg_name: str, src_system: int) -> None:
        """Count a dropped frame and tell the operator (rate-limited per sending system)."""
        self.stats.dropped += 1
        self.stats.dropped_by_type[msg_name] = self.stats.dropped_by_type.get(msg_name, 0) + 1
        log.info("%s: dropped %s from system %d (unsigned, wrong key or replayed)", link.name, msg_name,
                 src_system)
        if link.dispatcher.handles(msg_name):  # not for other vehicles' traffic on a shared channel
            self._report(("drop", src_system, msg_name),
                         f"Signing: dropped {msg_name} from sys {src_system} (unsigned, bad key or replay)")

    def dropped_frame(self, link: Link, frame: bytes) -> None:
        """A frame pymavlink refused (allow_unsigned_callback said no): name it from its header."""
        msg_name, src_system = "frame", 0
        if len(frame) >= 10 and frame[0] == 0xFD:
            msg_id = frame[7] | frame[8] << 8 | frame[9] << 16
            cls = _all.mavlink_map.get(msg_id)
            msg_name = cls.msgname if cls is not None else f"message {msg_id}"
            src_system = frame[5]
        self.dropped(link, msg_name, src_system)

    def _deny(self, link: Link, msg: Any, reason: str) -> None:
        self.stats.denied += 1
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        name = msg.get_type()
        if name in COMMAND_MESSAGES:
            link.send(mav.MAVLink_command_ack_message(int(msg.command), mav.MAV_RESULT_DENIED, 0, 0, *src))
        elif name == "SET_MODE":
            link.send(mav.MAVLink_command_ack_message(mav.MAVLINK_MSG_ID_SET_MODE, mav.MAV_RESULT_DENIED,
                                                      0, 0, *src))
        elif name in MISSION_WRITES:
            link.send(mav.MAVLink_mission_ack_message(src[0], src[1], mav.MAV_MISSION_DENIED,
                                                      int(getattr(msg, "mission_type", 0))))
        elif (answer := self._deny_answers.get(name)) is not None:
            try:
                answer(link, msg)
            except Exception:  # a refusal must never take the link down
                log.exception("answering a denied %s failed", name)
        log.warning("%s: %s", link.name, reason)
        self._report(("deny", src[0], name), reason)

    def _report(self, key: tuple[str, int, str], text: str) -> None:
        now_s = self.now_s()
        last = self._last_report_s.get(key)
        if last is not None and now_s - last < DROP_REPORT_S:
            return
        self._last_report_s[key] = now_s
        self.announce(text)

    # -- SETUP_SIGNING -------------------------------------------------------------------------
    def setup_signing(self, link: Link, msg: Any) -> str | None:
        """Apply SETUP_SIGNING from a trusted link; returns a refusal reason or None."""
        if not self.is_trusted(link):
            return f"SETUP_SIGNING refused: untrusted link {link.name}"
        key = bytes(int(b) & 0xFF for b in msg.secret_key)
        if len(key) != KEY_BYTES:
            return "SETUP_SIGNING refused: the key must be 32 bytes"
        if int(msg.initial_timestamp) > timestamp_now() + MAX_AHEAD_TIMESTAMP:
            return "SETUP_SIGNING refused: initial_timestamp over a year ahead of the vehicle clock"
        if not any(key) and int(msg.initial_timestamp) == 0:
            if self.require_signing:
                return "SETUP_SIGNING: cannot disable, signing is required"
            self.key = None
            if not self.key_is_configured and self.key_path is not None:
                self.key_path.unlink(missing_ok=True)
        else:
            if self.key_path is not None:
                try:
                    write_key_file(self.key_path, key)
                except OSError as exc:
                    return f"SETUP_SIGNING: key not saved ({exc.strerror or exc})"
            self.key = key
        for other in tuple(self._links):
            self._apply_key(other.codec)
            other.codec.signing.timestamp = max(other.codec.signing.timestamp, int(msg.initial_timestamp))
        return None
