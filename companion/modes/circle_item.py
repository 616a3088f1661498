"""Circling a point (:class:`CircleTask`, GPS point tracking: sampling, LOITER_TURNS, LOITER and
GUIDED with a radius), or, in a current the boat cannot circle in, holding on the circle bow into
it (:class:`~companion.modes.stem_hold.StemHold`).  Where that hold cannot work either (wind
against the current: it was given up in this current before) the boat circles on LOITER's hold
orbit (:class:`~companion.modes.holding.OrbitTask`)."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace

from companion.angles import angle_between_rad
from companion.control.target import ControlTarget
from companion.guidance.circle import CircleTracker
from companion.guidance.current import CurrentObserver
from companion.guidance.geo import LocalFrame, distance_bearing, wrap_pi
from companion.guidance.holding import OrbitGains
from companion.guidance.params import circle_gains
from companion.messages import NavState
from companion.modes.holding import OrbitTask
from companion.modes.navigation import crab_feed_forward, crabbed
from companion.modes.station_trials import StationTrials
from companion.modes.stem_hold import StemHold
from companion.params import ParamStore

log = logging.getLogger(__name__)


ESTIMATE_AGREE_MPS = 0.15
"""The estimator's current counts for the choice when it is within this of the observer's on every
axis the observer has seen (:meth:`~companion.guidance.current.CurrentObserver.agrees`)."""
ESTIMATE_AGREE_RAD = math.radians(25.0)
"""... or, once the observer has converged, when the two point within this of each other: after the
first hold the observer read 0.24-0.35 m/s where the estimator read 0.45-0.55 m/s, 10 deg apart, in
issue 15's 0.5 m/s flood, and the boat circled the second point in it (6-15 m; ``docs/tuning.md``)."""
ESTIMATE_STRONG_MARGIN_MPS = 0.3
"""The estimator's current picks the hold on its own when it is at least this above
``USV_CIRC_HOLD_C``: wind can cancel that much of it only rarely, and the observer, which learns the
drift only across the bow, can read under the threshold after a hold (``docs/tuning.md``)."""
DECIDE_OUTSIDE_M = 8.0
"""A circle item chooses between circling and holding on the circle until the boat is this close
to the circle (the hold's route starts with a point up to this far out)."""
ORBIT_APPROACH_K = 0.75
"""Until the boat has been on the circle, a circle item's hold orbit (:meth:`CircleTask._start_circling`)
converges with this gain instead of ``USV_HOLD_ORB_K``: the item starts circling up to
:data:`DECIDE_OUTSIDE_M` outside the circle, where the orbit's field at 1.5 pointed the boat almost
at the centre; arriving at 2.4 m/s it ran through the centre, and the turn that followed looped
8.7 m out (0.8 m/s with 6 m/s of wind against it; ``docs/tuning.md``)."""
REPLAN_TURN_RAD = math.radians(15.0)
"""A hold the boat has not yet reached (its point or the circle; on its legs, or under the keeper
on the way up the current) is planned again from where the boat is when the current it is flown on
has turned by more than this since it was planned: the first hold after arming is picked on an
estimate still settling from the run-up (it read 110-125 deg for a drift toward 85-90 deg, and the
creep up the current then ran through the circle's centre; ``docs/tuning.md``) ..."""
REPLAN_OUTSIDE_M = 5.0
"""... only while the boat is more than this outside the circle and has not been on it (planned
again 0.2 m inside, the route swept it 13 m off the circle) ..."""
REPLAN_SIDE_RAD = math.radians(90.0)
"""... and only as the same kind of hold (above or below the idle creep) with its hold point within
this round the circle of the old one: a boat turned about close to the circle onto a new route
swept through it (10 m)."""


def _same_direction(observed_ne_mps: tuple[float, float] | None,
                    estimated_ne_mps: tuple[float, float]) -> bool:
    """Both currents known and within :data:`ESTIMATE_AGREE_RAD` of each other in direction."""
    if observed_ne_mps is None or 0.0 in (math.hypot(*observed_ne_mps), math.hypot(*estimated_ne_mps)):
        return False
    return angle_between_rad(observed_ne_mps, estimated_ne_mps) <= ESTIMATE_AGREE_RAD


def circling_clockwise(pos_ne: tuple[float, float], heading_rad: float) -> bool:
    """Whether a boat at ``pos_ne`` (north, east m from the centre) with its bow on ``heading_rad``
    goes clockwise round the centre (seen from above, north up); straight at it or away from it:
    clockwise."""
    return pos_ne[0] * math.sin(heading_rad) - pos_ne[1] * math.cos(heading_rad) >= 0.0


class CircleTask:
    """Approach ``point`` and circle it at ``radius_m``; counts turns and time on the circle."""

    def __init__(self, params: ParamStore, point: tuple[float, float], radius_m: float,
                 clockwise: bool | None = True, approach_speed_mps: float = 3.0,
                 drift: CurrentObserver | None = None,
                 water_current: Callable[[], tuple[float, float] | None] | None = None,
                 trials: StationTrials | None = None, idling: Callable[[], bool] | None = None) -> None:
        """``clockwise``: the direction; ``None``: the item leaves it open and the boat circles the
        way its bow goes round the centre when it starts circling (a sampling circle).
        ``water_current``: the estimator's confident water current (north, east m/s) or
        ``None``, used to choose between circling and holding on the circle while ``drift`` has
        not yet seen the boat steer in two directions (the first item after a straight leg).
        ``trials``: where holding bow into the current failed (:meth:`StemHold.when_needed`); a
        hold given up after the boat reached it (``StemHold.failed_on_hold``) is recorded there.
        ``idling``: whether the jet idles now (the hold's ferry glide, :class:`StemHold`)."""
        self.frame = LocalFrame(*point)
        self.params = params
        self.drift = drift
        self.water_current = water_current
        self.trials = trials
        self.idling = idling
        self.point = point
        self.radius_m = max(radius_m, params.get("USV_TURN_RAD"))
        self.tracker = CircleTracker((0.0, 0.0), self.radius_m, clockwise is None or clockwise,
                                     circle_gains(params))  # an open direction starts clockwise
        self.free_direction = clockwise is None
        """The item leaves the direction open: the boat circles the way its bow turns round the
        centre when it starts circling (:func:`circling_clockwise`)."""
        self.circle_speed_mps = params.get("USV_CIRC_SPD")
        self.approach_speed_mps = approach_speed_mps
        self.on_circle_since_s: float | None = None
        self.stem: StemHold | None = None
        """Set when the current is too strong to circle in: the boat holds on the circle."""
        self.circling = False
        """Set once the boat circles (closer than :data:`DECIDE_OUTSIDE_M` outside the circle with no
        hold picked): the choice is not revisited (a hold picked in the middle of a lap swept the boat
        9 m off the circle; one picked 3 m out ran its route through the circle)."""
        self._hold_retried = False
        """A hold lost before the boat came near the circle is flown once more from where it is."""
        self.orbit: OrbitTask | None = None
        """Set when the boat circles in a water current at least the idle creep
        (:meth:`_start_circling`): it flies the hold orbit instead of the tracker."""
        self._orbit_gains: tuple[OrbitGains, OrbitGains] | None = None
        """The hold orbit's gains until the boat has been on the circle, and after."""
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
        if self.stem is None and not self.circling:
            current, strength_mps = self._current()
            self.stem = StemHold.when_needed(self.params, current, self.radius_m, pos, nav.heading_rad,
                                             strength_mps, (nav.vel_north_mps, nav.vel_east_mps),
                                             self.trials, nav.t_s, self.idling)
            if self.stem is None and out.distance_m < self.radius_m + DECIDE_OUTSIDE_M:
                self._start_circling(pos, nav.heading_rad)
            if self.stem is not None:
                log.info("circle item: holding on the circle in a %.2f m/s current (%.1f m out)",
                         math.hypot(*self.stem.current_ne_mps), out.distance_m)
        if (self.stem is not None and not self.stem.reached
                and self.on_circle_since_s is None
                and out.distance_m > self.radius_m + REPLAN_OUTSIDE_M):
            self._replan(pos, nav)
        if self.stem is not None:
            target = self.stem.step(pos, nav, dt_s)
            if not self.stem.lost:
                return target
            if self.stem.failed_on_hold and self.trials is not None:
                self.trials.failed(self.stem.current_ne_mps, nav.t_s)
            retry = self.on_circle_since_s is None and not self._hold_retried
            log.warning("circle item: the hold given up %.1f m from its point on the circle (%s); %s",
                        math.dist(pos, self.stem.hold_ne),
                        "after reaching it" if self.stem.on_hold else "never there",
                        "again from here" if retry else "circling")
            if retry:  # not yet near the circle: a second approach costs no tracking error
                self._hold_retried = True
                self.stem = StemHold(self.params, self.radius_m, self.stem.current_ne_mps, pos,
                                     nav.heading_rad, strength_mps=self.stem.strength_mps, idling=self.idling)
                return self.stem.step(pos, nav, dt_s)
            self.stem = None
            self._start_circling(pos, nav.heading_rad)
        if self.orbit is not None:
            return self._orbit_step(nav, dt_s)
        far = out.distance_m > self.radius_m + 10.0
        speed = self.approach_speed_mps if far else self.circle_speed_mps
        target = ControlTarget(out.course_rad, speed, out.course_rate_radps)
        return crabbed(target, nav, crab_feed_forward(self.params, self.drift))

    def _replan(self, pos_ne: tuple[float, float], nav: NavState) -> None:
        """Plan the hold again when its current has turned by more than :data:`REPLAN_TURN_RAD`,
        as the same kind of hold on the same side of the circle (:data:`REPLAN_SIDE_RAD`); the
        caller checks the boat is not yet there (:data:`REPLAN_OUTSIDE_M`)."""
        assert self.stem is not None
        current, strength_mps = self._current()
        if current is None or math.hypot(*current) == 0.0:
            return
        turned_rad = angle_between_rad(current, self.stem.current_ne_mps)
        if turned_rad <= REPLAN_TURN_RAD:
            return
        stem = StemHold.when_needed(self.params, current, self.radius_m, pos_ne, nav.heading_rad,
                                    strength_mps, (nav.vel_north_mps, nav.vel_east_mps), idling=self.idling)
        if stem is not None and stem.below_creep == self.stem.below_creep and self._same_side(stem):
            log.info("circle item: the hold planned again, its current turned %.0f deg",
                     math.degrees(turned_rad))
            self.stem = stem

    def _same_side(self, stem: StemHold) -> bool:
        """The new hold point within :data:`REPLAN_SIDE_RAD` round the centre of the old one."""
        assert self.stem is not None
        return angle_between_rad(stem.hold_ne, self.stem.hold_ne) <= REPLAN_SIDE_RAD

    def _start_circling(self, pos_ne: tuple[float, float], heading_rad: float) -> None:
        """Circle from now on, the way the bow goes round the centre when the item leaves the
        direction open.  In a water current at least the idle creep (``USV_HOLD_CREEP``), which
        the item circles in only when holding bow into it failed (:meth:`StemHold.when_needed`:
        wind against the current), on LOITER's hold orbit (:class:`OrbitTask`: speed through the
        water, the current's crab, the yaw priority of a continuous turn) rather than the tracker's
        course over ground: on the tuning grid (in-process, 0.8 m/s with 6 m/s of wind against it)
        the tracker's loops reached 3.6-10.2 m off the circle.  Not in a weaker current, where the
        tracker does better (``docs/tuning.md``)."""
        self.circling = True
        if self.free_direction:
            self.tracker.set_clockwise(circling_clockwise(pos_ne, heading_rad))
        if self.water_current is None:
            return
        current = self.water_current()
        if current is not None and math.hypot(*current) >= self.params.get_or("USV_HOLD_CREEP", math.inf):
            self.orbit = OrbitTask(self.params, self.point, self.water_current, current, self.tracker.lam > 0)
            gains = self.orbit.orbit.gains
            self._orbit_gains = (replace(gains, k_orbit=ORBIT_APPROACH_K), gains)

    def _orbit_step(self, nav: NavState, dt_s: float) -> ControlTarget:
        """One step on the hold orbit; a gentler convergence until the boat has been on the circle
        (:data:`ORBIT_APPROACH_K`)."""
        assert self.orbit is not None and self._orbit_gains is not None
        approach, on_circle = self._orbit_gains
        self.orbit.orbit.gains = approach if self.on_circle_since_s is None else on_circle
        return self.orbit.step(nav, dt_s)

    def _current(self) -> tuple[tuple[float, float] | None, float]:
        """The current the hold would be flown on and the strength the circle-or-hold choice is
        made on.  The current: the observer's once it has converged (it includes the wind's leeway),
        else the estimator's if it agrees within :data:`ESTIMATE_AGREE_MPS` with what the observer
        has seen, or within :data:`ESTIMATE_AGREE_RAD` in direction with the converged observer's
        (10 s after arming the estimator read 128 deg for a current toward 90), else ``None``.  The
        strength: the stronger of the two (the observer's, time constant 6 s, read 0.3-0.4 m/s at
        times in 0.5 m/s).  The estimator counts only below the idle creep
        (``USV_HOLD_CREEP``): the hold that stems a stronger current is chosen on the observer alone,
        as before (in 0.8 m/s against 5 m/s of wind the estimator's 0.8 m/s, which has no leeway,
        picked it at the first point and the boat never got onto the circle in 900 s), unless it is
        :data:`ESTIMATE_STRONG_MARGIN_MPS` above ``USV_CIRC_HOLD_C``: then it counts too, and is the
        hold's current until the observer has converged."""
        observed = self.drift.current_ne_mps if self.drift is not None and self.drift.converged else None
        raw = estimated = self.water_current() if self.water_current is not None else None
        if estimated is not None and (
                math.hypot(*estimated) >= self.params.get_or("USV_HOLD_CREEP", 0.0)
                or (self.drift is not None and not self.drift.agrees(estimated, ESTIMATE_AGREE_MPS)
                    and not _same_direction(observed, estimated))):
            estimated = None
        strength = max((math.hypot(*c) for c in (observed, estimated) if c is not None), default=0.0)
        strong_mps = self.params.get_or("USV_CIRC_HOLD_C", 0.0) + ESTIMATE_STRONG_MARGIN_MPS
        if raw is not None and math.hypot(*raw) >= max(strong_mps, strength):
            return (observed or raw), math.hypot(*raw)
        return (observed or estimated), strength

    def time_on_circle_s(self, now_s: float) -> float:
        return 0.0 if self.on_circle_since_s is None else now_s - self.on_circle_since_s
