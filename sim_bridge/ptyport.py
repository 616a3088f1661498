"""The simulator's side of a pseudo-terminal: the device end a companion opens as a serial port.

The master end is read with ``loop.add_reader``; both ends are put in raw mode (no echo,
no CR/LF translation) and the simulator keeps the slave open so the pty survives a
companion that closes and reopens it.  :attr:`PtyPort.path` is what the companion opens
(``sensors.gnss_port`` / ``servos.port``).

With ``link_path`` the port is also published under a stable name (a symbolic link to
the pty, as udev's ``/dev/serial/by-id`` links or socat's ``link=``), replaced atomically
on start: a companion configured with that name finds a restarted simulator again even
though the kernel hands out a different ``/dev/pts/N``.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import tty
from pathlib import Path

from companion.transport import LinkStats, Receiver


class PtyPort:
    def __init__(self, name: str = "pty", link_path: str | Path | None = None) -> None:
        self.name = name
        self.stats = LinkStats()
        self._receiver: Receiver | None = None
        self.master_fd, self._slave_fd = os.openpty()
        tty.setraw(self.master_fd)
        tty.setraw(self._slave_fd)
        os.set_blocking(self.master_fd, False)
        self.device = os.ttyname(self._slave_fd)
        self.path = self.device
        self.link_path = Path(link_path) if link_path is not None else None
        if self.link_path is not None:
            tmp = self.link_path.with_name(f".{self.link_path.name}.{os.getpid()}.tmp")
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
            os.symlink(self.device, tmp)
            os.replace(tmp, self.link_path)
            self.path = str(self.link_path)
        self._reading = False

    def set_receiver(self, receiver: Receiver) -> None:
        self._receiver = receiver

    async def open(self) -> None:
        asyncio.get_running_loop().add_reader(self.master_fd, self._on_readable)
        self._reading = True

    def _on_readable(self) -> None:
        try:
            data = os.read(self.master_fd, 65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        self.stats.bytes_in += len(data)
        if data and self._receiver is not None:
            self._receiver(data)

    def write(self, data: bytes) -> None:
        try:
            n = os.write(self.master_fd, data)
            self.stats.bytes_out += n
        except (BlockingIOError, OSError):
            self.stats.write_errors += 1

    async def close(self) -> None:
        if self._reading:
            with contextlib.suppress(Exception):
                asyncio.get_running_loop().remove_reader(self.master_fd)
            self._reading = False
        for fd in (self.master_fd, self._slave_fd):
            with contextlib.suppress(OSError):
                os.close(fd)
        if self.link_path is not None:
            with contextlib.suppress(OSError):
                if os.readlink(self.link_path) == self.device:
                    self.link_path.unlink()
