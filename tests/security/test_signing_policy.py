"""The signing policy of one link, in process: pymavlink stations' frames fed to a vehicle link."""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import all as mavlink2

from companion.clock import SimClock
from companion.config import ConfigError
from companion.link.endpoint import Dispatcher, Link
from companion.link.signing import (
    LinkSecurity,
    load_key_file,
    timestamp_now,
    write_key_file,
)

KEY = bytes(range(32))
OTHER = bytes(range(100, 132))


def station(key: bytes | None, *, system_id: int = 255, link_id: int = 0,
            timestamp: int | None = None) -> Any:
    codec = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=190)
    if key is not None:
        codec.signing.secret_key = key
        codec.signing.sign_outgoing = True
        codec.signing.link_id = link_id
        codec.signing.timestamp = timestamp_now() if timestamp is None else timestamp
    return codec


def frame(codec: Any, msg: Any) -> bytes:
    data = bytes(msg.pack(codec))
    codec.seq = (codec.seq + 1) % 256
    return data


class Vehicle:
    """One vehicle link with the policy, recording what reaches the handlers and what it says."""

    def __init__(self, tmp: Path, *, require: bool = True, key: bytes | None = KEY, name: str = "tcp:x:1",
                 trusted: tuple[str, ...] = ("serial",), sysids: tuple[int, ...] = ()) -> None:
        self.texts: list[str] = []
        self.handled: list[str] = []
        self.sent: list[bytes] = []
        self.clock = SimClock()
        self.security = LinkSecurity(key=key, require_signing=require, trusted_links=list(trusted),
                                     gcs_sysids=list(sysids), key_path=tmp / "signing.key",
                                     now_s=self.clock.now_s, announce=self.texts.append)
        self.dispatcher = Dispatcher()
        self.dispatcher.on("*", lambda link, msg: self.handled.append(msg.get_type()))
        for acted_on in ("COMMAND_LONG", "PARAM_SET"):
            self.dispatcher.on(acted_on, lambda link, msg: None)
        self.link = self.new_link(name)

    def new_link(self, name: str) -> Link:
        return Link(name, self.sent.append, clock=self.clock, dispatcher=self.dispatcher,
                    security=self.security)


def arm(codec: Any) -> Any:
    return codec.command_long_encode(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)


def test_only_validly_signed_fresh_frames_change_state(tmp_path: Path) -> None:
    v = Vehicle(tmp_path)
    good, unsigned, wrong = station(KEY), station(None), station(OTHER)
    v.link.feed(frame(unsigned, arm(unsigned)))
    v.link.feed(frame(wrong, arm(wrong)))
    v.link.feed(frame(unsigned, unsigned.param_set_encode(1, 1, b"LOIT_RADIUS", 7, 9)))
    assert v.handled == []
    assert v.security.stats.dropped == 3 and v.link.rx_dropped == 3
    assert any("Signing: dropped" in t for t in v.texts)
    v.texts.clear()
    other_boat = station(None, system_id=2)
    v.link.feed(frame(other_boat, other_boat.global_position_int_encode(0, 0, 0, 0, 0, 0, 0, 0, 0)))
    assert v.texts == [] and v.security.stats.dropped == 4  # another vehicle's telemetry: dropped quietly
    signed_arm = frame(good, arm(good))
    v.link.feed(signed_arm)
    assert v.handled == ["COMMAND_LONG"]
    v.link.feed(signed_arm)  # replay on the same link
    v.new_link("tcp:y:2").feed(signed_arm)  # and on a new connection
    assert v.handled == ["COMMAND_LONG"]
    # reads stay open to everyone
    v.link.feed(frame(unsigned, unsigned.param_request_list_encode(1, 1)))
    v.link.feed(frame(unsigned, unsigned.command_long_encode(1, 1, 512, 0, 148, 0, 0, 0, 0, 0, 0)))
    assert v.handled == ["COMMAND_LONG", "PARAM_REQUEST_LIST", "COMMAND_LONG"]


def test_wrong_key_frame_from_the_future_does_not_lock_out_the_real_station(tmp_path: Path) -> None:
    v = Vehicle(tmp_path)
    now = timestamp_now()
    forger = station(OTHER, timestamp=now + 10**12)  # same stream (link 0, 255/190), far future
    v.link.feed(frame(forger, arm(forger)))
    good = station(KEY, timestamp=now)
    v.link.feed(frame(good, arm(good)))
    assert v.handled == ["COMMAND_LONG"]


def test_old_session_replayed_as_a_new_stream_is_refused(tmp_path: Path) -> None:
    v = Vehicle(tmp_path)
    old = station(KEY, link_id=9, timestamp=timestamp_now() - 5 * 60 * 100_000)  # 5 minutes ago
    v.link.feed(frame(old, arm(old)))
    assert v.handled == []


def test_unsigned_heartbeats_do_not_hold_off_the_gcs_failsafe(tmp_path: Path) -> None:
    v = Vehicle(tmp_path)
    unsigned = station(None)
    v.link.feed(frame(unsigned, unsigned.heartbeat_encode(6, 8, 0, 0, 0)))
    assert v.link.gcs.silence() is None and v.handled == ["HEARTBEAT"]
    good = station(KEY)
    v.link.feed(frame(good, good.heartbeat_encode(6, 8, 0, 0, 0)))
    assert v.link.gcs.silence() is not None


def test_without_require_signing_unsigned_stations_are_obeyed_and_replies_are_signed(tmp_path: Path) -> None:
    v = Vehicle(tmp_path, require=False)
    unsigned = station(None)
    v.link.feed(frame(unsigned, arm(unsigned)))
    assert v.handled == ["COMMAND_LONG"]
    v.link.send(mavlink2.MAVLink_heartbeat_message(10, 3, 0, 0, 0, 3))
    listener = station(KEY)
    msg = listener.parse_char(v.sent[-1])
    assert msg is not None and msg.get_signed()


def test_gcs_sysids_denies_with_ack_and_reason(tmp_path: Path) -> None:
    v = Vehicle(tmp_path, sysids=(255,))
    stranger = station(KEY, system_id=7)
    v.link.feed(frame(stranger, arm(stranger)))
    assert v.handled == []
    ack = station(None).parse_char(v.sent[-1])
    assert ack.get_type() == "COMMAND_ACK" and ack.result == mavlink2.MAV_RESULT_DENIED
    assert any("sys 7 not in gcs_sysids" in t for t in v.texts)


def setup_signing(codec: Any, key: bytes, timestamp: int) -> bytes:
    return frame(codec, codec.setup_signing_encode(1, 1, list(key), timestamp))


def test_setup_signing_only_on_trusted_links(tmp_path: Path) -> None:
    v = Vehicle(tmp_path, require=False, key=None)
    v.dispatcher.on("SETUP_SIGNING",
                    lambda link, msg: v.texts.append(str(v.security.setup_signing(link, msg))))
    gcs = station(None)
    v.link.feed(setup_signing(gcs, OTHER, timestamp_now()))  # tcp: not trusted
    assert v.security.key is None and not (tmp_path / "signing.key").exists()
    assert any("untrusted link" in t for t in v.texts)
    usb = v.new_link("serial:/dev/ttyACM0")
    usb.feed(setup_signing(gcs, OTHER, timestamp_now()))
    assert v.security.key == OTHER
    saved = tmp_path / "signing.key"
    assert stat.S_IMODE(saved.stat().st_mode) == 0o600 and load_key_file(saved) == OTHER
    assert v.link.codec.signing.sign_outgoing  # every link signs from now on
    usb.feed(setup_signing(gcs, bytes(32), 0))  # all zero: signing off
    assert v.security.key is None and not saved.exists()


def test_setup_signing_cannot_disable_required_signing(tmp_path: Path) -> None:
    v = Vehicle(tmp_path, name="serial:/dev/ttyUSB0")
    msg = station(None).setup_signing_encode(1, 1, [0] * 32, 0)
    assert "signing is required" in str(v.security.setup_signing(v.link, msg))
    assert v.security.key == KEY


def test_key_files(tmp_path: Path) -> None:
    good = tmp_path / "good.key"
    write_key_file(good, KEY)
    assert load_key_file(good) == KEY
    os.chmod(good, 0o640)
    with pytest.raises(ConfigError, match="chmod 600"):
        load_key_file(good)
    for text in ("abc", KEY.hex()[:-2], KEY.hex() + "00", "zz" * 32):
        bad = tmp_path / "bad.key"
        bad.write_text(text)
        os.chmod(bad, 0o600)
        with pytest.raises(ConfigError, match="64 hex characters"):
            load_key_file(bad)
    with pytest.raises(ConfigError, match="cannot read"):
        load_key_file(tmp_path / "missing.key")


def test_require_signing_without_a_key_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="require_signing"):
        Vehicle(tmp_path, key=None)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(min_size=0, max_size=300), flips=st.lists(st.integers(0, 10_000), max_size=6))
def test_garbage_and_bit_flipped_signed_frames_never_raise_nor_act(tmp_path: Path, data: bytes,
                                                                   flips: list[int]) -> None:
    v = Vehicle(tmp_path)
    good = station(KEY)
    arm_frame = frame(good, arm(good))
    param_frame = frame(good, good.param_set_encode(1, 1, b"LOIT_RADIUS", 7, 9))
    signed = bytearray(arm_frame + param_frame)
    for bit in flips:
        signed[(bit // 8) % len(signed)] ^= 1 << (bit % 8)
    arm_sent, param_sent = bytes(signed[:len(arm_frame)]), bytes(signed[len(arm_frame):])
    for _ in range(2):  # the second time: replays
        for datagram in (bytes(data), arm_sent, param_sent):  # one frame per datagram, as UDP stations
            v.link.feed(datagram, datagram=True)
    v.link.feed(bytes(data) + bytes(signed))  # on a byte stream (TCP, serial): garbage first
    intact = param_sent == param_frame
    assert v.handled.count("PARAM_SET") == (1 if intact else 0)  # a damaged frame never, a replay never


def test_setup_signing_with_a_timestamp_beyond_the_signature_is_refused(tmp_path: Path) -> None:
    """Found by the fuzzer (tests/rig): 2**64 - 1 as initial_timestamp on the trusted serial link
    made every frame the vehicle sent unencodable (48-bit signature timestamp): silent on every link."""
    v = Vehicle(tmp_path, require=False, key=None, name="serial:/dev/ttyUSB0")
    msg = station(None).setup_signing_encode(1, 1, list(OTHER), 2**64 - 1)
    assert "over a year ahead" in str(v.security.setup_signing(v.link, msg))
    assert v.security.key is None
    v.link.send(mavlink2.MAVLink_heartbeat_message(11, 8, 0, 0, 3, 3))
    assert v.sent  # the vehicle still talks
