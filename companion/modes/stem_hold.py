"""Holding on the circle of a circle item in a current it cannot circle in (:class:`StemHold`,
the geometry of :mod:`companion.guidance.stem`): legs to the abeam point (below the idle creep: to
a point straight downstream of the hold point, :data:`CREEP_BELOW_M`), then the current-fed station
keeper (:class:`~companion.guidance.holding.CurrentStationKeeper`) onto the hold point."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from companion.angles import current_along_mps
from companion.control.target import ControlTarget
from companion.guidance.bow_turn import KeeperTurn, downstream_speed_mps
from companion.guidance.ferry import IdleWater
from companion.guidance.geo import along_across_m, wrap_pi
from companion.guidance.hold_params import current_station_gains
from companion.guidance.holding import CurrentStationKeeper
from companion.guidance.los import LosFollower, LosType
from companion.guidance.params import leg_config, los_gains
from companion.guidance.stem import below_route, stem_route
from companion.guidance.waypoints import LegNavigator
from companion.messages import NavState
from companion.modes.evidence import LeakyEvidence
from companion.modes.station_trials import StationTrials
from companion.params import ParamStore

STEM_ARRIVAL_MPS = 1.0
"""The leg to the abeam point brakes to this speed (not the corner speed) at its end, where the
station keeper takes over 5 m outside the circle: a boat arriving faster runs on through the hold
point and the circle while the keeper turns it into the current (``docs/tuning.md``)."""
STEM_DROP_BACK_M = 5.0
STEM_DROP_BACK_BOW_RAD = math.radians(80.0)
"""A boat that starts the hold more than STEM_DROP_BACK_M upstream of the hold point, more upstream
than across the current from it, with its bow not within STEM_DROP_BACK_BOW_RAD of downstream,
drops back onto the point under the station keeper at once, as GUIDED's approach does from upstream
(:class:`~companion.modes.holding.ApproachTask`): the legs to the abeam point would run it past the
circle with the current, and a boat already running down the current would coast through the
circle while it turns (``docs/tuning.md``)."""
STEM_SIDE_AHEAD_S = 2.0
"""A boat with its bow down the current holds on the side of the current's line through the
circle's centre where it will be this long ahead along its bow at its speed over ground; any other
boat, on the side where it is.  A boat arriving from upstream, 1 m east of the line with its bow
30 deg west of downstream at 3.5 m/s, was sent to the east abeam point: its turn onto that leg ran
through the circle, and the hold's turn then swept it 10 m off the circle (``docs/tuning.md``)."""
STEM_NEAR_CIRCLE_M = 0.5
STEM_REACH_S = 60.0
"""Above the idle creep a hold is given up (flown once more, then circling) when the boat has not
come within STEM_NEAR_CIRCLE_M outside the circle STEM_REACH_S after the station keeper took over,
like the hold below the creep (:data:`CREEP_REACH_S`): wind against the current can leave the keeper
stalled off its point, and the bottle would never fill (``docs/tuning.md``)."""
STEM_RUN_UP_M = 4.0
"""Above the idle creep a hold is also given up for circling once the boat, having been near the
circle, is more than STEM_RUN_UP_M upstream of its hold point, and the vehicle records the current
(:class:`~companion.modes.station_trials.StationTrials`: LOITER and GUIDED then orbit in it): with
wind against the current the idling boat ran up the current off its hold (0.8 m/s, 6 m/s of wind
against it, in-process: 5 m upstream, then ferrying across the current 4-8 m off its point until
the minute of :data:`STEM_REACH_S` ran out; ``docs/tuning.md``)."""

CREEP_ABEAM_M = 8.0
"""Below the idle creep the abeam point is this far outside the circle (at 5 m the boat came in at
speed and ran through the hold point and the circle)."""
CREEP_BELOW_M = 8.0
CREEP_CLEAR_M = 2.0
"""Below the idle creep the legs end CREEP_BELOW_M straight downstream of the hold point (via the
abeam point when the way there would pass within CREEP_CLEAR_M of the circle: at 1 m a leg from the
south-south-west passed 3.2 m from a 2 m circle's centre, 0.7 m outside the sampler's 2.5 m circle,
and a boat cutting inside it at the hand-over started the pump there, so the loop onto the hold
counted in Fig. 13; ``docs/tuning.md``), and the station keeper brings the boat up the current
onto the hold point, bow into it: the current brakes the boat.  Handed over at the abeam point,
across the current, a boat coming from across with the wind astern coasted on at 1.5-2 m/s at idle
while the bow came round, through the hold point and the circle (the flood's first point, tuning
seeds: 6-7 m; ``docs/tuning.md``)."""
CREEP_HOLD_DOWNSTREAM_RAD = math.radians(30.0)
"""Below the idle creep the hold point is this far round the circle downstream of the line
across the current (the creep upstream then runs along a chord of the circle)."""
CREEP_KEEPER_KI_PER_S2 = 0.0
"""Below the idle creep the keeper runs without its integral (``CurrentStationGains.ki_per_s2``):
the boat cannot stand still, so there is no steady error for it to learn, and it wound up on the
ferry from the abeam point instead (0.5 m/s, as large as the current, 3.5 s after the handover on
usv bench nav's 0.5 m/s tuning cell), pushing the boat metres past its point across the current
and back (docs/tuning.md)."""
CREEP_CAP_WITHIN_RAD = math.radians(30.0)
"""Below the idle creep, with the keeper's bow clamped off upstream and the boat's bow within this
of it, the surge is capped so the boat makes good the desired velocity's component along the
current (:attr:`~companion.guidance.holding.HoldOutput.surge_cap_mps`; idle, in practice).
Upstream of its point the projection of the desired velocity on the clamped heading asked
1-1.35 m/s, whose upstream component cancelled the current: the boat ferried across the current
2-4 m upstream of its point for a minute (usv bench nav's 0.5 m/s tuning cell).  Not while the
bow is farther off: idling then, the jet barely turned and the boat drifted 7 m upstream (flood,
first point)."""
CREEP_ON_HOLD_M = 1.0
CREEP_LOST_M = 4.0
"""Below the idle creep a hold that has reached its point (within CREEP_ON_HOLD_M, or the boat has
been within :data:`STEM_NEAR_CIRCLE_M` outside the circle: one that came onto the circle 1.1 m from
its point ferried off at idle to 16 m in 50 s, wind against the current) and then crept this far
off it is given up for circling (the boat cannot stop: it crept upstream 60 m in 0.3 m/s,
looping, and the bottle never filled) ..."""
CREEP_RUNAWAY_M = 20.0
"""... and one that has never reached it, this far off ..."""
CREEP_REACH_S = 60.0
"""... or this long after the keeper took over (without its integral the keeper can leave the boat
at idle where creep, current and wind cancel: on the flood's tuning seeds 22/23 a retried first
hold sat there 475 s and 900+ s and the bottle never filled).  The same when the boat has stood on
its hold point but never within :data:`STEM_NEAR_CIRCLE_M` outside the circle: on the flood's seed
19 the keeper held it 0.65 m off its point, 1 m outside the circle, for 900 s and the bottle never
filled.  Not remembered as a failed hold: holding itself worked."""
CREEP_RUN_UP_MPS = 0.45
CREEP_RUN_UP_S = 3.0
"""Below the idle creep a hold that has reached its point (as for :data:`CREEP_LOST_M`) is also
given up when the boat runs up the current faster than CREEP_RUN_UP_MPS for CREEP_RUN_UP_S (net,
leaky count), and the vehicle remembers the current (:attr:`StemHold.failed_on_hold`): with wind
against the current the idling boat ran up at 0.52-0.91 m/s on its hold (median), where holds that
work crept 0.00-0.31 m/s (issue 15's flood, wind along or across the current;
``docs/tuning.md``), and was given up only 4 m off."""


class StemHold:
    """Keep station on the circle, bow into the current (:mod:`companion.guidance.stem`): a leg to
    the abeam point, then the current-fed station keeper
    (:class:`~companion.guidance.holding.CurrentStationKeeper`, the observed current as its
    feed-forward) onto the hold point."""

    def __init__(self, params: ParamStore, radius_m: float, current_ne_mps: tuple[float, float],
                 pos_ne: tuple[float, float], heading_rad: float,
                 vel_ne_mps: tuple[float, float] = (0.0, 0.0), strength_mps: float | None = None,
                 idling: Callable[[], bool] | None = None) -> None:
        """``pos_ne``, ``heading_rad``, ``vel_ne_mps``: where the boat is (north, east m from the
        circle's centre), its bow, and its velocity over ground (the side of the hold,
        :data:`STEM_SIDE_AHEAD_S`).  ``strength_mps``: the strength the hold was chosen on (default:
        the current's speed); below ``USV_HOLD_CREEP`` the hold is the one below the idle creep.
        ``idling``: whether the jet idles now; above the idle creep the keeper then ferry-glides as
        LOITER's does (:mod:`companion.guidance.ferry`)."""
        self.strength_mps = math.hypot(*current_ne_mps) if strength_mps is None else strength_mps
        self.below_creep = self.strength_mps < params.get_or("USV_HOLD_CREEP", 0.0)
        """The boat cannot stand on the hold point (:mod:`companion.guidance.stem`): wider abeam
        point, hold point turned downstream."""
        ahead_m = STEM_SIDE_AHEAD_S * math.hypot(*vel_ne_mps)
        if current_along_mps(heading_rad, current_ne_mps) <= 0.0:
            ahead_m = 0.0  # bow across or up the current: the side it is on
        ahead_ne = (pos_ne[0] + ahead_m * math.cos(heading_rad), pos_ne[1] + ahead_m * math.sin(heading_rad))
        *self.route, self.hold_ne = stem_route(
            (0.0, 0.0), radius_m, current_ne_mps, ahead_ne,
            *((CREEP_ABEAM_M, CREEP_HOLD_DOWNSTREAM_RAD) if self.below_creep else ()))
        if self.below_creep:
            self.route = below_route((0.0, 0.0), radius_m, current_ne_mps, pos_ne, self.route[0],
                                     self.hold_ne, CREEP_BELOW_M, CREEP_CLEAR_M)
        cfg = leg_config(params, params.get("USV_CIRC_SPD") + math.hypot(*current_ne_mps), 1.0)
        self.turn = KeeperTurn(None if self.below_creep else cfg.turn_speed_mps)
        """How the bow turns onto the keeper's heading: under power at the corner speed, not below
        the idle creep (:class:`~companion.guidance.bow_turn.KeeperTurn`)."""
        cfg = replace(cfg, turn_speed_mps=min(cfg.turn_speed_mps, STEM_ARRIVAL_MPS))
        los = LosFollower(los_gains(params), LosType(int(params.get("USV_LOS_TYPE"))))
        self.legs = LegNavigator(los, cfg)
        self._leg = 0
        self._set_leg(pos_ne)
        self.current_ne_mps = current_ne_mps
        gains = replace(current_station_gains(params), ferry_only_to_hold=True)
        if self.below_creep:
            gains = replace(gains, ki_per_s2=CREEP_KEEPER_KI_PER_S2)
        self.keeper = CurrentStationKeeper(self.hold_ne, heading_rad, gains)
        self.holding = not self.below_creep and self._drops_back(pos_ne, heading_rad)
        """The keeper flies from the start when the boat is well upstream of the hold point
        (:data:`STEM_DROP_BACK_M`): the current sets it back onto the point, bow into it."""
        self.keeper_s = 0.0
        """Seconds since the keeper took over from the legs."""
        self.radius_m = radius_m
        self.near_circle = False
        """The boat has been within :data:`STEM_NEAR_CIRCLE_M` outside the circle while holding."""
        self.on_hold = False
        """The boat has been within :data:`CREEP_ON_HOLD_M` of the hold point."""
        self.lost = False
        """Set when the hold is given up for circling: below the idle creep when it has crept off
        (:data:`CREEP_LOST_M`) or runs up the current (:data:`CREEP_RUN_UP_MPS`), above it when it
        has run up the current (:data:`STEM_RUN_UP_M`); either side of it when the boat has not come
        near the circle a minute after the keeper took over (:data:`CREEP_REACH_S`,
        :data:`STEM_REACH_S`)."""
        self.failed_on_hold = False
        """Given up after reaching the hold (below the idle creep: crept off or ran up; above it:
        ran up): the drift (current less the wind's push) is too weak to hold in, which the vehicle
        remembers."""
        self._run_up = LeakyEvidence()
        self.idling = idling
        self.idle_water = IdleWater(params.get_or("USV_HOLD_CREEP", 0.0))
        """The idling boat's speed through the water: the keeper's ferry glide above the creep."""

    @property
    def reached(self) -> bool:
        """The boat has been on the hold point (:attr:`on_hold`) or near the circle (:attr:`near_circle`)."""
        return self.on_hold or self.near_circle

    @classmethod
    def when_needed(cls, params: ParamStore, current_ne_mps: tuple[float, float] | None, radius_m: float,
                    pos_ne: tuple[float, float], heading_rad: float,
                    strength_mps: float | None = None,
                    vel_ne_mps: tuple[float, float] = (0.0, 0.0),
                    trials: StationTrials | None = None, t_s: float = 0.0,
                    idling: Callable[[], bool] | None = None) -> StemHold | None:
        """A hold on ``current_ne_mps`` (north, east m/s; ``None``: unknown) when ``strength_mps``
        (default: its speed) is at least ``USV_CIRC_HOLD_C``, else ``None`` (circle); nor in a
        current where holding bow into it failed before (``trials``, at ``t_s``), above the idle
        creep too: there wind against the current leaves the idling boat running up it (0.8 m/s
        against 6 m/s of wind), and each item's hold ran it 4-10 m off the circle before it was
        given up (``docs/tuning.md``)."""
        limit = params.get_or("USV_CIRC_HOLD_C", 0.0)
        if current_ne_mps is None or limit <= 0.0:
            return None
        strength = math.hypot(*current_ne_mps) if strength_mps is None else strength_mps
        if strength < limit:
            return None
        if trials is not None and trials.ruled_out(current_ne_mps, t_s):
            return None
        return cls(params, radius_m, current_ne_mps, pos_ne, heading_rad, vel_ne_mps, strength, idling)

    def _drops_back(self, pos_ne: tuple[float, float], heading_rad: float) -> bool:
        """More than :data:`STEM_DROP_BACK_M` upstream of the hold point, more upstream than across
        the current from it, and the bow not within :data:`STEM_DROP_BACK_BOW_RAD` of downstream."""
        down_m, across_m = along_across_m(pos_ne, self.hold_ne, self.current_ne_mps)
        downstream_rad = math.atan2(self.current_ne_mps[1], self.current_ne_mps[0])
        return (-down_m > max(STEM_DROP_BACK_M, abs(across_m))
                and abs(wrap_pi(heading_rad - downstream_rad)) > STEM_DROP_BACK_BOW_RAD)

    def _set_leg(self, pos_ne: tuple[float, float]) -> None:
        start = pos_ne if self._leg == 0 else self.route[self._leg - 1]
        nxt = self.route[self._leg + 1] if self._leg + 1 < len(self.route) else None
        self.legs.set_leg(start, self.route[self._leg], nxt)

    def step(self, pos_ne: tuple[float, float], nav: NavState, dt_s: float) -> ControlTarget:
        if not self.holding:
            st = self.legs.update(pos_ne, nav.speed_over_ground_mps, dt_s, nav.course_over_ground_rad)
            if not st.reached:
                return st.target
            self._leg += 1
            if self._leg < len(self.route):
                self._set_leg(pos_ne)
                return self.legs.update(pos_ne, nav.speed_over_ground_mps, dt_s,
                                        nav.course_over_ground_rad).target
            self.holding = True
        off_m = math.dist(pos_ne, self.hold_ne)
        self.keeper_s += dt_s
        self.on_hold = self.on_hold or off_m < CREEP_ON_HOLD_M
        self.near_circle = self.near_circle or math.hypot(*pos_ne) <= self.radius_m + STEM_NEAR_CIRCLE_M
        reached = self.reached
        if self.below_creep and off_m > (CREEP_LOST_M if reached else CREEP_RUNAWAY_M):
            self.lost = True
            self.failed_on_hold = reached
        if not self.near_circle and self.keeper_s > (CREEP_REACH_S if self.below_creep else STEM_REACH_S):
            self.lost = True  # never near the circle (below the creep: also when on the hold point)
        if (not self.below_creep and not self.lost and reached
                and -along_across_m(pos_ne, self.hold_ne, self.current_ne_mps)[0] > STEM_RUN_UP_M):
            self.lost = self.failed_on_hold = True
        down_mps = downstream_speed_mps((nav.vel_north_mps, nav.vel_east_mps), self.current_ne_mps)
        if self.below_creep and reached and not self.lost:
            running_up = self._run_up.add(down_mps < -CREEP_RUN_UP_MPS, dt_s) > CREEP_RUN_UP_S
            self.lost = self.failed_on_hold = running_up
        idle = None if self.below_creep or self.idling is None else self.idle_water.update(
            self.idling(), (nav.vel_north_mps, nav.vel_east_mps), self.current_ne_mps, dt_s)
        out = self.keeper.update(pos_ne, self.current_ne_mps, dt_s, idle)
        downstream_m = along_across_m(pos_ne, self.hold_ne, self.current_ne_mps)[0]
        heading, speed = self.turn.command(
            out.heading_rad, out.surge_speed_mps, nav.heading_rad, nav.r_radps, downstream_m,
            down_mps, current_along_mps(nav.heading_rad, self.current_ne_mps))
        if self.below_creep and abs(wrap_pi(out.heading_rad - nav.heading_rad)) < CREEP_CAP_WITHIN_RAD:
            speed = min(speed, out.surge_cap_mps)
        return ControlTarget(heading, speed, is_heading=True, hold_station=not self.turn.powered)
