"""Telemetry logs (.tlog): every frame a link sends or receives, as MAVProxy and QGC write them.

The format is what pymavlink's ``mavlogdump.py`` reads: for each frame an 8-byte
big-endian timestamp in microseconds since the Unix epoch, then the raw MAVLink frame.
Writes are buffered and flushed once a second; a failing disk (full, removed) disables
the log with one warning instead of stopping the link.
"""

from __future__ import annotations

import contextlib
import logging
import struct
from pathlib import Path
from typing import BinaryIO

log = logging.getLogger(__name__)

_STAMP = struct.Struct(">Q")


class TlogWriter:
    """Append-only writer of one .tlog file."""

    def __init__(self, path: Path) -> None:
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: BinaryIO | None = open(path, "ab")  # noqa: SIM115 - kept open for the link's life
        self.frames = 0

    def write(self, unix_time_s: float, frame: bytes) -> None:
        if self._fh is None:
            return
        try:
            self._fh.write(_STAMP.pack(int(unix_time_s * 1e6)) + frame)
            self.frames += 1
        except OSError as exc:
            log.warning("tlog %s disabled: %s", self.path, exc)
            self.close()

    def flush(self) -> None:
        if self._fh is None:
            return
        try:
            self._fh.flush()
        except OSError as exc:
            log.warning("tlog %s disabled: %s", self.path, exc)
            self.close()

    def close(self) -> None:
        fh, self._fh = self._fh, None
        if fh is not None:
            with contextlib.suppress(OSError):
                fh.close()
