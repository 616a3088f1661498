"""A pymavlink ground station on the TCP port of a ``usv sitl`` process, with or without a signing key.

It uses pymavlink as a ground-station script would: ``mavutil.mavlink_connection`` (MAVLink 2)
and ``setup_signing`` (key, link id, timestamp from the wall clock).  A thread records every
message the vehicle sends, with whether it arrived signed; :meth:`Station.send` returns the
bytes of the frame it sent, so a test can replay them.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import Any

MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID = 6, 8
MAV_MODE_FLAG_SAFETY_ARMED = 128


class Station:
    """One ground station (TCP client) of the vehicle."""

    def __init__(self, port: int, *, key: bytes | None = None, system_id: int = 255,
                 link_id: int = 0) -> None:
        from pymavlink import mavutil

        previous = os.environ.get("MAVLINK20")
        os.environ["MAVLINK20"] = "1"  # mavutil picks the protocol version when the dialect is set
        try:
            self.conn: Any = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=system_id,
                                                        source_component=190, dialect="all",
                                                        autoreconnect=False)
        finally:
            if previous is None:
                os.environ.pop("MAVLINK20", None)
            else:
                os.environ["MAVLINK20"] = previous
        if key is not None:
            self.conn.setup_signing(key, sign_outgoing=True, link_id=link_id)
        self.mav = self.conn.mav
        self.received: list[Any] = []
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._receive, daemon=True),
                         threading.Thread(target=self._beat, daemon=True)]
        for thread in self._threads:
            thread.start()

    def close(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(5)
        self.conn.close()

    def _beat(self) -> None:
        while not self._stop.is_set():
            self.heartbeat()  # 1 Hz of wall time, as QGC and MAVProxy
            self._stop.wait(1.0)

    def __enter__(self) -> Station:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _receive(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self.conn.recv_match(blocking=True, timeout=0.2)
            except Exception:  # the connection closed under us
                return
            if msg is not None and msg.get_type() != "BAD_DATA":
                with self._lock:
                    self.received.append(msg)

    # -- sending ----------------------------------------------------------------------------
    def send(self, msg: Any) -> bytes:
        """Encode (and sign, with a key) ``msg``, send it and return the frame's bytes."""
        with self._send_lock:
            frame = msg.pack(self.mav)
            self.mav.seq = (self.mav.seq + 1) % 256
            self.conn.write(frame)
        return bytes(frame)

    def write(self, frame: bytes) -> None:
        """Send raw bytes (a replay)."""
        with self._send_lock:
            self.conn.write(frame)

    def heartbeat(self) -> None:
        self.send(self.mav.heartbeat_encode(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0))

    def command(self, command: int, *params: float) -> bytes:
        p = [*params, 0, 0, 0, 0, 0, 0, 0][:7]
        return self.send(self.mav.command_long_encode(1, 1, command, 0, *p))

    def param_set(self, name: str, value: float) -> bytes:
        return self.send(self.mav.param_set_encode(1, 1, name.encode(), value, 9))

    # -- receiving --------------------------------------------------------------------------
    def mark(self) -> int:
        with self._lock:
            return len(self.received)

    def messages(self, msg_type: str, since: int = 0) -> list[Any]:
        with self._lock:
            return [m for m in self.received[since:] if m.get_type() == msg_type]

    def wait(self, msg_type: str, predicate: Callable[[Any], bool] = lambda m: True, *,
             since: int | None = None, timeout_s: float = 20.0,
             give_up: Callable[[], bool] = lambda: False) -> Any | None:
        """The first ``msg_type`` after ``since`` (default: now) matching ``predicate``, or None
        after ``timeout_s`` or as soon as ``give_up()`` (no answer can come any more)."""
        start = self.mark() if since is None else since
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                for m in self.received[start:]:
                    if m.get_type() == msg_type and predicate(m):
                        return m
            if give_up():
                return None
            time.sleep(0.02)
        return None

    # -- vehicle state, as seen from this station ----------------------------------------------
    def armed(self) -> bool:
        hb = self.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1 and m.autopilot != MAV_AUTOPILOT_INVALID)
        assert hb is not None, "no vehicle heartbeat"
        return bool(hb.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)

    def param(self, name: str) -> float:
        for _ in range(5):
            since = self.mark()
            self.send(self.mav.param_request_read_encode(1, 1, name.encode(), -1))
            pv = self.wait("PARAM_VALUE", lambda m: m.param_id == name, since=since, timeout_s=3.0)
            if pv is not None:
                return float(pv.param_value)
        raise AssertionError(f"no PARAM_VALUE for {name}")

    def upload(self, items: list[tuple[float, float]], *, timeout_s: float = 20.0,
               give_up: Callable[[], bool] = lambda: False) -> int | None:
        """Upload waypoints (lat, lon deg) as a mission; returns the MISSION_ACK type, or None after
        ``timeout_s`` or as soon as ``give_up()`` (no answer can come any more)."""
        since = self.mark()
        frames = [self.mav.mission_item_int_encode(1, 1, i, 0 if i == 0 else 3, 16, 0, 1, 0, 2.0, 0, 0,
                                                   round(lat * 1e7), round(lon * 1e7), 0, 0)
                  for i, (lat, lon) in enumerate(items)]
        self.send(self.mav.mission_count_encode(1, 1, len(items), 0))
        deadline = time.monotonic() + timeout_s
        answered: set[int] = set()
        while time.monotonic() < deadline:
            with self._lock:
                new = self.received[since:]
            for m in new:
                since += 1
                if m.get_type() == "MISSION_ACK":
                    return int(m.type)
                if m.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and m.seq < len(frames):
                    self.send(frames[m.seq])
                    answered.add(m.seq)
            if give_up():
                return None
            time.sleep(0.01)
        return None

    def download(self, *, timeout_s: float = 20.0) -> list[tuple[float, float]]:
        """The mission as the vehicle serves it: (lat, lon deg) of every item."""
        since = self.mark()
        self.send(self.mav.mission_request_list_encode(1, 1, 0))
        count = self.wait("MISSION_COUNT", since=since, timeout_s=timeout_s)
        assert count is not None, "no MISSION_COUNT"
        out: list[tuple[float, float]] = []
        for seq in range(count.count):
            since = self.mark()
            self.send(self.mav.mission_request_int_encode(1, 1, seq, 0))
            item = self.wait("MISSION_ITEM_INT", lambda m, s=seq: m.seq == s, since=since,
                             timeout_s=timeout_s)
            assert item is not None, f"no item {seq}"
            out.append((round(item.x / 1e7, 6), round(item.y / 1e7, 6)))
        self.send(self.mav.mission_ack_encode(1, 1, 0, 0))
        return out
