"""One message packed once for every link it goes to (telemetry streams, broadcasts).

pymavlink's ``msg.pack(codec)`` builds the payload, the header and the CRC from scratch for
each link (about 12 us per message in lockstep SITL); links of one vehicle differ only in
the sequence number.  For an unsigned MAVLink 2 frame (header ``FD LEN INCOMPAT COMPAT SEQ
SYSID COMPID MSGID[3]``, payload, CRC16) of the same system and component ids,
:func:`restamp` writes the link's sequence number into byte 4 and computes the CRC again over
bytes 1..end-2 plus the message's CRC_EXTRA (MAVLink 2 serialisation: X.25 / MCRF4XX
checksum), which gives exactly the bytes ``msg.pack`` would.  Signed links, MAVLink 1 frames and
other ids are packed by pymavlink as before.
"""

from __future__ import annotations

from typing import Any

from companion.link.dialect import mav

MAGIC_V2 = 0xFD
SEQ_INDEX = 4
IFLAG_SIGNED = 0x01


_FAST_CRC = getattr(mav, "mcrf4xx", None)
"""fastcrc's CRC-16/MCRF4XX, which pymavlink uses when it is installed (else its Python one)."""


def x25_crc(data: bytes) -> int:
    """MAVLink's X.25 (CRC-16/MCRF4XX) checksum of ``data``, seeded 0xFFFF."""
    if _FAST_CRC is not None:
        return int(_FAST_CRC(data, 0xFFFF))
    return int(mav.x25crc(data).crc)


def restamp(frame: bytes, seq: int, crc_extra: int) -> bytes:
    """``frame`` (unsigned MAVLink 2) with sequence number ``seq`` and its CRC recomputed."""
    buf = bytearray(frame)
    buf[SEQ_INDEX] = seq
    crc = x25_crc(bytes(buf[1:-2]) + bytes((crc_extra,)))
    buf[-2:] = crc.to_bytes(2, "little")
    return bytes(buf)


class SharedPack:
    """The frames of the messages of one send to several links (create one per send round:
    a message must not change between the links, which holds for a message built for the round)."""

    def __init__(self) -> None:
        self._frames: dict[int, tuple[Any, bytes]] = {}

    def pack(self, msg: Any, codec: Any) -> bytes:
        """``msg.pack(codec)``, or the frame packed for an earlier link restamped with ``codec``'s
        sequence number when that gives the same bytes (module docstring)."""
        signing = codec.signing.sign_outgoing
        kept = self._frames.get(id(msg))
        if kept is not None and kept[0] is msg and not signing:
            frame = kept[1]
            if frame[5] == codec.srcSystem and frame[6] == codec.srcComponent:
                return restamp(frame, codec.seq, msg.crc_extra)
        frame = msg.pack(codec)
        if not signing and frame[0] == MAGIC_V2 and not frame[2] & IFLAG_SIGNED:
            self._frames[id(msg)] = (msg, frame)
        return bytes(frame)
