"""Holding a point from the water-current estimate: the tasks LOITER, GUIDED and RTL run on
their point (issue 14; guidance in :mod:`companion.guidance.holding`).

:func:`hold_task` picks, from the host's current estimate at the moment it is called, either
keeping station bow into the current (:class:`CurrentStationTask`, current stronger than
``USV_HOLD_CREEP``) or a drift-compensated orbit at ``USV_TURN_RAD`` (:class:`OrbitTask`); it
returns ``None`` without an estimate or with ``USV_HOLD_MODE`` 0, and the mode then holds as it
did before (its own :class:`~companion.modes.navigation.StationTask`).  :func:`goto_task` is the
leg GUIDED and RTL fly to the point: in a strong current it arrives bow into the current, from
downstream up the line into the point, or from upstream letting the current set it back
(:class:`ApproachTask`), so the boat brakes onto the point instead of overshooting it and looping
back (a jet cannot turn without thrust, and turning round at the point let the current carry it
13-28 m past).  Wind against the current can leave a drift weaker than the idle creep, which the
current estimate does not show: GUIDED and RTL then give the station keeper up for the orbit
(:func:`companion.modes.creep.orbit_if_creeping`), as LOITER does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from companion.angles import current_along_mps, upstream_rad
from companion.control.target import ControlTarget
from companion.guidance.bow_turn import KeeperTurn, downstream_speed_mps
from companion.guidance.current import water_speed_mps
from companion.guidance.ferry import IdleWater
from companion.guidance.geo import LocalFrame, along_across_m, wrap_2pi
from companion.guidance.hold_params import HOLD_CURRENT, current_station_gains, orbit_gains
from companion.guidance.holding import (
    REST_MPS,
    CurrentStationKeeper,
    DriftOrbit,
    HoldStrategy,
    orbit_clockwise,
    pick_strategy,
)
from companion.guidance.los import LosFollower
from companion.messages import CurrentEstimate, NavState
from companion.modes.host import ModeHost
from companion.modes.navigation import GotoTask, estimator_current
from companion.params import ParamStore

CurrentSource = Callable[[], tuple[float, float] | None]
"""The latest current estimate (north, east m/s), ``None`` while there is none."""


class _Held:
    """The last current a task saw, so a briefly stale estimate does not stop it."""

    def __init__(self, source: CurrentSource, initial_ne_mps: tuple[float, float]) -> None:
        self.source = source
        self.current_ne_mps = initial_ne_mps

    def __call__(self) -> tuple[float, float]:
        fresh = self.source()
        if fresh is not None:
            self.current_ne_mps = fresh
        return self.current_ne_mps


class CurrentStationTask:
    """Keep station on ``point`` (lat, lon) bow into a known current; large turns onto the keeper's
    heading under power, the way the boat already turns (:class:`~companion.guidance.bow_turn.KeeperTurn`,
    at ``USV_WP_TURN_SPD``, as the hold on a sampling circle)."""

    strategy = HoldStrategy.STATION

    def __init__(self, params: ParamStore, point: tuple[float, float], heading_rad: float,
                 current: CurrentSource, initial_ne_mps: tuple[float, float], trial: bool = False,
                 started_s: float = 0.0, idling: Callable[[], bool] = lambda: False) -> None:
        self.frame = LocalFrame(*point)
        self.point = point
        self.current = _Held(current, initial_ne_mps)
        self.keeper = CurrentStationKeeper((0.0, 0.0), heading_rad, current_station_gains(params))
        self.turn = KeeperTurn(params.get("USV_WP_TURN_SPD"))
        self.distance_m = 0.0
        self.cross_track_m = 0.0
        self.trial = trial
        """Tried in a current weaker than the idle creep (:func:`tries_station`)."""
        self.downstream_m = 0.0
        """Where the boat is along the current from the point (m, downstream positive)."""
        self.started_s = started_s
        """When the task started (vehicle clock)."""
        self.idling = idling
        """Whether the jet idles now (:meth:`~companion.control.actuator.ActuatorMapper.idling`)."""
        self.idle_water = IdleWater(params.get("USV_HOLD_CREEP"))
        """The idling boat's speed through the water: the keeper's ferry glide
        (:mod:`companion.guidance.ferry`)."""

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        current = self.current()
        pos_ne = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        idle = None if self.trial else self.idle_water.update(
            self.idling(), (nav.vel_north_mps, nav.vel_east_mps), current, dt_s)
        out = self.keeper.update(pos_ne, current, dt_s, idle)
        self.distance_m = out.distance_m
        self.downstream_m = along_across_m(pos_ne, (0.0, 0.0), current)[0]
        heading, speed = self.turn.command(
            out.heading_rad, out.surge_speed_mps, nav.heading_rad, nav.r_radps, self.downstream_m,
            downstream_speed_mps((nav.vel_north_mps, nav.vel_east_mps), current),
            current_along_mps(nav.heading_rad, current))
        return ControlTarget(heading, speed, is_heading=True, hold_station=not self.turn.powered,
                             current_along_mps=current_along_mps(out.heading_rad, current))


class OrbitTask:
    """Circle ``point`` at the turning radius through a known (weak) current."""

    strategy = HoldStrategy.ORBIT

    def __init__(self, params: ParamStore, point: tuple[float, float], current: CurrentSource,
                 initial_ne_mps: tuple[float, float], clockwise: bool = True) -> None:
        self.frame = LocalFrame(*point)
        self.point = point
        self.current = _Held(current, initial_ne_mps)
        self.orbit = DriftOrbit((0.0, 0.0), params.get("USV_TURN_RAD"), clockwise, orbit_gains(params))
        self.radius_m = self.orbit.radius_m
        self.distance_m = 0.0
        self.radial_error_m = 0.0
        self.cross_track_m = 0.0

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        current = self.current()
        at_rest = water_speed_mps(nav.vel_north_mps, nav.vel_east_mps, current) < REST_MPS
        out = self.orbit.update(self.frame.to_ne(nav.lat_deg, nav.lon_deg), current, dt_s,
                                nav.heading_rad, at_rest)
        self.distance_m, self.radial_error_m = out.distance_m, out.radial_error_m
        return ControlTarget(out.heading_rad, out.surge_speed_mps, out.turn_rate_radps, is_heading=True,
                             circling=True)


def _current_source(host: ModeHost) -> CurrentSource:
    def latest() -> tuple[float, float] | None:
        est = host.water_current
        return None if est is None else (est.north_mps, est.east_mps)
    return latest


TRIAL_MAX_TURN_RADPS = math.radians(20.0)
"""A boat turning faster than this (an orbit: 30-50 deg/s) keeps orbiting rather than try to keep
station in a weak current: coming out of a turn at orbit speed, the idle jet let it coast 9 m off
before the creep was seen, and it joined the orbit from there 13 m out (in-process, 0.3 m/s with
6 m/s of wind against it)."""


def strategy(host: ModeHost) -> HoldStrategy:
    """How the point will be held with the estimate of this moment (LEGACY: without one, or
    ``USV_HOLD_MODE`` 0).  The choice is the water current's; wind against the current can leave
    a drift weaker than the idle creep, which :class:`~companion.modes.creep.CreepWatch` finds on
    the point (the guidance observer's drift is no substitute: it sees the wind's sideways leeway,
    not its push along the bow; ``docs/tuning.md``).  Where it found it in this current before
    (:class:`~companion.modes.station_trials.StationTrials`), ORBIT at once."""
    if int(host.params.get("USV_HOLD_MODE")) != HOLD_CURRENT:
        return HoldStrategy.LEGACY
    est = host.water_current
    if est is None:
        return HoldStrategy.LEGACY
    current = (est.north_mps, est.east_mps)
    kind = pick_strategy(current, est.confidence, host.params.get("USV_HOLD_CREEP"))
    if kind == HoldStrategy.STATION and host.station_trials.ruled_out(current, host.now_s()):
        return HoldStrategy.ORBIT
    return kind


def tries_station(host: ModeHost, est: CurrentEstimate) -> bool:
    """Whether a hold first tries keeping station bow into the current ``est`` (:func:`hold_task`;
    not a boat already orbiting, :data:`TRIAL_MAX_TURN_RADPS`): between ``USV_HOLD_TRY`` and
    ``USV_HOLD_CREEP``, standing out of its uncertainty, and not a current in which station
    keeping failed before (:class:`~companion.modes.station_trials.StationTrials`).  Wind from
    ahead slows the idle creep, and then the boat stands on its point where the current alone
    could not hold it (in-process, 0.3-0.5 m/s with 6 m/s of wind along the current: LOITER within
    0.3-0.7 m of its point; orbiting 4.3-9.9 m)."""
    current = (est.north_mps, est.east_mps)
    params = host.params
    return (pick_strategy(current, est.confidence, params.get("USV_HOLD_TRY")) == HoldStrategy.STATION
            and est.speed_mps <= params.get("USV_HOLD_CREEP")
            and not host.station_trials.ruled_out(current, host.now_s()))


def hold_task(host: ModeHost, point: tuple[float, float], nav: NavState,
              try_station: bool = False) -> CurrentStationTask | OrbitTask | None:
    """The task that holds ``point`` (lat, lon) in the current of this moment (:func:`strategy`),
    ``None``: LEGACY.  ``try_station`` (LOITER, GUIDED): a current weaker than the creep is first
    held bow into it (:func:`tries_station`).  RTL does not try: AUTO, which usually follows it,
    joins its first leg from the hold's orbit, and from rest bow into the current it turned onto
    the leg the long way round (tuning grid: square 1.6 -> 6.7 m in one cell)."""
    kind = strategy(host)
    est = host.water_current
    if kind == HoldStrategy.LEGACY or est is None:
        return None
    current = (est.north_mps, est.east_mps)
    trial = (try_station and kind == HoldStrategy.ORBIT and abs(nav.r_radps) < TRIAL_MAX_TURN_RADPS
             and tries_station(host, est))
    if kind == HoldStrategy.STATION or trial:
        upstream = upstream_rad((est.north_mps, est.east_mps))
        heading = nav.heading_rad if math.cos(nav.heading_rad - upstream) > 0.0 else upstream
        return CurrentStationTask(host.params, point, heading, _current_source(host), current,
                                  trial=trial, started_s=nav.t_s, idling=host.control.mapper.idling)
    return OrbitTask(host.params, point, _current_source(host), current,
                     orbit_clockwise(nav.heading_rad, nav.r_radps, current))


HANDOVER_FRACTION = 0.75
"""The last leg hands over to station keeping this fraction of ``USV_HOLD_BRAKE`` from the point."""
UPSTREAM_COS = 0.5
"""A leg within 60 degrees of upstream already ends bow into the current: flown as it is."""


class ApproachTask:
    """Go to ``end`` (lat, lon) so as to arrive bow into a strong current:

    * the direct leg points within 60 degrees of upstream: flown as it is;
    * the boat is downstream of ``end`` (but the leg is not that close to upstream): the leg up the
      current into ``end`` from the point ``USV_HOLD_BRAKE`` metres downstream of it, which the LOS
      follower joins from where the boat is;
    * the boat is upstream of ``end`` (or level with it): no leg, :attr:`reached` at once; the
      station keeper turns the bow into the current and lets the current set the boat back onto
      ``end`` (no route round a point downstream of ``end``: its detour runs the boat past ``end``;
      ``docs/tuning.md``).

    :attr:`reached` within :data:`HANDOVER_FRACTION` of ``USV_HOLD_BRAKE`` of ``end`` (the station
    keeper's approach-speed law, ``USV_STN_P`` x distance, brakes the boat onto it from there), or
    when the leg passes ``end`` within ``USV_HOLD_BRAKE`` of it; a leg that ends farther off (the
    boat swept past ``end`` far abeam) is planned again from where the boat is."""

    def __init__(self, params: ParamStore, start: tuple[float, float], end: tuple[float, float],
                 speed_mps: float, current_ne_mps: tuple[float, float],
                 accept_radius_m: float | None = None) -> None:
        self.frame = LocalFrame(*end)
        self.point = end
        self.end = end
        self.params, self.speed_mps, self.accept_radius_m = params, speed_mps, accept_radius_m
        self.current_ne_mps = current_ne_mps
        speed_c = math.hypot(*current_ne_mps)
        self.upstream_ne = (-current_ne_mps[0] / speed_c, -current_ne_mps[1] / speed_c)
        self.brake_m = params.get("USV_HOLD_BRAKE")
        self.handover_m = HANDOVER_FRACTION * self.brake_m
        self.cross_track_m = 0.0
        self.leg: GotoTask | None = None
        self.distance_m = math.inf
        self._plan(start)

    def _plan(self, start: tuple[float, float], follower: LosFollower | None = None) -> None:
        s_n, s_e = self.frame.to_ne(*start)
        self.distance_m = math.hypot(s_n, s_e)
        up_n, up_e = self.upstream_ne
        downstream_m = along_across_m((s_n, s_e), (0.0, 0.0), (-up_n, -up_e))[0]  # the boat, of end
        if self.distance_m == 0.0 or downstream_m / self.distance_m >= UPSTREAM_COS:
            self.leg = GotoTask(self.params, start, self.end, self.speed_mps, self.accept_radius_m,
                                follower=follower, water_current=self._current)
        elif downstream_m > 0.0:
            below = self.frame.to_lat_lon(-up_n * self.brake_m, -up_e * self.brake_m)
            self.leg = GotoTask(self.params, below, self.end, self.speed_mps, self.accept_radius_m,
                                follower=follower, water_current=self._current)
        else:
            self.leg = None

    def _current(self) -> tuple[float, float]:
        return self.current_ne_mps

    @property
    def reached(self) -> bool:
        if self.leg is None:
            return True
        passed = self.leg.reached and self.distance_m <= self.brake_m
        return self.distance_m <= self.handover_m or passed

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        here = (nav.lat_deg, nav.lon_deg)
        if self.leg is not None and self.leg.reached and not self.reached:
            self._plan(here, self.leg.follower)
        if self.leg is None:  # upstream: bow into the current (the caller holds the point)
            heading = math.atan2(self.upstream_ne[1], self.upstream_ne[0])
            return ControlTarget(wrap_2pi(heading), 0.0, is_heading=True, hold_station=True)
        target = self.leg.step(nav, dt_s)
        self.distance_m = math.hypot(*self.frame.to_ne(*here))
        self.cross_track_m = self.leg.cross_track_m
        return target


ARRIVAL_DECEL_MPS2 = 0.3
"""Braking profile of :class:`BrakingGoto` (the jet slows by drag only)."""


class BrakingGoto:
    """The leg to a point that will be orbited, slowed so that the boat arrives at the orbit's
    speed: ``speed <= sqrt(v_end^2 + 2 a d)``, ``v_end`` the orbit's water speed plus the current
    along the leg.  In-process lockstep, tuning cells 0.3-0.5 m/s: after-arrival maximum 7.3-10.6 m
at the leg's corner speed, 5.2-7.8 m braked; RTL 6.0-14.4 -> 6.0-13.7 m."""

    def __init__(self, goto: GotoTask, arrive_speed_mps: float) -> None:
        self.goto = goto
        self.frame, self.point, self.end = goto.frame, goto.point, goto.end
        self.arrive_speed_mps = arrive_speed_mps
        self.distance_m = math.inf
        self.cross_track_m = 0.0

    @property
    def reached(self) -> bool:
        return self.goto.reached

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        target = self.goto.step(nav, dt_s)
        self.distance_m, self.cross_track_m = self.goto.distance_m, self.goto.cross_track_m
        limit = math.sqrt(self.arrive_speed_mps**2 + 2.0 * ARRIVAL_DECEL_MPS2 * self.distance_m)
        return replace(target, speed_mps=min(target.speed_mps, limit))


def goto_task(host: ModeHost, start: tuple[float, float], end: tuple[float, float], speed_mps: float,
              accept_radius_m: float | None = None) -> GotoTask | ApproachTask | BrakingGoto:
    """The leg GUIDED/RTL fly to a point they will hold: in a current to be stemmed an
    :class:`ApproachTask` (arrive bow into it), in a weaker one a :class:`BrakingGoto` (arrive at
    the orbit's speed), without an estimate the plain :class:`GotoTask`."""
    est = host.water_current
    kind = strategy(host)
    if kind == HoldStrategy.STATION and est is not None:
        current = (est.north_mps, est.east_mps)
        return ApproachTask(host.params, start, end, speed_mps, current, accept_radius_m)
    goto = GotoTask(host.params, start, end, speed_mps, accept_radius_m,
                    water_current=estimator_current(host))
    if kind == HoldStrategy.ORBIT and est is not None:
        leg_n, leg_e = goto.frame.to_ne(*end)
        leg_m = max(1e-6, math.hypot(leg_n, leg_e))
        along = (est.north_mps * leg_n + est.east_mps * leg_e) / leg_m
        return BrakingGoto(goto, max(0.5, host.params.get("USV_HOLD_ORB_SPD") + along))
    return goto


STOP_WITHIN_M = 1.0
"""Engine-stop holding: the return leg's acceptance radius (the engine stops there)."""
RETURN_SPEED_MPS = 2.0
STOP_SPEED_MPS = 0.8
"""The return leg brakes to this at the point (returning with the station keeper carried the
boat past it at 1.3-1.8 m/s and looped 4-7 m out)."""


class EngineStopTask:
    """Slack-water station keeping with the engine off (``USV_HOLD_ESTOP`` 1): drift until the
    boat is ``USV_HOLD_DRIFT`` from the point, restart and go back along a braked leg
    (:class:`BrakingGoto` at :data:`RETURN_SPEED_MPS`), stop the engine again when the leg
    reaches the point (within :data:`STOP_WITHIN_M`, or past it).  :attr:`drifting` says whether
    the engine is to be off now (the mode then asks for ignition off)."""

    def __init__(self, params: ParamStore, point: tuple[float, float]) -> None:
        self.params = params
        self.frame, self.point = LocalFrame(*point), point
        self.drift_m = params.get("USV_HOLD_DRIFT")
        self.drifting = True
        self.returning: BrakingGoto | None = None
        self.restarts = 0
        self.distance_m = 0.0
        self.cross_track_m = 0.0

    def update(self, nav: NavState) -> bool:
        """Switch between drifting and returning for ``nav``; whether the engine is to be off."""
        self.distance_m = math.hypot(*self.frame.to_ne(nav.lat_deg, nav.lon_deg))
        if self.drifting and self.distance_m > self.drift_m:
            self.drifting = False
            self.restarts += 1
            here = (nav.lat_deg, nav.lon_deg)
            leg = GotoTask(self.params, here, self.point, RETURN_SPEED_MPS, STOP_WITHIN_M)
            self.returning = BrakingGoto(leg, STOP_SPEED_MPS)
        elif not self.drifting and self.returning is not None and self.returning.reached:
            self.drifting = True
        return self.drifting

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        if self.returning is None:  # drifting: nothing to steer (the mode stops the engine)
            return ControlTarget(nav.heading_rad, 0.0, is_heading=True)
        target = self.returning.step(nav, dt_s)
        self.cross_track_m = self.returning.cross_track_m
        return target


def engine_stop_task(host: ModeHost, point: tuple[float, float], nav: NavState) -> EngineStopTask | None:
    """An :class:`EngineStopTask` when ``USV_HOLD_ESTOP`` is 1 and the estimate says slack water
    (below ``USV_HOLD_SLACK``), else ``None``."""
    params = host.params
    est = host.water_current
    if int(params.get("USV_HOLD_ESTOP")) != 1 or est is None or est.speed_mps >= params.get("USV_HOLD_SLACK"):
        return None
    return EngineStopTask(params, point)
