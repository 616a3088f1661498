"""Telemetry logs (.tlog): every frame a link sends or receives, as MAVProxy and QGC write them.

The format is what pymavlink's ``mavlogdump.py`` reads: for each frame an 8-byte
big-endian timestamp in microseconds since the Unix epoch, then the raw MAVLink frame.
Writes are buffered and flushed once a second; a failing disk (full, removed) disables
the log with one warning instead of stopping the link.

Bounded (:class:`TlogDirectory`), so that a flood of connections cannot fill the disk:

* a link's log file is created only once its peer has sent a valid frame: a connection that
  never says anything (a port scan, a client cut mid-frame) leaves no file; the last
  :data:`PRE_BUFFER_FRAMES` frames the vehicle sent before are kept in memory and written first;
* a file that reaches ``USV_TLOG_FILE_MB`` is closed and the link goes on in a new part
  (``...-part2.tlog``), so no single file grows without bound;
* after every new file and every flush, closed files are deleted while the directory holds more
  than ``USV_TLOG_MAX_MB`` in total or more than ``links.tlog_max_files`` files: small ones
  (under :data:`SMALL_LOG_BYTES`) first, each group oldest first.  Open files are never deleted,
  and a large log is deleted for the file count only when large logs alone exceed it, so many
  short connections at once cannot push out a real session's log.
"""

from __future__ import annotations

import contextlib
import logging
import struct
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

log = logging.getLogger(__name__)

_STAMP = struct.Struct(">Q")
PRE_BUFFER_FRAMES = 256
"""Frames sent before the peer spoke that are kept for the log (older ones are not logged)."""
MB = 1_000_000
SMALL_LOG_BYTES = 16_000
"""Logs smaller than this (a connection that said little) are deleted before larger ones, so a
flood of short connections cannot push out the log of a real session."""


class TlogWriter:
    """Append-only writer of one link's .tlog (rotated into parts by its :class:`TlogDirectory`)."""

    def __init__(self, path: Path, directory: TlogDirectory | None = None) -> None:
        self.path = path
        self.directory = directory
        self.frames = 0
        self.bytes_written = 0
        self.part = 1
        self.disabled = False
        self._fh: BinaryIO | None = None
        self._pending: deque[bytes] | None = deque(maxlen=PRE_BUFFER_FRAMES) if directory else None
        if directory is None:
            self._open(path)

    @property
    def is_open(self) -> bool:
        return self._fh is not None

    def _open(self, path: Path) -> None:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._fh = open(path, "ab")  # noqa: SIM115 - kept open for the link's life
        except OSError as exc:
            log.warning("tlog %s disabled: %s", path, exc)
            self.disabled = True
            return
        self.path = path
        self.bytes_written = 0
        if self.directory is not None:
            self.directory.opened(self)

    def write(self, unix_time_s: float, frame: bytes, *, received: bool = False) -> None:
        """Log one frame; ``received``: it came from the peer (which starts the file)."""
        if self.disabled:
            return
        record = _STAMP.pack(int(unix_time_s * 1e6)) + frame
        if self._fh is None:
            if self._pending is None:
                return
            self._pending.append(record)
            if not received:
                return
            pending, self._pending = self._pending, None
            self._open(self.path)
            for earlier in pending:
                self._append(earlier)
            return
        self._append(record)

    def _append(self, record: bytes) -> None:
        if self._fh is None:
            return
        try:
            self._fh.write(record)
        except OSError as exc:
            log.warning("tlog %s disabled: %s", self.path, exc)
            self.close()
            self.disabled = True
            return
        self.frames += 1
        self.bytes_written += len(record)
        if self.directory is not None and self.bytes_written >= self.directory.file_bytes():
            self._rotate()

    def _rotate(self) -> None:
        self._close_file()
        self.part += 1
        stem = self.path.stem.split("-part")[0]
        self._open(self.path.with_name(f"{stem}-part{self.part}{self.path.suffix}"))

    def flush(self) -> None:
        if self._fh is None:
            return
        try:
            self._fh.flush()
        except OSError as exc:
            log.warning("tlog %s disabled: %s", self.path, exc)
            self.close()
            self.disabled = True

    def _close_file(self) -> None:
        fh, self._fh = self._fh, None
        if fh is not None:
            with contextlib.suppress(OSError):
                fh.close()
            if self.directory is not None:
                self.directory.closed(self)

    def close(self) -> None:
        self._pending = None
        self._close_file()


class TlogDirectory:
    """The .tlog files of one vehicle, kept under a total size and a file count."""

    def __init__(self, path: Path, *, max_total_bytes: Callable[[], float], file_bytes: Callable[[], float],
                 max_files: int) -> None:
        self.path = path
        self.max_total_bytes = max_total_bytes
        self.file_bytes = file_bytes
        self.max_files = max_files
        self._open: set[Path] = set()
        self.deleted = 0

    def writer(self, name: str) -> TlogWriter:
        """A writer for a new link; its file appears when the peer first speaks."""
        return TlogWriter(self.path / f"{name}.tlog", self)

    def opened(self, writer: TlogWriter) -> None:
        self._open.add(writer.path)
        self.enforce()

    def closed(self, writer: TlogWriter) -> None:
        self._open.discard(writer.path)
        self.enforce()

    def enforce(self) -> None:
        """Delete closed logs (small ones first, then the oldest) while over the size or count limit."""
        files: list[tuple[float, int, Path]] = []
        with contextlib.suppress(OSError):
            for p in self.path.glob("*.tlog"):
                with contextlib.suppress(OSError):
                    st = p.stat()
                    files.append((st.st_mtime, st.st_size, p))
        files.sort(key=lambda f: (f[1] >= SMALL_LOG_BYTES, f[0]))  # small ones first, then oldest first
        total = sum(size for _, size, _ in files)
        count = len(files)
        big = sum(1 for _, size, _ in files if size >= SMALL_LOG_BYTES)
        limit = self.max_total_bytes()
        for _, size, path in files:
            over_size, over_count = total > limit, count > self.max_files
            if not (over_size or over_count):
                break
            if path in self._open:
                continue
            if size >= SMALL_LOG_BYTES and not over_size and big <= self.max_files:
                continue  # too many files because of small or open ones: a real session's log stays
            try:
                path.unlink()
            except OSError:
                continue
            self.deleted += 1
            total -= size
            count -= 1
            big -= size >= SMALL_LOG_BYTES
