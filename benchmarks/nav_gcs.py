"""A plain pymavlink ground station for ``usv bench nav``: what a QGC user or a script does.

It listens where the vehicle sends (``udpin``), sends HEARTBEAT every
:data:`GCS_HEARTBEAT_PERIOD_WALL_S` of wall time whatever the vehicle's clock does (as QGC and
MAVSDK do), arms, changes modes with DO_SET_MODE, sends go-tos with DO_REPOSITION, uploads
missions item by item, reads parameters, and keeps a timeline of what it saw, stamped with the
vehicle's own clock (``time_boot_ms`` of the latest message that carries one).  Everything is
single-threaded: every wait goes through :meth:`GroundStation.pump`, which also sends the
heartbeats, so nothing races on the socket.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

GCS_HEARTBEAT_PERIOD_WALL_S = 0.1
"""Wall seconds between the ground station's HEARTBEATs.  QGroundControl and MAVSDK send 1 Hz of wall
time and the bench must finally run with 1.0.  Until the GCS-loss rule also counts wall time (issue 15:
lost only after FS_GCS_TIMEOUT of vehicle time *and* a few seconds of wall time), 1 Hz at the bench's
speed-up (20x) means 20 s of vehicle time between heartbeats, which trips FS_GCS_TIMEOUT (5 s) and
spoils every figure; 0.1 s is 2 s of vehicle time.  Set to 1.0 when that rule is on main."""

MODE_HOLD, MODE_LOITER, MODE_AUTO, MODE_RTL, MODE_GUIDED = 4, 5, 10, 11, 15
"""ArduPilot Rover mode numbers (the vehicle's default ``ardurover`` profile)."""

MAV_CMD_USV_NAV_SAMPLE_HERE = 31001
"""USV_CMD_NAV_SAMPLE_HERE of the boat's dialect (mavlink_dialect/usv.xml)."""


_UPLOAD_REPLIES = ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")


class GcsError(RuntimeError):
    """The vehicle did not answer as a ground station expects (timeout, refusal)."""


@dataclass
class Event:
    """Something the ground station saw or did, at vehicle time ``t_s``."""

    t_s: float
    kind: str
    value: Any = None


@dataclass
class Timeline:
    """What happened during a flight, in the vehicle's time base (seconds since its boot)."""

    events: list[Event] = field(default_factory=list)
    positions: list[tuple[float, float, float]] = field(default_factory=list)
    """(t_s, lat_deg, lon_deg) from GLOBAL_POSITION_INT: the vehicle's own estimate."""

    def add(self, t_s: float, kind: str, value: Any = None) -> None:
        self.events.append(Event(t_s, kind, value))

    def first(self, kind: str, after_s: float = -1.0) -> Event | None:
        return next((e for e in self.events if e.kind == kind and e.t_s >= after_s), None)

    def to_json(self) -> dict[str, Any]:
        return {"events": [[round(e.t_s, 3), e.kind, e.value] for e in self.events]}


class GroundStation:
    """One pymavlink ``udpin`` connection to the vehicle, system 255 component 190 (like QGC)."""

    def __init__(self, port: int, *, heartbeat_period_wall_s: float = GCS_HEARTBEAT_PERIOD_WALL_S) -> None:
        os.environ["MAVLINK20"] = "1"  # mission_type and other v2 extension fields
        from pymavlink import mavutil

        import companion.link.dialect  # noqa: F401  (adds the boat's messages to pymavlink's 'all')

        mavutil.set_dialect("all")
        self.mavutil = mavutil
        self.conn: Any = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255,
                                                    source_component=190, dialect="all")
        self.mav: Any = self.conn.mav
        self.heartbeat_period_wall_s = heartbeat_period_wall_s
        self._next_hb_wall = 0.0
        self.t_s = 0.0
        """Vehicle time (s since boot) of the latest timestamped message."""
        self.timeline = Timeline()
        self.mode = -1
        self.armed = False
        self.home: tuple[float, float] | None = None
        self.position: tuple[float, float] | None = None
        self.mission_seq = -1
        self.mission_state = 0
        self.statustexts: list[tuple[float, str]] = []
        self.failsafe = False
        self._samples_seen: set[tuple[int, int]] = set()

    def close(self) -> None:
        self.conn.close()

    def _heard(self) -> bool:
        """Whether the vehicle's address is known (pymavlink's udpin keeps its peers in ``clients``)."""
        return bool(self.conn.clients)

    # -- receiving ------------------------------------------------------------------------
    def pump(self, wall_timeout_s: float = 0.05) -> Any:
        """Receive one message (or time out), keep the timeline, send the heartbeat when due."""
        now = time.monotonic()
        if now >= self._next_hb_wall and self._heard():
            self.mav.heartbeat_send(self.mavutil.mavlink.MAV_TYPE_GCS,
                                    self.mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self._next_hb_wall = now + self.heartbeat_period_wall_s
        wait = max(0.0, min(wall_timeout_s, self._next_hb_wall - now)) if self._heard() \
            else wall_timeout_s
        msg = self.conn.recv_match(blocking=True, timeout=wait)
        if msg is not None:
            self._observe(msg)
        return msg

    def _observe(self, msg: Any) -> None:
        kind = msg.get_type()
        if hasattr(msg, "time_boot_ms") and msg.get_srcComponent() == 1:
            self.t_s = max(self.t_s, msg.time_boot_ms / 1000.0)
        t, tl = self.t_s, self.timeline
        if kind == "HEARTBEAT" and msg.get_srcComponent() == 1:
            armed = bool(msg.base_mode & self.mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            if msg.custom_mode != self.mode:
                tl.add(t, "mode", int(msg.custom_mode))
            if armed != self.armed:
                tl.add(t, "armed", armed)
            self.mode, self.armed = int(msg.custom_mode), armed
        elif kind == "GLOBAL_POSITION_INT":
            self.position = (msg.lat / 1e7, msg.lon / 1e7)
            tl.positions.append((t, *self.position))
        elif kind == "HOME_POSITION":
            self.home = (msg.latitude / 1e7, msg.longitude / 1e7)
        elif kind == "MISSION_CURRENT":
            if msg.seq != self.mission_seq:
                tl.add(t, "mission_current", int(msg.seq))
            state = int(getattr(msg, "mission_state", 0))
            if state != self.mission_state:
                tl.add(t, "mission_state", state)
            self.mission_seq, self.mission_state = int(msg.seq), state
        elif kind == "MISSION_ITEM_REACHED":
            tl.add(t, "reached", int(msg.seq))
        elif kind == "STATUSTEXT":
            text = msg.text if isinstance(msg.text, str) else msg.text.decode(errors="replace")
            self.statustexts.append((t, text))
            tl.add(t, "statustext", text)
            self.failsafe |= "failsafe" in text.lower() and "cleared" not in text.lower()
        elif kind == "USV_SAMPLER_STATUS" and msg.last_sample_bottle:
            key = (int(msg.last_sample_bottle), int(msg.last_sample_time_unix_usec))
            if key not in self._samples_seen:
                self._samples_seen.add(key)
                tl.add(t, "sample_reported", [key[0], float(msg.last_sample_distance)])

    def wait(self, done: Callable[[], bool], *, vehicle_s: float, wall_s: float | None = None,
             what: str = "condition") -> None:
        """Pump until ``done()``; fail after ``vehicle_s`` of vehicle time or ``wall_s`` of wall time
        (default: as long as ``vehicle_s`` at a third of real time, a guard against a stalled vehicle)."""
        wall_s = 30.0 + 3.0 * vehicle_s if wall_s is None else wall_s
        start_t, start_wall = self.t_s, time.monotonic()
        while not done():
            if self.t_s - start_t > vehicle_s or time.monotonic() - start_wall > wall_s:
                raise GcsError(f"timed out waiting for {what} (vehicle t={self.t_s:.1f} s)")
            self.pump()

    def wait_message(self, kind: str, cond: Callable[[Any], bool] | None = None, *,
                     wall_s: float = 10.0) -> Any:
        deadline = time.monotonic() + wall_s
        while time.monotonic() < deadline:
            msg = self.pump()
            if msg is not None and msg.get_type() == kind and (cond is None or cond(msg)):
                return msg
        raise GcsError(f"no {kind} within {wall_s} s of wall time")

    def sleep_vehicle(self, seconds: float) -> None:
        """Let ``seconds`` of vehicle time pass (the ground station keeps listening)."""
        end = self.t_s + seconds
        self.wait(lambda: self.t_s >= end, vehicle_s=seconds + 5.0, what="vehicle time")

    # -- sending --------------------------------------------------------------------------
    def connect(self, wall_s: float = 60.0) -> None:
        """Wait for the vehicle's heartbeat and home, then ask for positions at ``GPI_RATE_HZ``."""
        self.wait_message("HEARTBEAT", lambda m: m.get_srcComponent() == 1, wall_s=wall_s)
        self.pump(0.0)  # first heartbeat of ours
        self.command(self.mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 1e6 / GPI_RATE_HZ)
        self.wait(lambda: self.home is not None and self.position is not None, vehicle_s=30.0,
                  what="home position")

    def command(self, cmd: int, *params: float, retries: int = 2, wall_s: float = 3.0) -> int:
        """COMMAND_LONG; returns the final MAV_RESULT (raises when no ACK comes)."""
        p = [*params, *[0.0] * (7 - len(params))]
        for attempt in range(retries + 1):
            self.mav.command_long_send(1, 1, cmd, attempt, *p)
            try:
                ack = self.wait_message("COMMAND_ACK", lambda m: m.command == cmd and m.result != 5,
                                        wall_s=wall_s)
            except GcsError:
                continue
            self.timeline.add(self.t_s, "ack", [int(cmd), int(ack.result)])
            return int(ack.result)
        raise GcsError(f"no COMMAND_ACK for command {cmd}")

    def command_int(self, cmd: int, lat_deg: float, lon_deg: float, *params: float) -> int:
        p = [*params, *[0.0] * (4 - len(params))]
        self.mav.command_int_send(1, 1, self.mavutil.mavlink.MAV_FRAME_GLOBAL_INT, cmd, 0, 0, *p,
                                  round(lat_deg * 1e7), round(lon_deg * 1e7), 0.0)
        ack = self.wait_message("COMMAND_ACK", lambda m: m.command == cmd and m.result != 5)
        self.timeline.add(self.t_s, "ack", [int(cmd), int(ack.result)])
        return int(ack.result)

    def arm(self, vehicle_s: float = 60.0) -> None:
        """Arm, retrying every vehicle second until the pre-arm checks pass."""
        end = self.t_s + vehicle_s
        while self.t_s < end:
            if self.command(self.mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0:
                return
            self.sleep_vehicle(1.0)
        raise GcsError("the vehicle refused to arm")

    def set_mode(self, mode: int) -> None:
        """DO_SET_MODE as MAVProxy and MAVSDK send it; the timeline gets ``set_mode`` at the ACK."""
        result = self.command(self.mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, mode)
        if result != 0:
            raise GcsError(f"mode {mode} refused (MAV_RESULT {result}): {self.statustexts[-1:]}")
        self.timeline.add(self.t_s, "set_mode", mode)
        self.mission_state = -1  # a mission state from before the change says nothing about this one
        self.wait(lambda: self.mode == mode, vehicle_s=5.0, what=f"HEARTBEAT in mode {mode}")

    def goto(self, lat_deg: float, lon_deg: float) -> None:
        """GUIDED, then DO_REPOSITION as COMMAND_INT (what MAVSDK's Action.goto_location sends)."""
        self.set_mode(MODE_GUIDED)
        result = self.command_int(self.mavutil.mavlink.MAV_CMD_DO_REPOSITION, lat_deg, lon_deg, -1, 0)
        if result != 0:
            raise GcsError(f"DO_REPOSITION refused (MAV_RESULT {result})")
        self.timeline.add(self.t_s, "goto", [lat_deg, lon_deg])

    def read_param(self, name: str) -> float:
        self.mav.param_request_read_send(1, 1, name.encode(), -1)
        msg = self.wait_message("PARAM_VALUE", lambda m: m.param_id == name)
        return float(msg.param_value)

    def upload_mission(self, items: list[tuple[int, int, tuple[float, ...], float, float]]) -> None:
        """Upload ``(frame, command, (param1..4), lat_deg, lon_deg)`` items, home placeholder first
        (the QGC/MAVProxy convention for an ArduPilot vehicle)."""
        mavlink = self.mavutil.mavlink
        assert self.home is not None
        plan = [(mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, (0.0,) * 4, *self.home), *items]
        self.mav.mission_count_send(1, 1, len(plan), mavlink.MAV_MISSION_TYPE_MISSION)
        while True:
            msg = self._next_request()
            if msg.get_type() == "MISSION_ACK":
                if msg.type != mavlink.MAV_MISSION_ACCEPTED:
                    raise GcsError(f"mission refused (MAV_MISSION_RESULT {msg.type}): "
                                   f"{self.statustexts[-1:]}")
                self.timeline.add(self.t_s, "mission_uploaded", len(plan))
                return
            frame, cmd, p, lat, lon = plan[msg.seq]
            self.mav.mission_item_int_send(1, 1, msg.seq, frame, cmd, 0, 1, *p, round(lat * 1e7),
                                           round(lon * 1e7), 0.0, mavlink.MAV_MISSION_TYPE_MISSION)

    def _next_request(self) -> Any:
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            msg = self.pump()
            if msg is not None and msg.get_type() in _UPLOAD_REPLIES:
                return msg
        raise GcsError("mission upload: the vehicle stopped asking for items")


GPI_RATE_HZ = 10.0
"""GLOBAL_POSITION_INT rate the ground station asks for (vehicle time)."""
