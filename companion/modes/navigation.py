"""Shared machinery of the navigating modes (LOITER, AUTO, GUIDED, RTL, CRUISE).

Navigation *tasks* are small stateful objects a mode runs one at a time: go to a point along a
leg (:class:`GotoTask`, ILOS/ALOS), keep station on a point with the bow into the current
(:class:`StationTask`), or circle a point (:class:`CircleTask`, GPS point tracking).  Each
``step(nav)`` returns a :class:`~companion.control.target.ControlTarget` for the host's
:class:`~companion.control.system.ControlSystem`.  Positions are handled in a flat-earth frame
anchored where the task starts (:mod:`companion.guidance.geo`).
"""

from __future__ import annotations

import math
from typing import Protocol

from companion.clock import StepTimer
from companion.control.target import ControlRequest, ControlTarget
from companion.guidance.circle import CircleTracker
from companion.guidance.geo import LocalFrame, distance_bearing, wrap_2pi, wrap_pi
from companion.guidance.los import LosFollower, LosType
from companion.guidance.params import circle_gains, leg_config, los_gains, station_gains
from companion.guidance.station import StationKeeper
from companion.guidance.waypoints import LegNavigator
from companion.messages import NavState
from companion.modes.base import Mode, NavTarget, requires_position
from companion.modes.host import ModeHost
from companion.params import ParamStore

FALLBACK_VALUES = {"WP_SPEED": 5.0, "CRUISE_SPEED": 5.0, "WP_RADIUS": 2.0, "LOIT_RADIUS": 2.0,
                   "MIS_DONE_BEHAVE": 0.0}
"""Used only if the ArduPilot-named parameters are not in the table (unit tests of one part)."""


def param(params: ParamStore, name: str) -> float:
    return params.get_or(name, FALLBACK_VALUES[name])


def wp_speed_mps(params: ParamStore, override: float | None = None) -> float:
    if override is not None and override > 0:
        return override
    speed = param(params, "WP_SPEED")
    return speed if speed > 0 else param(params, "CRUISE_SPEED")


def course_over_ground(nav: NavState) -> float:
    return math.atan2(nav.vel_east_mps, nav.vel_north_mps)


class GotoTask:
    """Follow the leg from ``start`` to ``end`` (lat, lon) at ``speed_mps``."""

    def __init__(self, params: ParamStore, start: tuple[float, float], end: tuple[float, float],
                 speed_mps: float, accept_radius_m: float | None = None,
                 next_point: tuple[float, float] | None = None, follower: LosFollower | None = None) -> None:
        """``follower``: the previous leg's LOS follower, so the crab (integral/adaptive) estimate
        of the current carries over a corner (scaled by the cosine of the turn) instead of being
        learnt again on every leg; a new one when None."""
        self.frame = LocalFrame(*start)
        self.end = end
        radius = accept_radius_m if accept_radius_m and accept_radius_m > 0 else param(params, "WP_RADIUS")
        los_type = LosType(int(params.get("USV_LOS_TYPE")))
        if follower is None or follower.los_type != los_type:
            follower = LosFollower(los_gains(params), los_type)
        self.follower = follower
        self.nav = LegNavigator(follower, leg_config(params, speed_mps, radius))
        nxt = self.frame.to_ne(*next_point) if next_point is not None else None
        self.nav.set_leg((0.0, 0.0), self.frame.to_ne(*end), nxt)
        self.point = end
        self.reached = False
        self.distance_m = math.inf
        self.cross_track_m = 0.0

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        pos = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        st = self.nav.update(pos, nav.speed_over_ground_mps, dt_s, course_over_ground(nav))
        end = self.nav.end
        self.distance_m = math.hypot(end[0] - pos[0], end[1] - pos[1])
        self.cross_track_m = st.errors.cross_m
        self.reached = self.reached or st.reached
        return st.target


class StationTask:
    """Keep station on ``point`` (lat, lon), bow into the current (active, not drifting)."""

    def __init__(self, params: ParamStore, point: tuple[float, float], heading_rad: float) -> None:
        self.frame = LocalFrame(*point)
        self.point = point
        self.keeper = StationKeeper((0.0, 0.0), station_gains(params), heading_rad)
        self.distance_m = 0.0
        self.cross_track_m = 0.0

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        out = self.keeper.update(self.frame.to_ne(nav.lat_deg, nav.lon_deg), dt_s)
        self.distance_m = out.distance_m
        return ControlTarget(out.heading_rad, out.surge_speed_mps, is_heading=True, hold_station=True)


class CircleTask:
    """Approach ``point`` and circle it at ``radius_m``; counts turns and time on the circle."""

    def __init__(self, params: ParamStore, point: tuple[float, float], radius_m: float,
                 clockwise: bool = True, approach_speed_mps: float = 3.0) -> None:
        self.frame = LocalFrame(*point)
        self.point = point
        self.radius_m = max(radius_m, params.get("USV_TURN_RAD"))
        self.tracker = CircleTracker((0.0, 0.0), self.radius_m, clockwise, circle_gains(params))
        self.circle_speed_mps = params.get("USV_CIRC_SPD")
        self.approach_speed_mps = approach_speed_mps
        self.on_circle_since_s: float | None = None
        self.turns = 0.0
        self._last_bearing: float | None = None
        self.distance_m = math.inf
        self.radial_error_m = math.inf
        self.cross_track_m = 0.0

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        pos = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        out = self.tracker.update(pos, nav.speed_over_ground_mps, dt_s)
        self.distance_m, self.radial_error_m = out.distance_m, out.radial_error_m
        if self.on_circle_since_s is None and out.distance_m <= self.radius_m + 0.5:
            self.on_circle_since_s = nav.t_s
        if self.on_circle_since_s is not None:
            bearing = distance_bearing(*pos)[1]
            if self._last_bearing is not None:
                self.turns += abs(wrap_pi(bearing - self._last_bearing)) / (2 * math.pi)
            self._last_bearing = bearing
        far = out.distance_m > self.radius_m + 10.0
        speed = self.approach_speed_mps if far else self.circle_speed_mps
        return ControlTarget(out.course_rad, speed, out.course_rate_radps)

    def time_on_circle_s(self, now_s: float) -> float:
        return 0.0 if self.on_circle_since_s is None else now_s - self.on_circle_since_s


class Task(Protocol):
    """What a mode runs: a target per step, plus where it is going for telemetry."""

    frame: LocalFrame
    point: tuple[float, float]
    distance_m: float
    cross_track_m: float

    def step(self, nav: NavState, dt_s: float) -> ControlTarget: ...


class NavMode(Mode):
    """Base of the navigating modes: position required, runs a task through the control system."""

    autonomous = True

    def __init__(self) -> None:
        super().__init__()
        self.task: Task | None = None
        self._timer = StepTimer()

    def requirements(self, host: ModeHost) -> str | None:
        return requires_position(host)

    def enter(self, host: ModeHost) -> None:
        self._timer.reset()
        host.control.reset()

    def dt(self, nav: NavState) -> float:
        """This period's step (sensor time, clamped)."""
        return self._timer.step(nav.t_s)

    def run_task(self, host: ModeHost, nav: NavState, task: Task,
                 dt_s: float | None = None) -> ControlRequest:
        """One step of ``task``: its target for the controller stage; the telemetry target.
        ``dt_s``: this period's :meth:`dt` if the mode has already taken it."""
        target = task.step(nav, self.dt(nav) if dt_s is None else dt_s)
        point = task.point
        dist_m = task.distance_m if math.isfinite(task.distance_m) else 0.0
        north, east = task.frame.to_ne(*point)
        here_n, here_e = task.frame.to_ne(nav.lat_deg, nav.lon_deg)
        bearing = distance_bearing(north - here_n, east - here_e)[1]
        self.nav_target = NavTarget(
            lat_deg=point[0], lon_deg=point[1], speed_mps=max(0.0, target.speed_mps), wp_dist_m=dist_m,
            target_bearing_rad=bearing, nav_bearing_rad=wrap_2pi(target.course_rad),
            xtrack_error_m=task.cross_track_m,
            speed_error_mps=target.speed_mps - nav.u_mps)
        return ControlRequest.follow(target, ignition_on=host.armed)
