"""One companion per state directory: an exclusive ``fcntl.flock`` on ``<state_dir>/usv.lock``.

Two companions on one state directory would overwrite each other's parameters, missions and
sample log.  :class:`StateDirLock` takes an exclusive, non-blocking lock on a lock file that
holds the owner's PID; a second instance gets :class:`StateDirBusy` naming the directory and
the PID holding it.  The lock belongs to the open file, so the kernel releases it when the
process dies, SIGKILL included: a stale lock file (left by a crash) never blocks a restart.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path
from types import TracebackType

LOCK_FILE_NAME = "usv.lock"


class StateDirBusy(RuntimeError):
    """Another live process holds the state directory."""

    def __init__(self, state_dir: Path, pid: int | None) -> None:
        holder = f"PID {pid}" if pid is not None else "an unknown process"
        super().__init__(f"state directory {state_dir} is in use by another companion ({holder}); "
                         "stop it or give this one another --state-dir")
        self.state_dir = state_dir
        self.pid = pid


class StateDirLock:
    """Exclusive ownership of a state directory for the life of this object (a context manager)."""

    def __init__(self, state_dir: Path) -> None:
        self.state_dir = Path(state_dir)
        self.path = self.state_dir / LOCK_FILE_NAME
        self._fd: int | None = None

    def acquire(self) -> None:
        """Take the lock or raise :class:`StateDirBusy`; writes this process's PID into the file."""
        self.state_dir.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = _read_pid(fd)
            os.close(fd)
            raise StateDirBusy(self.state_dir, pid) from None
        except BaseException:
            os.close(fd)
            raise
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._fd = fd

    def release(self) -> None:
        fd, self._fd = self._fd, None
        if fd is None:
            return
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)  # the file stays (unlinking it would race with a starting instance)
        os.close(fd)  # closing the descriptor releases the lock

    def __enter__(self) -> StateDirLock:
        self.acquire()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.release()


def _read_pid(fd: int) -> int | None:
    """The PID written by the holder (``None`` if it has not written it yet)."""
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None
