"""A real ``usv sitl`` process to fuzz, reached over all three kinds of link at once.

:class:`FuzzTarget` starts ``usv sitl`` (lockstep, real time by default) whose links are a UDP
target (a socket of this process), a TCP server and a serial radio on a pseudo-terminal whose
master end this process holds.  Every link has a client here that parses what the vehicle sends
(a thread per link).  :meth:`FuzzTarget.send` writes hostile bytes on one link;
:meth:`FuzzTarget.check_alive` then asks the vehicle, on that same link, for a PING reply and a
PARAM_VALUE and waits for a fresh HEARTBEAT, as a ground station would after a burst of noise
(re-asking up to :data:`ALIVE_ATTEMPTS` times: the request itself may be swallowed by a frame
the noise left half-received, which the parser then resynchronises past).
:meth:`FuzzTarget.rss_kb` reads the process's resident memory from ``/proc``.
"""

from __future__ import annotations

import contextlib
import enum
import functools
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.mavlink_gcs import free_port
from companion.link.dialect import mav, new_codec

ALIVE_ATTEMPTS = 3
ALIVE_TIMEOUT_S = 2.0
"""Wall seconds per attempt (the vehicle answers within milliseconds when it is well)."""
HEARTBEAT_FRESH_S = 1.5
READY_TIMEOUT_S = 120.0
GCS_SYSTEM_ID, GCS_COMPONENT_ID = 255, 190


class Channel(enum.Enum):
    UDP = "udp"
    TCP = "tcp"
    SERIAL = "serial"


def usv_command() -> list[str]:
    script = Path(sys.executable).with_name("usv")
    if script.exists():
        return [str(script)]
    found = shutil.which("usv")
    return [found] if found else [sys.executable, "-m", "companion.cli"]


def rss_kb(pid: int) -> int:
    """Resident set size of ``pid`` in kB (``VmRSS``; 0 when unknown)."""
    with contextlib.suppress(OSError, ValueError):
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


class _Inbox:
    """What the vehicle sent on one link, parsed; waiters block on a condition."""

    def __init__(self) -> None:
        self.codec = new_codec(GCS_SYSTEM_ID, GCS_COMPONENT_ID)
        self.cond = threading.Condition()
        self.messages: list[tuple[float, Any]] = []

    def feed(self, data: bytes) -> None:
        now = time.monotonic()
        msgs = [m for m in (self.codec.parse_buffer(data) or []) if m.get_type() != "BAD_DATA"]
        if msgs:
            with self.cond:
                self.messages.extend((now, m) for m in msgs)
                del self.messages[:-2000]
                self.cond.notify_all()

    def wait(self, since: float, match: Any, timeout_s: float) -> Any | None:
        deadline = time.monotonic() + timeout_s
        with self.cond:
            while True:
                for t, m in self.messages:
                    if t >= since and match(m):
                        return m
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.cond.wait(left)


def _is_ping_answer(msg: Any, seq: int) -> bool:
    return bool(msg.get_type() == "PING" and msg.seq == seq and msg.target_system == GCS_SYSTEM_ID)


@dataclass
class AliveReport:
    ok: bool
    attempts: int
    missing: list[str]


class FuzzTarget:
    """``usv sitl`` with a UDP, a TCP and a serial (pty) link, each with a parsing client here."""

    def __init__(self, workdir: Path, *, speedup: float = 1.0) -> None:
        self.workdir = workdir
        self.speedup = speedup
        self.udp_port = free_port(socket.SOCK_DGRAM)
        self.tcp_port = free_port(socket.SOCK_STREAM)
        self.master_fd, self.slave_fd = os.openpty()
        tty.setraw(self.slave_fd)
        tty.setraw(self.master_fd)
        self.serial_device = os.ttyname(self.slave_fd)
        self.inbox = {channel: _Inbox() for channel in Channel}
        self.proc: subprocess.Popen[bytes] | None = None
        self.log_path = workdir / "fuzz-sitl.log"
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("127.0.0.1", self.udp_port))
        self.udp.settimeout(0.2)
        self.vehicle_udp: tuple[str, int] | None = None
        self.tcp: socket.socket | None = None
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._codec = new_codec(GCS_SYSTEM_ID, GCS_COMPONENT_ID)
        self._ping_seq = 0
        self._send_lock = threading.Lock()

    # -- life cycle -------------------------------------------------------------------------
    def __enter__(self) -> FuzzTarget:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> None:
        state = self.workdir / "state"
        config = self.workdir / "fuzz.toml"
        config.write_text(f'[vehicle]\nstate_dir = "{state}"\n[links]\n'
                          f'udp_targets = ["127.0.0.1:{self.udp_port}"]\n'
                          f'tcp_listen = "127.0.0.1:{self.tcp_port}"\n'
                          f'serial = ["{self.serial_device}:57600"]\n', encoding="utf-8")
        args = [*usv_command(), "sitl", "-c", str(config), "--speedup", str(self.speedup)]
        log = open(self.log_path, "wb")  # noqa: SIM115 - the process owns it until stop()
        self.proc = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1"})
        log.close()
        self._spawn(self._read_udp)
        self._spawn(self._read_serial)
        deadline = time.monotonic() + READY_TIMEOUT_S
        while b"ready" not in self.log_path.read_bytes() or self.vehicle_udp is None:
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"usv sitl did not start:\n{self.log_path.read_text(errors='replace')}")
            time.sleep(0.1)
        self.tcp = self.connect_tcp()
        self._spawn(self._read_tcp)
        # the first samples after "ready" may stall the loop (the estimator's first step): wait
        # until the vehicle answers on every link before any fuzzing
        for channel in Channel:
            while not self.check_alive(channel).ok:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    self.stop()
                    raise RuntimeError(f"usv sitl does not answer on {channel.value}:\n"
                                       f"{self.log_path.read_text(errors='replace')}")

    def stop(self) -> None:
        self._stop.set()
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        for thread in self._threads:
            thread.join(2)
        for close in (self.udp.close, *(() if self.tcp is None else (self.tcp.close,))):
            with contextlib.suppress(OSError):
                close()
        for fd in (self.master_fd, self.slave_fd):
            with contextlib.suppress(OSError):
                os.close(fd)

    @property
    def pid(self) -> int:
        assert self.proc is not None
        return self.proc.pid

    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def rss_kb(self) -> int:
        return rss_kb(self.pid)

    # -- readers ----------------------------------------------------------------------------
    def _spawn(self, target: Any) -> None:
        thread = threading.Thread(target=target, daemon=True)
        thread.start()
        self._threads.append(thread)

    def _read_udp(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self.udp.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            self.vehicle_udp = addr
            self.inbox[Channel.UDP].feed(data)

    def _read_tcp(self) -> None:
        assert self.tcp is not None
        while not self._stop.is_set():
            try:
                data = self.tcp.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            if not data:
                return
            self.inbox[Channel.TCP].feed(data)

    def _read_serial(self) -> None:
        import select

        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self.master_fd], [], [], 0.2)
                if ready:
                    self.inbox[Channel.SERIAL].feed(os.read(self.master_fd, 65536))
            except OSError:
                time.sleep(0.05)  # the vehicle has the slave closed for a moment (reopening)

    # -- sending ----------------------------------------------------------------------------
    def connect_tcp(self) -> socket.socket:
        sock = socket.create_connection(("127.0.0.1", self.tcp_port), timeout=5.0)
        sock.settimeout(0.2)
        return sock

    def send(self, channel: Channel, data: bytes) -> None:
        """Write ``data`` on one link (one datagram on UDP; bytes on the TCP and serial streams)."""
        with self._send_lock:
            if channel is Channel.UDP:
                assert self.vehicle_udp is not None
                self.udp.sendto(data, self.vehicle_udp)
            elif channel is Channel.TCP:
                assert self.tcp is not None
                self.tcp.sendall(data)
            else:
                view = memoryview(data)
                deadline = time.monotonic() + 5.0
                while view and time.monotonic() < deadline:
                    try:
                        view = view[os.write(self.master_fd, view):]
                    except BlockingIOError:
                        time.sleep(0.001)

    def send_msg(self, channel: Channel, msg: Any) -> None:
        frame = msg.pack(self._codec)
        self._codec.seq = (self._codec.seq + 1) % 256
        self.send(channel, bytes(frame))

    def cut_tcp_connections(self, frames: list[bytes]) -> int:
        """One TCP connection per frame: half of the frame is sent, then the connection is cut."""
        for frame in frames:
            with contextlib.closing(self.connect_tcp()) as sock:
                sock.sendall(frame[:max(1, len(frame) // 2)])
        return len(frames)

    # -- the check --------------------------------------------------------------------------
    def check_alive(self, channel: Channel) -> AliveReport:
        """PING answered, PARAM_VALUE of SYSID_THISMAV, and a HEARTBEAT not older than
        :data:`HEARTBEAT_FRESH_S` (1 Hz stream), on ``channel``."""
        inbox = self.inbox[channel]
        missing: list[str] = ["process"]
        for attempt in range(1, ALIVE_ATTEMPTS + 1):
            if not self.running():
                return AliveReport(False, attempt, ["process"])
            since = time.monotonic()
            self._ping_seq = (self._ping_seq + 1) % 2**32
            seq = self._ping_seq
            # a burst of zeros first: on a byte stream it completes any frame the noise left
            # half-received (its checksum then fails and the parser resynchronises)
            if channel is not Channel.UDP:
                self.send(channel, bytes(280))
            self.send_msg(channel, mav.MAVLink_ping_message(int(since * 1e6), seq, 0, 0))
            self.send_msg(channel, mav.MAVLink_param_request_read_message(1, 1, b"SYSID_THISMAV", -1))
            checks: dict[str, Callable[[Any], bool]] = {
                "PING": functools.partial(_is_ping_answer, seq=seq),
                "PARAM_VALUE": lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == "SYSID_THISMAV",
                "HEARTBEAT": lambda m: m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1,
            }
            # heartbeats come at 1 Hz: one from the last HEARTBEAT_FRESH_S counts as fresh
            missing = [name for name, match in checks.items()
                       if inbox.wait(since - (HEARTBEAT_FRESH_S if name == "HEARTBEAT" else 0.0),
                                     match, ALIVE_TIMEOUT_S) is None]
            if not missing:
                return AliveReport(True, attempt, [])
        return AliveReport(False, ALIVE_ATTEMPTS, missing)
