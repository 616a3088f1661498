"""An external ground station for the SITL mission tests: pymavlink on a UDP port of ``usv sitl``.

It behaves as QGroundControl or MAVProxy do on the wire: a HEARTBEAT (type GCS) once per *wall*
second while :attr:`PymavlinkGcs.heartbeats` is set, commands answered by COMMAND_ACK, the
mission upload protocol.  A receiver thread records what the vehicle says, stamped with the
vehicle's clock (``time_boot_ms``), so tests can time failsafes in simulated seconds.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from companion.guidance.geo import distance_to_segment_m
from companion.mission.items import MissionItem

MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID = 6, 8
MAV_MODE_FLAG_SAFETY_ARMED = 128
CMD_DO_SET_MODE, CMD_ARM_DISARM = 176, 400
MODE_RTL = 11


@dataclass
class Seen:
    """What the vehicle said, in vehicle seconds."""

    t_s: float = 0.0
    mode: int = -1
    armed: bool = False
    system_status: int = 0
    position: tuple[float, float] | None = None
    home: tuple[float, float] | None = None
    texts: list[tuple[float, str]] = field(default_factory=list)
    reached: dict[int, float] = field(default_factory=dict)
    modes: list[tuple[float, int]] = field(default_factory=list)
    track: list[tuple[float, float, float]] = field(default_factory=list)
    acks: list[Any] = field(default_factory=list)
    mission_msgs: list[Any] = field(default_factory=list)


class PymavlinkGcs:
    """A ground station on ``udpin:127.0.0.1:<port>`` (the vehicle sends there)."""

    def __init__(self, port: int, *, heartbeats: bool = True, system_id: int = 255) -> None:
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=system_id,
                                               source_component=190, dialect="common")
        self.heartbeats = heartbeats
        self.last_heartbeat_t_s: float | None = None
        """Vehicle time of the last message received when the last heartbeat was sent."""
        self.seen = Seen()
        self._lock = threading.Lock()
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

    # -- threads ---------------------------------------------------------------------------
    def _beat(self) -> None:
        while not self._stop.is_set():
            if self.heartbeats and self.conn.clients:  # the vehicle's address is known once it spoke
                self.send(lambda mav: mav.heartbeat_send(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0))
                self.last_heartbeat_t_s = self.seen.t_s
            self._stop.wait(1.0)  # 1 Hz of wall time, whatever the simulator's speed

    def _receive(self) -> None:
        while not self._stop.is_set():
            msg = self.conn.recv_match(blocking=True, timeout=0.2)
            if msg is None or msg.get_srcSystem() != 1:
                continue
            s, kind = self.seen, msg.get_type()
            s.t_s = max(s.t_s, getattr(msg, "time_boot_ms", 0) / 1000.0)
            if kind == "HEARTBEAT" and msg.get_srcComponent() == 1:
                s.armed = bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
                s.system_status = msg.system_status
                if msg.custom_mode != s.mode:
                    s.modes.append((s.t_s, msg.custom_mode))
                s.mode = msg.custom_mode
            elif kind == "GLOBAL_POSITION_INT":
                s.position = (msg.lat / 1e7, msg.lon / 1e7)
                s.track.append((s.t_s, *s.position))
            elif kind == "HOME_POSITION":
                s.home = (msg.latitude / 1e7, msg.longitude / 1e7)
            elif kind == "STATUSTEXT":
                s.texts.append((s.t_s, msg.text))
            elif kind == "MISSION_ITEM_REACHED":
                s.reached.setdefault(msg.seq, s.t_s)
            elif kind == "COMMAND_ACK":
                s.acks.append(msg)
            elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"):
                s.mission_msgs.append(msg)

    # -- acting ----------------------------------------------------------------------------
    def send(self, build: Callable[[Any], None]) -> None:
        with self._lock:
            build(self.conn.mav)

    def wait(self, cond: Callable[[], bool], timeout_s: float, what: str) -> None:
        """Wait (wall seconds) until ``cond()``."""
        deadline = time.monotonic() + timeout_s
        while not cond():
            assert time.monotonic() < deadline, f"{what}: not in {timeout_s} s; texts {self.seen.texts[-8:]}"
            time.sleep(0.02)

    def command(self, command: int, *params: float, timeout_s: float = 10.0) -> int:
        p = [*params, *([0.0] * (7 - len(params)))]
        for _ in range(3):
            mark = len(self.seen.acks)
            self.send(lambda mav: mav.command_long_send(1, 1, command, 0, *p))
            deadline = time.monotonic() + timeout_s / 3
            while time.monotonic() < deadline:
                for ack in self.seen.acks[mark:]:
                    if ack.command == command:
                        return int(ack.result)
                time.sleep(0.02)
        raise AssertionError(f"no COMMAND_ACK for command {command}")

    def set_mode(self, mode: int) -> int:
        return self.command(CMD_DO_SET_MODE, 1, mode)

    def upload(self, plan: list[MissionItem], timeout_s: float = 30.0) -> int:
        """The mission upload protocol (MISSION_ITEM_INT); the MISSION_ACK result."""
        mark = len(self.seen.mission_msgs)
        self.send(lambda mav: mav.mission_count_send(1, 1, len(plan), 0))
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            msgs = self.seen.mission_msgs[mark:]
            mark += len(msgs)
            for m in msgs:
                if m.get_type() == "MISSION_ACK":
                    return int(m.type)
                it = plan[m.seq]
                self.send(self._item_sender(it, m.seq))
            time.sleep(0.01)
        raise AssertionError("mission upload did not finish")

    def settle(self) -> None:
        """A test or script that failed may leave the boat armed: RTL (as the ground station, with
        heartbeats), then disarm at home."""
        if not self.seen.armed:
            return
        self.heartbeats = True
        self.set_mode(MODE_RTL)
        home_reached = lambda: any("home reached" in t for _, t in self.seen.texts[-5:])  # noqa: E731
        self.wait(lambda: not self.seen.armed or home_reached(), 60, "RTL home")
        if self.seen.armed:
            self.command(CMD_ARM_DISARM, 0)
        self.wait(lambda: not self.seen.armed, 10, "disarm")

    @staticmethod
    def _item_sender(it: MissionItem, seq: int) -> Callable[[Any], None]:
        def send(mav: Any) -> None:
            mav.mission_item_int_send(1, 1, seq, it.frame, it.command, it.current, it.autocontinue, it.param1,
                                      it.param2, it.param3, it.param4, it.x, it.y, it.z, 0)
        return send

    def texts_since(self, t_s: float) -> list[str]:
        return [text for t, text in self.seen.texts if t >= t_s]


def min_distance_m(track: list[tuple[float, float]], point: tuple[float, float]) -> float:
    """Closest approach (m) of a polyline of (north, east) metres to ``point``."""
    path = [p for p, q in zip(track, [None, *track], strict=False) if p != q]  # no zero-length segments
    if len(path) == 1:
        return math.dist(path[0], point)
    return min(distance_to_segment_m(point, a, b) for a, b in itertools.pairwise(path))
