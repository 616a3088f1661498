"""AUTO (Rover 10): run the uploaded mission item by item.

Navigation items: NAV_WAYPOINT (param1 hold s, param2 acceptance radius m), NAV_LOITER_UNLIM,
NAV_LOITER_TIME (param1 s), NAV_LOITER_TURNS (param1 turns) with param3 the radius (0: keep
station bow into the current; > 0 circle clockwise, < 0 anticlockwise), NAV_DELAY (param1 s,
keeping station), NAV_RETURN_TO_LAUNCH, and the payload items USV_CMD_NAV_SAMPLE_HERE (circle
the point, take a sample on the circle) and USV_CMD_NAV_LAUNCH_AT (bow on the bearing, fire).
Immediate items: DO_CHANGE_SPEED, DO_JUMP, DO_SET_HOME, DO_SET_SERVO, DO_SET_RELAY,
CONDITION_DELAY.  Items are validated at upload (:mod:`companion.mission.validate`), so a bad
coordinate never reaches this mode.  After the last item the mission is COMPLETE and the boat
goes to HOLD or LOITER according to MIS_DONE_BEHAVE.
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import TYPE_CHECKING, Any

from companion.control.target import ControlTarget
from companion.guidance.geo import wrap_pi
from companion.messages import ActuatorCommand, ModeNumber, NavState, Severity
from companion.mission import items as mi
from companion.modes.base import StandardMode
from companion.modes.host import ModeHost
from companion.modes.navigation import (
    CircleTask,
    GotoTask,
    NavMode,
    StationTask,
    param,
    wp_speed_mps,
)

if TYPE_CHECKING:
    from companion.mission.items import MissionItem
    from companion.payloads.registry import Payloads

log = logging.getLogger(__name__)

CMD_NAV_LAUNCH_AT = 31000
LAUNCH_HEADING_TOL_DEG = 10.0
"""Bow within this many degrees of the launch bearing before the launcher may fire."""
LAUNCH_MAX_DIST_M = 8.0
"""Farther than this from the launch point, the boat goes back to it before turning to fire."""
LAUNCH_MAX_SPEED_MPS = 1.8
"""'Stopped' for a water jet holding a heading: steerage way is about 1.5 m/s in SITL."""
CMD_NAV_SAMPLE_HERE = 31001
NAV_COMMANDS = frozenset({mi.CMD_NAV_WAYPOINT, mi.CMD_NAV_LOITER_UNLIM, mi.CMD_NAV_LOITER_TIME,
                          mi.CMD_NAV_LOITER_TURNS, mi.CMD_NAV_RETURN_TO_LAUNCH, mi.CMD_NAV_DELAY,
                          CMD_NAV_LAUNCH_AT, CMD_NAV_SAMPLE_HERE})
POSITION_COMMANDS = NAV_COMMANDS - {mi.CMD_NAV_RETURN_TO_LAUNCH, mi.CMD_NAV_DELAY}


class AutoMode(NavMode):
    number = ModeNumber.AUTO
    name = "AUTO"
    standard_mode = StandardMode.MISSION
    description = "Auto: run the uploaded mission (waypoints, loiters, delays, speed, RTL, sampling, launch)."

    def __init__(self) -> None:
        super().__init__()
        self.seq = -1
        self.phase = ""
        self.speed_override: float | None = None
        self._since_s = 0.0
        self._last_point: tuple[float, float] | None = None
        self._jumps_done: dict[int, int] = {}
        self._job: Any = None
        self._fire: asyncio.Task[str | None] | None = None
        self._launch_bearing = 0.0
        self._launch_steer: _HeadingTask | None = None

    # -- mode interface ------------------------------------------------------------------
    def requirements(self, host: ModeHost) -> str | None:
        items = [i for i in host.mission.items() if i.seq >= host.mission.first_seq]
        if not items:
            return "no mission uploaded"
        if not any(i.command in NAV_COMMANDS for i in items):
            return "mission has no navigation item"
        return super().requirements(host)

    def enter(self, host: ModeHost) -> None:
        super().enter(host)
        host.mission.start()
        self.speed_override = host.speed_override_mps
        self._jumps_done = {}
        self.task = None  # no crab estimate carried in from an earlier AUTO run
        nav = host.nav()
        assert nav is not None
        self._last_point = (nav.lat_deg, nav.lon_deg)
        self._start(host, nav, host.mission.current_seq)

    def exit(self, host: ModeHost) -> None:
        super().exit(host)
        if self._fire is not None and not self._fire.done():
            self._fire.cancel()
        self.seq = -1

    def update(self, host: ModeHost, nav: NavState) -> ActuatorCommand | None:
        if host.mission.current_seq != self.seq:  # the operator jumped (MISSION_SET_CURRENT)
            self._start(host, nav, host.mission.current_seq)
        if self.seq < 0:
            return None
        item = self._item(host, self.seq)
        if item is None:
            self._finish(host)
            return None
        if self._run(host, nav, item):
            if item.command in NAV_COMMANDS:
                host.mission.report_reached(item.seq)
                if item.command in POSITION_COMMANDS:
                    self._last_point = (item.lat_deg, item.lon_deg)
            self._advance(host, nav, self.seq + 1)
        elif self.task is not None:
            return self.run_task(host, nav, self.task)
        return None

    # -- item sequencing -----------------------------------------------------------------
    def _item(self, host: ModeHost, seq: int) -> MissionItem | None:
        return next((i for i in host.mission.items() if i.seq == seq), None)

    def _advance(self, host: ModeHost, nav: NavState, seq: int) -> None:
        if self._item(host, seq) is None:
            self._finish(host)
            return
        host.mission.set_current(seq)
        self._start(host, nav, seq)

    def _finish(self, host: ModeHost) -> None:
        self.seq = -1
        host.mission_complete()
        behave = int(param(host.params, "MIS_DONE_BEHAVE"))
        reason = host.set_mode(ModeNumber.LOITER if behave == 1 else ModeNumber.HOLD)
        if reason:
            host.status(f"AUTO: mission done, {reason}", Severity.WARNING)

    def _start(self, host: ModeHost, nav: NavState, seq: int) -> None:
        """Begin item ``seq``: immediate items run at once and the next one starts."""
        for _ in range(64):  # bounded: a DO_JUMP loop of immediate items cannot hang the loop
            self.seq = seq
            item = self._item(host, seq)
            if item is None:
                self._finish(host)
                return
            self.phase, self._since_s, self._job, self._fire = "start", nav.t_s, None, None
            if item.command in NAV_COMMANDS:
                self._begin_nav(host, nav, item)
                return
            nxt = self._immediate(host, item)
            if nxt is None:  # a condition that waits (CONDITION_DELAY)
                return
            if self._item(host, nxt) is None:
                self._finish(host)
                return
            host.mission.set_current(nxt)
            seq = nxt
        host.status("AUTO: too many jumps without a navigation item; stopping", Severity.ERROR)
        self._finish(host)

    def _immediate(self, host: ModeHost, item: MissionItem) -> int | None:
        """Run a DO/condition item; the next sequence number, or None to wait on it."""
        c = item.command
        if c == mi.CMD_DO_CHANGE_SPEED:
            if item.param2 > 0:
                self.speed_override = item.param2
        elif c == mi.CMD_DO_JUMP:
            done = self._jumps_done.get(item.seq, 0)
            repeat = int(item.param2)
            if repeat < 0 or done < repeat:
                self._jumps_done[item.seq] = done + 1
                return int(item.param1)
        elif c == mi.CMD_DO_SET_HOME:
            nav = host.nav()
            if item.param1 == 1 and nav is not None:
                host.set_home(nav.lat_deg, nav.lon_deg)
            elif item.is_global:
                host.set_home(item.lat_deg, item.lon_deg)
        elif c == mi.CMD_DO_SET_SERVO:
            host.set_servo_override(int(item.param1), int(item.param2))
        elif c == mi.CMD_DO_SET_RELAY:
            host.set_relay_state(int(item.param1), bool(item.param2))
        elif c == mi.CMD_CONDITION_DELAY:
            self.phase = "delay"
            return None
        else:
            host.status(f"AUTO: item {item.seq} command {c} not supported; skipped", Severity.WARNING)
        return item.seq + 1

    def _next_point(self, host: ModeHost, seq: int) -> tuple[float, float] | None:
        nxt = self._item(host, seq + 1)
        while nxt is not None and nxt.command not in NAV_COMMANDS:
            nxt = self._item(host, nxt.seq + 1)
        if nxt is None or nxt.command != mi.CMD_NAV_WAYPOINT:
            return None
        return (nxt.lat_deg, nxt.lon_deg)

    def _begin_nav(self, host: ModeHost, nav: NavState, item: MissionItem) -> None:
        params = host.params
        here = (nav.lat_deg, nav.lon_deg)
        speed = wp_speed_mps(params, self.speed_override)
        c = item.command
        if c == mi.CMD_NAV_DELAY:
            self.task, self.phase = StationTask(params, here, nav.heading_rad), "delay"
            return
        if c == mi.CMD_NAV_RETURN_TO_LAUNCH:
            if host.home is None:
                host.status("AUTO: no home for RETURN_TO_LAUNCH; keeping station", Severity.WARNING)
                self.task, self.phase = StationTask(params, here, nav.heading_rad), "hold"
                return
            target = (host.home.lat_deg, host.home.lon_deg)
        else:
            target = (item.lat_deg, item.lon_deg)
        start = self._last_point or here
        if math.dist(start, here) * 111_000 > 50.0:  # knocked far off the old leg: start from here
            start = here
        accept = item.param2 if c == mi.CMD_NAV_WAYPOINT and item.param2 > 0 else None
        nxt = self._next_point(host, item.seq) if c == mi.CMD_NAV_WAYPOINT and item.param1 <= 0 else None
        carried = self.task.follower if isinstance(self.task, GotoTask) else None  # last leg's crab estimate
        self.task = GotoTask(params, start, target, speed, accept, nxt, follower=carried)
        self.phase = "goto"

    def _run(self, host: ModeHost, nav: NavState, item: MissionItem) -> bool:
        """Advance the current item's state machine; True when the item is done."""
        c, t = item.command, nav.t_s
        if self.phase == "delay":
            return t - self._since_s >= max(0.0, item.param1)
        if self.phase == "goto":
            assert isinstance(self.task, GotoTask)
            # circles take over 15 m out (the circle law approaches by itself); the rest on arrival
            arrived = self.task.distance_m <= 15.0 if self._circles(item) else self.task.reached
            return self._arrived(host, nav, item) if arrived else False
        if self.phase == "loiter":
            if c == mi.CMD_NAV_LOITER_UNLIM:
                return False
            if c == mi.CMD_NAV_LOITER_TURNS and isinstance(self.task, CircleTask):
                return self.task.turns >= item.param1
            if c == mi.CMD_NAV_LOITER_TURNS:
                return t - self._since_s >= 60.0 * item.param1  # no radius: a minute per turn
            hold = item.param1
            return t - self._since_s >= hold
        if self.phase == "sample":
            return self._sample(host, nav, item)
        if self.phase == "launch":
            return self._launch(host, nav, item)
        return True

    @staticmethod
    def _circles(item: MissionItem) -> bool:
        loiters = (mi.CMD_NAV_LOITER_UNLIM, mi.CMD_NAV_LOITER_TIME, mi.CMD_NAV_LOITER_TURNS)
        return item.command == CMD_NAV_SAMPLE_HERE or (item.command in loiters and abs(item.param3) > 0)

    def _arrived(self, host: ModeHost, nav: NavState, item: MissionItem) -> bool:
        params = host.params
        c, point = item.command, (item.lat_deg, item.lon_deg)
        self._since_s = nav.t_s
        if c == mi.CMD_NAV_WAYPOINT:
            if item.param1 > 0:
                self.task, self.phase = StationTask(params, point, nav.heading_rad), "loiter"
                return False
            return True
        if c == mi.CMD_NAV_RETURN_TO_LAUNCH:
            return True
        if c in (mi.CMD_NAV_LOITER_UNLIM, mi.CMD_NAV_LOITER_TIME, mi.CMD_NAV_LOITER_TURNS):
            if abs(item.param3) > 0:
                self.task = CircleTask(params, point, abs(item.param3), clockwise=item.param3 > 0)
            else:
                self.task = StationTask(params, point, nav.heading_rad)
            self.phase = "loiter"
            return False
        if c == CMD_NAV_SAMPLE_HERE:
            default_radius_m = params.get_or("USV_SMPL_CIRC_M", params.get("USV_TURN_RAD"))
            radius = item.param2 if item.param2 > 0 else default_radius_m
            self.task, self.phase = CircleTask(params, point, radius), "sample"
            return False
        if c == CMD_NAV_LAUNCH_AT:
            self.phase = "launch"
            bearing = math.radians(item.param1) if math.isfinite(item.param1) else nav.heading_rad
            self._launch_bearing = bearing
            self.task = StationTask(params, point, bearing)
            self._launch_steer = _HeadingTask(bearing, self.task, speed_mps=0.0)
            return False
        return True

    def _sample(self, host: ModeHost, nav: NavState, item: MissionItem) -> bool:
        task = self.task
        assert isinstance(task, CircleTask)
        if self._job is None:
            if task.on_circle_since_s is None:
                return False
            payloads = _payloads(host, "no water sampler; sample item skipped")
            if payloads is None:
                return True
            accept = host.params.get_or("USV_SMPL_ACC_M", task.radius_m + 0.5)
            job = payloads.start_sample(
                bottle=int(item.param1) if math.isfinite(item.param1) else 0,
                fill_s=item.param3 if item.param3 > 0 else None,
                volume_ml=item.param4 if item.param4 > 0 else None,
                mission_seq=item.seq, target=(item.lat_deg, item.lon_deg),
                accept_radius_m=accept)
            if isinstance(job, str):
                return True  # refused (announced by the payload); continue the mission
            self._job = job
        return bool(self._job.done.done())

    def _launch(self, host: ModeHost, nav: NavState, item: MissionItem) -> bool:
        """Bow on the bearing, slowed to steerage way, hold, fire.

        A water jet cannot reverse and needs thrust to steer, so "stop" means the slowest
        speed at which it still holds a heading: the controller is asked for zero speed on the
        bearing and the launcher fires once the bow has stayed within
        ``LAUNCH_HEADING_TOL_DEG`` at no more than ``LAUNCH_MAX_SPEED_MPS`` for ``hold`` s.
        """
        if self._fire is not None:
            return self._fire.done()
        err = abs(wrap_pi(self._launch_bearing - nav.heading_rad))
        hold = item.param2 if item.param2 > 0 else host.params.get_or("USV_LNCH_HOLD_S", 3.0)
        station = self._launch_steer.inner if self._launch_steer is not None else None
        if station is not None and station.distance_m > LAUNCH_MAX_DIST_M:
            self._since_s = nav.t_s  # carried off the point while turning: station-keep back to it
            self.task = station
            return False
        # steer for the bearing asking for zero speed: the jet keeps only steerage way
        self.task = self._launch_steer
        if err > math.radians(LAUNCH_HEADING_TOL_DEG) or nav.speed_over_ground_mps > LAUNCH_MAX_SPEED_MPS:
            self._since_s = nav.t_s
            return False
        if nav.t_s - self._since_s < hold:
            return False
        payloads = _payloads(host, "no rope launcher; launch item skipped")
        if payloads is None:
            return True
        self._fire = asyncio.get_running_loop().create_task(payloads.mission_fire(item.seq))
        return False


class _HeadingTask:
    """Point the bow at ``heading_rad`` at walking speed while staying near the launch point."""

    def __init__(self, heading_rad: float, inner: Any, speed_mps: float = 0.3) -> None:
        self.heading_rad = heading_rad
        self.speed_mps = speed_mps
        self.inner: Any = inner.inner if isinstance(inner, _HeadingTask) else inner
        self.frame, self.point = self.inner.frame, self.inner.point
        self.distance_m = 0.0
        self.cross_track_m = 0.0

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        self.inner.step(nav, dt_s)
        self.distance_m = self.inner.distance_m
        return ControlTarget(self.heading_rad, self.speed_mps, is_heading=True)


def _payloads(host: ModeHost, missing: str) -> Payloads | None:
    """The vehicle's payloads, or None after telling the operator ``AUTO: <missing>``."""
    if host.payloads is None:
        host.status(f"AUTO: {missing}", Severity.WARNING)
    return host.payloads
