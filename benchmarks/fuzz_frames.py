"""Hostile input for the fuzz harness: MAVLink frames and GPS-INS sentences that a broken radio,
a confused ground station or an attacker could send.

Every generator takes a :class:`random.Random` (a seeded one in ``usv bench --only fuzz``, the
one hypothesis draws from in the tests, so a failure shrinks and replays), and returns bytes.

MAVLink kinds (:class:`FrameKind`):

* ``RANDOM_BYTES``: 1-300 random bytes (with MAVLink 1/2 start markers sprinkled in);
* ``BIT_FLIP``: a valid frame with 1-8 bits flipped (header, payload or checksum);
* ``TRUNCATED``: a valid frame cut short (on a byte stream the next frame must still parse);
* ``EXTREME_FIELDS``: a frame with a *valid* checksum of any message of the dialect (common,
  development, ardupilotmega and the boat's own) whose fields are NaN, +-inf, the type's
  limits, zero or random, addressed to the vehicle most of the time, so it reaches the handlers;
* ``BAD_SIGNATURE``: an extreme-field frame with the MAVLink 2 "signed" flag, a valid checksum
  and a random 13-byte signature;
* ``BAD_LENGTH``: a valid frame whose length byte is changed and whose checksum is recomputed
  over the wrong length (the parser must not trust the length);
* ``MAVLINK1``: an extreme-field frame of a message with an id below 256 in MAVLink 1 framing
  (valid checksum), as an old radio or ground station sends it.
"""

from __future__ import annotations

import enum
import math
import random
import struct
from collections.abc import Sequence
from typing import Any

from pymavlink.generator.mavcrc import x25crc

from companion.link.dialect import mav, new_codec
from companion.sensors import nmea

VEHICLE_SYSTEM_ID = 1
VEHICLE_COMPONENT_ID = 1
MAVLINK2_MARKER = 0xFD
SIGNED_FLAG = 0x01
HEADER_LEN = 10
"""MAVLink 2 header bytes (marker to message id)."""


class FrameKind(enum.Enum):
    RANDOM_BYTES = "random_bytes"
    BIT_FLIP = "bit_flip"
    TRUNCATED = "truncated"
    EXTREME_FIELDS = "extreme_fields"
    BAD_SIGNATURE = "bad_signature"
    BAD_LENGTH = "bad_length"
    MAVLINK1 = "mavlink1"


FLOAT_EXTREMES = (math.nan, math.inf, -math.inf, 3.4e38, -3.4e38, 1e-45, -0.0, 0.0, 1.0, -1.0)
DOUBLE_EXTREMES = (math.nan, math.inf, -math.inf, 1.7e308, -1.7e308, 5e-324, -0.0, 0.0, 1.0)
INT_LIMITS: dict[str, tuple[int, int]] = {
    "int8_t": (-(2**7), 2**7 - 1), "uint8_t": (0, 2**8 - 1),
    "int16_t": (-(2**15), 2**15 - 1), "uint16_t": (0, 2**16 - 1),
    "int32_t": (-(2**31), 2**31 - 1), "uint32_t": (0, 2**32 - 1),
    "int64_t": (-(2**63), 2**63 - 1), "uint64_t": (0, 2**64 - 1),
    "uint8_t_mavlink_version": (0, 2**8 - 1),
}
TARGET_FIELDS = ("target_system", "target_component")


def message_classes() -> list[type]:
    """Every message class the vehicle's parser knows, in id order."""
    return [mav.mavlink_map[msg_id] for msg_id in sorted(mav.mavlink_map)]


def _scalar(ftype: str, rng: random.Random) -> Any:
    if ftype == "float":
        return rng.choice((*FLOAT_EXTREMES, rng.uniform(-1e6, 1e6)))
    if ftype == "double":
        return rng.choice((*DOUBLE_EXTREMES, rng.uniform(-1e9, 1e9)))
    low, high = INT_LIMITS[ftype]
    return rng.choice((low, high, 0, 1, rng.randint(low, high)))


def _field_value(cls: type, name: str, ftype: str, length: int, rng: random.Random) -> Any:
    if name == "target_system":
        return rng.choice((VEHICLE_SYSTEM_ID, VEHICLE_SYSTEM_ID, 0, rng.randint(0, 255)))
    if name == "target_component":
        return rng.choice((VEHICLE_COMPONENT_ID, 0, 0, rng.randint(0, 255)))
    if ftype == "char":  # a char array (bytes up to its length) or a single char (exactly one)
        size = rng.randint(0, length) if length else 1
        return bytes(rng.randint(1, 255) for _ in range(size))
    if length:
        return [_scalar(ftype, rng) for _ in range(length)]
    return _scalar(ftype, rng)


def extreme_message(cls: type, rng: random.Random) -> Any:
    """An instance of message class ``cls`` with hostile field values."""
    c: Any = cls
    lengths = dict(zip(c.ordered_fieldnames, c.array_lengths, strict=True))
    values = [_field_value(cls, name, ftype, lengths[name], rng)
              for name, ftype in zip(c.fieldnames, c.fieldtypes, strict=True)]
    return cls(*values)


def pack(msg: Any, rng: random.Random, *, mavlink1: bool = False) -> bytes:
    """``msg`` as a MAVLink 2 (or 1) frame from a random system/component with a random sequence."""
    codec = new_codec(rng.randint(1, 255), rng.randint(0, 255))
    codec.seq = rng.randint(0, 255)
    return bytes(msg.pack(codec, force_mavlink1=mavlink1))


def recrc(frame: bytearray, crc_extra: int) -> None:
    """Recompute the checksum of a MAVLink 2 ``frame`` in place (after editing its header)."""
    payload_len = frame[1]
    end = HEADER_LEN + payload_len
    crc = x25crc(frame[1:end])
    crc.accumulate(bytes([crc_extra]))
    frame[end:end + 2] = struct.pack("<H", crc.crc)


def _crc_extra(frame: bytes) -> int:
    msg_id = frame[7] | frame[8] << 8 | frame[9] << 16
    return int(mav.mavlink_map[msg_id].crc_extra)


def valid_frame(rng: random.Random, classes: Sequence[type] | None = None) -> bytes:
    cls = rng.choice(list(classes) if classes is not None else message_classes())
    return pack(extreme_message(cls, rng), rng)


def hostile_frame(kind: FrameKind, rng: random.Random, classes: Sequence[type] | None = None) -> bytes:
    """One piece of hostile input of ``kind`` (see the module docstring)."""
    if kind is FrameKind.RANDOM_BYTES:
        data = bytearray(rng.randbytes(rng.randint(1, 300)))
        for _ in range(rng.randint(0, 3)):
            data[rng.randrange(len(data))] = rng.choice((0xFD, 0xFE))
        return bytes(data)
    if kind is FrameKind.MAVLINK1:
        v1_classes = [c for c in (classes or message_classes()) if int(getattr(c, "id", 256)) < 256]
        return pack(extreme_message(rng.choice(v1_classes), rng), rng, mavlink1=True)
    frame = bytearray(valid_frame(rng, classes))
    if kind is FrameKind.EXTREME_FIELDS:
        return bytes(frame)
    if kind is FrameKind.BIT_FLIP:
        for _ in range(rng.randint(1, 8)):
            frame[rng.randrange(len(frame))] ^= 1 << rng.randrange(8)
        return bytes(frame)
    if kind is FrameKind.TRUNCATED:
        return bytes(frame[:rng.randrange(1, len(frame))])
    crc_extra = _crc_extra(bytes(frame))
    if kind is FrameKind.BAD_SIGNATURE:
        frame[2] |= SIGNED_FLAG
        recrc(frame, crc_extra)
        return bytes(frame) + rng.randbytes(13)
    # BAD_LENGTH: the declared payload length lies; the checksum matches the lie
    payload = frame[HEADER_LEN:-2]
    new_len = rng.choice((0, 1, 255, rng.randint(0, 255)))
    body = bytearray(frame[:HEADER_LEN]) + (payload + bytearray(rng.randbytes(255)))[:new_len]
    body[1] = new_len
    body += b"\0\0"
    recrc(body, crc_extra)
    return bytes(body)


# -- GPS-INS sentences ----------------------------------------------------------------------
SENTENCE_FIELD_COUNTS = {"GPFPD": 16, "GTIMU": 10, "PUSVE": 3, "PUSVP": 9, "PUSVRC": 10}
"""Fields (the name included) of each sentence the GPS-INS parser understands."""
HOSTILE_NMEA_FIELDS = ("nan", "NaN", "inf", "-inf", "1e309", "-1e309", "", "-", "0x1F", "1e-320",
                       "99999999999999999999", "-0", "41.77", "123.43", "0", "A", ",", "*", "$")


def hostile_sentence(rng: random.Random) -> bytes:
    """A GPS-INS sentence with a valid checksum and hostile fields (or the wrong field count)."""
    name = rng.choice((*SENTENCE_FIELD_COUNTS, "GPGGA", "X" * rng.randint(0, 8)))
    count = SENTENCE_FIELD_COUNTS.get(name, 5) + rng.choice((0, 0, 0, -1, 1, -5))
    fields = [rng.choice(HOSTILE_NMEA_FIELDS) if rng.random() < 0.7 else repr(rng.uniform(-1e6, 1e6))
              for _ in range(max(count - 1, 0))]
    body = ",".join([name, *fields]).encode("ascii")[:nmea.MAX_SENTENCE_BYTES + 20]
    return nmea.frame(body)


def hostile_nmea(rng: random.Random) -> bytes:
    """Hostile GPS-INS bytes: a checked sentence with bad fields, random bytes, a bit-flipped or
    truncated sentence, or an over-long line."""
    choice = rng.randrange(5)
    if choice == 0:
        return hostile_sentence(rng)
    if choice == 1:
        return rng.randbytes(rng.randint(1, 300))
    sentence = bytearray(hostile_sentence(rng))
    if choice == 2:
        sentence[rng.randrange(len(sentence))] ^= 1 << rng.randrange(8)
        return bytes(sentence)
    if choice == 3:
        return bytes(sentence[:rng.randrange(1, len(sentence))])
    return b"$" + b"A" * rng.randint(nmea.MAX_SENTENCE_BYTES, 2000)
