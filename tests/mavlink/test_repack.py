"""A message packed once for several links gives every link exactly the bytes pymavlink's own
pack gives it (its sequence number, a valid CRC); signed links are packed by pymavlink."""

from __future__ import annotations

from typing import Any

import pytest

from companion.link.dialect import mav, new_codec
from companion.link.repack import SharedPack
from companion.link.signing import new_link_codec
from mavlink_dialect import usv


def _messages() -> list[Any]:
    boat_status = next(iter(usv.mavlink_map.values()))  # a message of the boat's own dialect
    return [
        mav.MAVLink_heartbeat_message(mav.MAV_TYPE_SURFACE_BOAT, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0x81, 15, 4,
                                      3),
        mav.MAVLink_attitude_message(1234, 0.1, -0.2, 3.0, 0.01, 0.0, 0.0),  # trailing zeros trimmed
        mav.MAVLink_statustext_message(6, b"Mode GUIDED", 0, 0),
        mav.MAVLink_global_position_int_message(5000, 417700000, 1234300000, 0, 0, -12, 34, 0, 9000),
        mav.MAVLink_sys_status_message(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0),  # all zero
        boat_status(*([0] * len(boat_status.fieldnames))),
    ]


@pytest.mark.parametrize("index", range(6))
def test_every_link_gets_the_bytes_pymavlink_packs(index: int) -> None:
    links = [new_link_codec(1, 1) for _ in range(3)]
    for seq, codec in zip((7, 255, 0), links, strict=True):
        codec.seq = seq
    msg = _messages()[index]
    shared = SharedPack()
    frames = [shared.pack(msg, codec) for codec in links]
    expected = [_messages()[index].pack(codec) for codec in links]
    assert frames == expected
    parser = new_codec(255, 190)
    decoded = [parser.parse_char(frame) for frame in frames]
    assert [m.get_seq() for m in decoded] == [7, 255, 0]
    assert all(m.get_type() == msg.get_type() for m in decoded)


def test_a_signed_link_and_other_ids_are_packed_by_pymavlink() -> None:
    plain, signed, other = new_link_codec(1, 1), new_link_codec(1, 1), new_link_codec(2, 1)
    signed.signing.secret_key = bytes(range(32))
    signed.signing.sign_outgoing = True
    signed.signing.link_id = 3
    signed.signing.timestamp = 1000
    msg = _messages()[1]
    shared = SharedPack()
    shared.pack(msg, plain)
    frame = shared.pack(msg, signed)
    assert frame[2] & mav.MAVLINK_IFLAG_SIGNED and len(frame) == len(shared.pack(msg, plain)) + 13
    assert shared.pack(msg, other) == _messages()[1].pack(new_link_codec(2, 1))


@pytest.mark.parametrize("data", [b"", b"123456789", bytes(range(256))])
def test_the_checksum_is_mavlinks_x25(data: bytes, monkeypatch: pytest.MonkeyPatch) -> None:
    from pymavlink.generator.mavcrc import x25crc_slow

    from companion.link import repack

    assert repack.x25_crc(data) == x25crc_slow(data).crc
    monkeypatch.setattr(repack, "_FAST_CRC", None)  # without fastcrc: pymavlink's own
    assert repack.x25_crc(data) == x25crc_slow(data).crc
