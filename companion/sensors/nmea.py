"""NMEA 0183 framing shared by the GPS-INS parser and the simulator: checksum, build, split.

A sentence is ``$BODY*HH\\r\\n`` where HH is the XOR of every byte of BODY in upper-case
hex.  :class:`LineFramer` turns an arbitrary byte stream into checked sentence bodies;
garbage, over-long lines and bad checksums are counted and dropped, never raised.
"""

from __future__ import annotations

from dataclasses import dataclass

from numba import njit

MAX_SENTENCE_BYTES = 200
"""Longest accepted sentence; NMEA's limit is 82 but the XW-GI $GPFPD is longer."""


@njit(cache=True)
def checksum(body: bytes) -> int:
    """XOR of the bytes between ``$`` and ``*`` (compiled: a few hundred nanoseconds for a
    ``$GPFPD``, several sentences per 100 Hz sample in lockstep SITL)."""
    x = 0
    for byte in body:
        x ^= byte
    return x


def build(body: str) -> bytes:
    """``$BODY*HH\\r\\n`` for a body such as ``GPFPD,2168,...``."""
    return frame(body.encode("ascii"))


def frame(body: bytes) -> bytes:
    """:func:`build` for a body that is already ASCII bytes (e.g. from ``bytes % values``)."""
    return b"$%s*%02X\r\n" % (body, checksum(body))


@dataclass(slots=True)
class FramerStats:
    sentences: int = 0
    bad_checksum: int = 0
    garbage: int = 0
    too_long: int = 0

    @property
    def errors(self) -> int:
        return self.bad_checksum + self.garbage + self.too_long


class LineFramer:
    """Accumulates bytes and yields the checked bodies (``GPFPD,...``) of complete sentences."""

    def __init__(self) -> None:
        self._buf = b""
        self.stats = FramerStats()

    def feed(self, data: bytes) -> list[str]:
        buf = self._buf + data
        lines = buf.split(b"\n")
        self._buf = lines.pop()
        if len(self._buf) > MAX_SENTENCE_BYTES:
            self.stats.too_long += 1
            self._buf = b""
        out: list[str] = []
        for line in lines:
            body = self._check(line.rstrip(b"\r"))
            if body is not None:
                out.append(body)
        return out

    def _check(self, line: bytes) -> str | None:
        if not line:
            return None
        start = line.rfind(b"$")
        if start < 0 or len(line) - start > MAX_SENTENCE_BYTES:
            self.stats.garbage += 1
            return None
        if start > 0:
            self.stats.garbage += 1  # noise before the sentence; keep the sentence
        line = line[start:]
        star = line.rfind(b"*")
        if star < 0 or len(line) - star != 3:
            self.stats.garbage += 1
            return None
        body = line[1:star]
        try:
            expected = int(line[star + 1:], 16)
            text = body.decode("ascii")
        except (ValueError, UnicodeDecodeError):
            self.stats.garbage += 1
            return None
        if checksum(body) != expected:
            self.stats.bad_checksum += 1
            return None
        self.stats.sentences += 1
        return text
