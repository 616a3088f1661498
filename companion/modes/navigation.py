"""Shared machinery of the navigating modes (LOITER, AUTO, GUIDED, RTL, CRUISE).

Navigation *tasks* are small stateful objects a mode runs one at a time: go to a point along a
leg (:class:`GotoTask`, ILOS/ALOS), keep station on a point with the bow into the current
(:class:`StationTask`), or circle a point
(:class:`~companion.modes.circle_item.CircleTask`, GPS point tracking).  Each
``step(nav)`` returns a :class:`~companion.control.target.ControlTarget` for the host's
:class:`~companion.control.system.ControlSystem`.  Positions are handled in a flat-earth frame
anchored where the task starts (:mod:`companion.guidance.geo`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Protocol

from companion.angles import current_along_mps
from companion.clock import StepTimer
from companion.control.target import ControlRequest, ControlTarget
from companion.guidance.current import CurrentObserver, crab_heading, steady_crab_rad, water_speed_mps
from companion.guidance.geo import LocalFrame, distance_bearing, wrap_2pi, wrap_pi
from companion.guidance.hold_params import current_station_gains
from companion.guidance.los import LosFollower, LosType
from companion.guidance.params import leg_config, los_gains, station_gains
from companion.guidance.sidestep import SIDESTEP_MAX_SOG_MPS, SideStep
from companion.guidance.station import StationKeeper
from companion.guidance.waypoints import (
    PIVOT_DONE_RAD,
    U_TURN_RAD,
    LegNavigator,
    UTurnLatch,
    pivot_speed_mps,
    u_turn_sign,
)
from companion.messages import NavState
from companion.modes.base import Mode, NavTarget, requires_position
from companion.modes.host import ModeHost
from companion.params import ParamStore

log = logging.getLogger(__name__)

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


def crab_feed_forward(params: ParamStore, drift: CurrentObserver | None) -> CurrentObserver | None:
    """The observer whose current the course targets are crabbed against (``USV_LOS_CFF`` 1 and a
    converged estimate), else ``None`` (the controllers remove the measured crab angle)."""
    if drift is None or int(params.get_or("USV_LOS_CFF", 0.0)) != 1 or not drift.converged:
        return None
    return drift


def crabbed(target: ControlTarget, nav: NavState, drift: CurrentObserver | None) -> ControlTarget:
    """``target``'s course over ground as the heading that makes it good through the estimated
    current (:func:`companion.guidance.current.crab_heading`); unchanged without an estimate."""
    if drift is None or target.is_heading:
        return target
    c = drift.current_ne_mps
    return replace(target, course_rad=crab_heading(target.course_rad, _crab_water_speed_mps(nav, c), c),
                   is_heading=True)


def with_steady_crab(target: ControlTarget, nav: NavState, drift: CurrentObserver | None,
                     settled: Callable[[], tuple[float, float] | None] | None = None) -> ControlTarget:
    """``target`` with the crab that holds its course in steady running through the observer's
    current (``steady_crab_rad``: the controllers keep the measured crab they remove near it, so a
    turn's sideslip does not swing the bow past the next leg).  ``drift``: the observer once it has
    converged, else ``None``; then the estimator's current once it has settled (``settled``,
    :func:`settled_current`): the square's first corners from rest come before the observer has
    converged, and the turn's whole sideslip, removed as crab, swung the bow 4 deg past the second
    leg and the boat 0.45-0.49 m off it 10 m on in calm water (``docs/tuning.md``).  Neither, or a
    heading target: ``target`` unchanged."""
    if target.is_heading:
        return target
    c = drift.current_ne_mps if drift is not None else settled() if settled is not None else None
    if c is None:
        return target
    crab_rad = steady_crab_rad(target.course_rad, _crab_water_speed_mps(nav, c), c)
    return replace(target, steady_crab_rad=crab_rad)


def _crab_water_speed_mps(nav: NavState, current_ne_mps: tuple[float, float]) -> float:
    """The speed through the water a crab is computed for: at least 1 m/s (a slow boat's crab would
    ask for more than the bow can hold)."""
    return max(water_speed_mps(nav.vel_north_mps, nav.vel_east_mps, current_ne_mps), 1.0)


CURRENT_MIN_CONFIDENCE = 0.5
"""The estimator's current counts for the circle-or-hold choice from this confidence (as LOITER's
:func:`companion.guidance.holding.pick_strategy`)."""


def estimator_current(host: ModeHost) -> Callable[[], tuple[float, float] | None]:
    """The host's fresh water-current estimate (north, east m/s) when it is confident, else ``None``."""
    def latest() -> tuple[float, float] | None:
        est = host.water_current
        if est is None or est.confidence < CURRENT_MIN_CONFIDENCE:
            return None
        return (est.north_mps, est.east_mps)
    return latest


SETTLED_CURRENT_VAR_M2PS2 = 0.01
"""The estimator's current stands in for guidance's observer in a corner's steady crab
(:meth:`GotoTask.step`) once the variance of each of its components is below this (0.1 m/s)."""


def settled_current(host: ModeHost) -> Callable[[], tuple[float, float] | None]:
    """The host's latest water-current estimate (north, east m/s) once its uncertainty is below
    :data:`SETTLED_CURRENT_VAR_M2PS2`, whether or not the current stands out of it (slack water is
    a settled estimate too), else ``None``."""
    def latest() -> tuple[float, float] | None:
        est = host.water_current
        if est is None or max(est.north_var_m2ps2, est.east_var_m2ps2) >= SETTLED_CURRENT_VAR_M2PS2:
            return None
        return (est.north_mps, est.east_mps)
    return latest


class GotoTask:
    """Follow the leg from ``start`` to ``end`` (lat, lon) at ``speed_mps``."""

    def __init__(self, params: ParamStore, start: tuple[float, float], end: tuple[float, float],
                 speed_mps: float, accept_radius_m: float | None = None,
                 next_point: tuple[float, float] | None = None, follower: LosFollower | None = None,
                 drift: CurrentObserver | None = None,
                 water_current: Callable[[], tuple[float, float] | None] | None = None,
                 arrive_short_m: float = 0.0,
                 settled: Callable[[], tuple[float, float] | None] | None = None) -> None:
        """``follower``: the previous leg's LOS follower, so the crab (integral/adaptive) estimate
        of the current carries over a corner (scaled by the cosine of the turn) instead of being
        learnt again on every leg; a new one when None.  ``drift``: the vehicle's current
        observer, for the crab feed-forward (``USV_LOS_CFF``).  ``water_current``: the
        estimator's current (:func:`estimator_current`), for the speed of a U-turn onto the leg.
        ``accept_radius_m``: the item's own radius (> 0) also caps the corner's anticipation
        (:attr:`~companion.guidance.waypoints.LegConfig.corner_cut_max_m`); else ``WP_RADIUS``.
        ``arrive_short_m``: without a next point, the boat is down to the corner speed this far
        short of ``end`` (:attr:`~companion.guidance.waypoints.LegConfig.arrive_short_m`).
        ``settled``: the estimator's current once settled (:func:`settled_current`), for a leg from
        a corner's steady crab before ``drift`` has converged."""
        self.params = params
        self.drift = drift
        self.water_current = water_current
        self.settled = settled
        self.frame = LocalFrame(*start)
        self.end = end
        own_radius = accept_radius_m if accept_radius_m is not None and accept_radius_m > 0 else None
        radius = own_radius if own_radius is not None else param(params, "WP_RADIUS")
        los_type = LosType(int(params.get("USV_LOS_TYPE")))
        self.from_corner = follower is not None
        """The leg starts at a corner of a route (AUTO carried the previous leg's follower over): its
        target carries the steady crab (:func:`with_steady_crab`), for the exit of that corner's
        turn.  A leg started from a hold, from rest or by a new go-to does not: joining it, the
        turn's full sideslip lead measured better (``docs/tuning.md``).  (A GUIDED or RTL approach
        planned again also carries its follower, but has no observer: nothing changes there.)"""
        if follower is None or follower.los_type != los_type:
            follower = LosFollower(los_gains(params), los_type)
        self.follower = follower
        cfg = leg_config(params, speed_mps, radius, corner_cut_max_m=own_radius)
        self.nav = LegNavigator(follower, replace(cfg, arrive_short_m=arrive_short_m))
        nxt = self.frame.to_ne(*next_point) if next_point is not None else None
        self.nav.set_leg((0.0, 0.0), self.frame.to_ne(*end), nxt)
        self.point = end
        self.reached = False
        self.distance_m = math.inf
        self.cross_track_m = 0.0
        self._u_turn = UTurnLatch()
        self._first_step = True
        self.sidestep: SideStep | None = None
        """Set while the boat moves sideways before a U-turn from station keeping
        (:meth:`_plan_sidestep`)."""
        self.pivoting = False
        """A U-turn onto the leg is under way (from a heading error beyond
        :data:`~companion.guidance.waypoints.U_TURN_RAD` until it is below
        :data:`~companion.guidance.waypoints.PIVOT_DONE_RAD`)."""

    def _turn_onto_leg(self, target: ControlTarget, nav: NavState, leg_rad: float) -> ControlTarget:
        """A U-turn onto the leg (heading error beyond 135 deg) runs at ``USV_WP_UTURN_SPD`` through
        the water (:func:`~companion.guidance.waypoints.pivot_speed_mps`) and turns as fast as
        ``USV_UTURN_RATE`` (``ControlTarget.u_turn``) until the boat points within 45 deg; with a
        corner to come it goes the way :func:`~companion.guidance.waypoints.u_turn_sign` picks
        (toward the inside of the route), kept until the boat points within 90 deg (the last leg of
        a route, GUIDED's and RTL's, has no inside: the heading loop picks the way)."""
        inside = self.nav.inside_sign
        err_rad = wrap_pi(target.course_rad - nav.heading_rad)
        heading = self._u_turn.heading(
            err_rad, nav.heading_rad,
            lambda: u_turn_sign(nav.heading_rad, leg_rad, inside) if inside != 0.0 else 0.0, nav.t_s)
        if abs(err_rad) > U_TURN_RAD:
            self.pivoting = True
        elif abs(err_rad) < PIVOT_DONE_RAD:
            self.pivoting = False
        if self.pivoting:
            current = self.water_current() if self.water_current is not None else None
            speed = pivot_speed_mps(self.params.get("USV_WP_UTURN_SPD"), nav.heading_rad, current)
            target = replace(target, speed_mps=min(target.speed_mps, speed), u_turn=True,
                             current_along_mps=current_along_mps(nav.heading_rad, current))
        if heading is None:
            return target
        return replace(target, course_rad=heading, is_heading=True, course_rate_radps=0.0)

    def _plan_sidestep(self, nav: NavState, pos_ne: tuple[float, float]) -> SideStep | None:
        """The side step before a U-turn onto the leg (``USV_WP_UTURN_OFS``,
        :mod:`companion.guidance.sidestep`): the boat keeps station (slower than
        :data:`~companion.guidance.sidestep.SIDESTEP_MAX_SOG_MPS` over ground) bow into a current
        stronger than ``USV_HOLD_CREEP``, more than :data:`U_TURN_RAD` off the leg.  The U-turn's
        direction is latched here, so the turn goes the way the side step prepared for."""
        offset_m = self.params.get_or("USV_WP_UTURN_OFS", 0.0)
        if offset_m <= 0.0 or int(self.params.get_or("USV_WP_UTURN", 0.0)) != 1 or self.water_current is None:
            return None
        current = self.water_current()
        if (current is None or math.hypot(*current) < self.params.get_or("USV_HOLD_CREEP", math.inf)
                or nav.speed_over_ground_mps > SIDESTEP_MAX_SOG_MPS):
            return None
        end = self.nav.end
        leg_rad = math.atan2(end[1] - pos_ne[1], end[0] - pos_ne[0])
        err_rad = wrap_pi(leg_rad - nav.heading_rad)
        if abs(err_rad) <= U_TURN_RAD:
            return None
        inside = self.nav.inside_sign
        sign = u_turn_sign(nav.heading_rad, leg_rad, inside) if inside != 0.0 else math.copysign(1.0, err_rad)
        self._u_turn.latch(sign)
        return SideStep.start(pos_ne, nav.heading_rad, sign, offset_m, current_station_gains(self.params))

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        pos = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        if self._first_step:
            self._first_step = False
            self.sidestep = self._plan_sidestep(nav, pos)
        if self.sidestep is not None:
            current = self.water_current() if self.water_current is not None else None
            if current is not None:
                target = self.sidestep.step(pos, nav.heading_rad, current, dt_s)
                if not self.sidestep.done:
                    end = self.nav.end
                    self.distance_m = math.hypot(end[0] - pos[0], end[1] - pos[1])
                    return target
            self.sidestep = None  # there (or the estimate is gone): the U-turn, the way prepared
        drift = self.drift if self.drift is not None and self.drift.converged else None
        plan_current = drift.current_ne_mps if drift is not None and int(
            self.params.get_or("USV_WP_DRIFT", 0.0)) == 1 else None
        st = self.nav.update(pos, nav.speed_over_ground_mps, dt_s, nav.course_over_ground_rad, plan_current)
        end = self.nav.end
        self.distance_m = math.hypot(end[0] - pos[0], end[1] - pos[1])
        self.cross_track_m = st.errors.cross_m
        self.reached = self.reached or st.reached
        target = crabbed(st.target, nav, crab_feed_forward(self.params, self.drift))
        if self.from_corner:
            target = with_steady_crab(target, nav, drift, self.settled)
        if int(self.params.get_or("USV_WP_UTURN", 0.0)) == 1:
            target = self._turn_onto_leg(target, nav, st.errors.path_angle_rad)
        return target


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
        self.drift = CurrentObserver()
        """The current observer (the mode manager shares one between its modes and updates it)."""
        self.handed_over: Task | None = None
        """The task the previous navigating mode was running when this one was entered (set by the
        mode manager before :meth:`enter`; AUTO continues a hold orbit from it)."""

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
