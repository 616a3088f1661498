"""Evidence that a station keeper cannot hold its point (:class:`CreepWatch`), and the orbit
that takes over (:func:`orbit_if_creeping`; LOITER, GUIDED, RTL).

The hold-or-orbit choice of :mod:`companion.modes.holding` is made from the water-current
estimate, which does not show the wind: wind against the current can leave a drift weaker than
the jet's idle creep, and then the boat cannot stand on its point bow into the current.
"""

from __future__ import annotations

import math
from typing import TypeVar

from companion.guidance.bow_turn import downstream_speed_mps
from companion.guidance.geo import wrap_pi
from companion.guidance.holding import going_round_clockwise, orbit_clockwise
from companion.messages import NavState
from companion.modes.evidence import LeakyEvidence
from companion.modes.holding import CurrentStationTask, OrbitTask
from companion.modes.host import ModeHost

CREEP_MPS = 0.2
ON_HEADING_RAD = math.radians(45.0)
ORBIT_AFTER_S = 3.0
"""The creep signature (:class:`CreepWatch`): the jet idles (throttle at most ``IDLE_THROTTLE``), the
bow is within ON_HEADING_RAD of the station heading and the boat still makes more than CREEP_MPS
of headway, for ORBIT_AFTER_S net (leaky count)."""


CARRIED_DOWN_MPS = 0.4
CARRIED_FROM_M = 10.0
"""A boat the current carries down at CARRIED_DOWN_MPS or more (over ground) from more than
CARRIED_FROM_M up the current of its point is not creeping, whatever its headway along the bow
(:func:`carried_down`, GUIDED's and RTL's keeper)."""


STALL_FAR_M = 4.0
STALL_GAIN_M = 1.0
STALL_S = 20.0


def speed_down_the_current_mps(nav: NavState, task: CurrentStationTask) -> float:
    """The boat's speed over ground down ``task``'s current (negative: up it)."""
    return downstream_speed_mps((nav.vel_north_mps, nav.vel_east_mps), task.current())


def idling(host: ModeHost) -> bool:
    """The jet idles (:meth:`~companion.control.actuator.ActuatorMapper.idling`)."""
    return host.control.mapper.idling()


class CreepWatch:
    """Whether a station keeper holds a point the boat cannot stand on: the drift (current and
    wind together) is weaker than the jet's idle creep, which the keeper cannot know beforehand
    when the wind cancels part of the current.  Distance from the point is not evidence: a boat
    that must turn round into a strong current, or that motors back up to its point, is off it
    without the current being weak (``docs/tuning.md``)."""

    def __init__(self) -> None:
        self.evidence = LeakyEvidence()
        self.running_up = LeakyEvidence()
        """A station keeping trial's boat running on up the current (:func:`trial_creeping`)."""
        self._closest_m = math.inf
        self._closest_t_s = 0.0

    def stalled(self, host: ModeHost, nav: NavState, distance_m: float) -> bool:
        """The jet idles more than :data:`STALL_FAR_M` off the point and the boat has come no
        :data:`STALL_GAIN_M` closer for :data:`STALL_S`: the current does not set it back onto
        the point and the keeper will not motor there.  Catches a boat whose bow swings between
        the keeper's two headings, which the creep signature misses (``docs/tuning.md``)."""
        if not idling(host) or distance_m <= STALL_FAR_M or distance_m < self._closest_m - STALL_GAIN_M:
            self._closest_m, self._closest_t_s = distance_m, nav.t_s  # (re)start the clock here
            return False
        return nav.t_s - self._closest_t_s > STALL_S

    def count(self, failing: bool, dt_s: float, after_s: float,
              evidence: LeakyEvidence | None = None) -> bool:
        """Leaky evidence counter (:attr:`evidence`, or the one given): True (and reset) after
        ``after_s`` of net failure."""
        counter = self.evidence if evidence is None else evidence
        if counter.add(failing, dt_s) > after_s:
            counter.seconds = 0.0
            return True
        return False

    def creeping(self, host: ModeHost, nav: NavState, station_heading_rad: float, dt_s: float,
                 after_s: float = ORBIT_AFTER_S, excused: bool = False) -> bool:
        """True once the creep signature has lasted ``after_s`` (net), not counting samples the
        caller ``excused`` (:func:`carried_down`)."""
        at_idle = idling(host)
        on_heading = abs(wrap_pi(nav.heading_rad - station_heading_rad)) < ON_HEADING_RAD
        return self.count(at_idle and on_heading and nav.u_mps > CREEP_MPS and not excused, dt_s, after_s)


def orbit_instead(host: ModeHost, task: CurrentStationTask, nav: NavState) -> OrbitTask:
    """The drift-compensated orbit round ``task``'s point, for a station keeper that creeps (the
    vehicle's :class:`~companion.modes.station_trials.StationTrials` remembers it).  Taken up off
    the circle, it goes round the point the way the boat already goes round it
    (:func:`~companion.guidance.holding.going_round_clockwise`); else as an orbit entered at its
    point (:func:`~companion.guidance.holding.orbit_clockwise`)."""
    current = task.current()
    host.station_trials.failed(current, nav.t_s)
    offset_ne_m = task.frame.to_ne(nav.lat_deg, nav.lon_deg)
    clockwise = going_round_clockwise(offset_ne_m, (nav.vel_north_mps, nav.vel_east_mps),
                                      host.params.get("USV_TURN_RAD"))
    if clockwise is None:
        clockwise = orbit_clockwise(nav.heading_rad, nav.r_radps, current)
    return OrbitTask(host.params, task.point, task.current.source, current, clockwise)


def carried_down(nav: NavState, task: CurrentStationTask) -> bool:
    """The current carries the boat down toward its point: at :data:`CARRIED_DOWN_MPS` or more over
    ground, from more than :data:`CARRIED_FROM_M` up the current of it.  From upstream, GUIDED's
    and RTL's keeper lets the current set the idling boat back onto its point with the bow clamped
    70 deg off upstream; its headway across the current is not creep.  Nearer the point the creep
    signature counts as before: there a keeper the wind holds off its point must still be given up
    for the orbit (measurements and the thresholds' choice: ``docs/tuning.md``)."""
    down_mps = speed_down_the_current_mps(nav, task)
    return down_mps >= CARRIED_DOWN_MPS and task.downstream_m < -CARRIED_FROM_M


TaskT = TypeVar("TaskT")
POINT_ORBIT_AFTER_S = 10.0
"""GUIDED and RTL give their station keeper up after this much creep (net), longer than LOITER's
:data:`ORBIT_AFTER_S`: a keeper that holds with brief spells of headway (wind nearly cancelling
the idle creep) is left holding (``docs/tuning.md``)."""


def orbit_if_creeping(host: ModeHost, nav: NavState, task: TaskT, watch: CreepWatch,
                      dt_s: float) -> TaskT | OrbitTask:
    """``task``, or the orbit round its point (:func:`orbit_instead`) once it is a station keeper
    that ``watch`` sees creep: the drift is weaker than the idle creep (GUIDED and RTL on their
    point; LOITER runs its own choice); a keeper tried in a weak current, as :func:`trial_creeping`
    says."""
    if isinstance(task, CurrentStationTask) and (trial_creeping(host, nav, task, watch, dt_s) or (
            not task.trial and watch.creeping(host, nav, task.keeper.heading_rad, dt_s, POINT_ORBIT_AFTER_S,
                                              carried_down(nav, task)))
            or watch.stalled(host, nav, task.distance_m)):
        return orbit_instead(host, task, nav)
    return task


TRIAL_PAST_M = 1.0
SET_BACK_MPS = 0.15
"""A station keeping trial fails when the idling boat, more than TRIAL_PAST_M upstream of its point,
is not set back down the current at SET_BACK_MPS or more."""
TRIAL_SETTLE_S = 25.0
TRIAL_SETTLED_M = 2.5
"""A station keeping trial is also given up while farther than TRIAL_SETTLED_M from its point
TRIAL_SETTLE_S after it started (wind across the current sets the idling boat sideways and the
keeper ferries it to and fro 10 m wide without the creep ever showing).  Not sooner: a boat that
arrives heading down the current turns round under power and runs up to 8 m off first."""


TRIAL_UP_MPS = 0.3
TRIAL_UP_S = 1.5
"""A station keeping trial also fails at once when the idling boat, more than TRIAL_PAST_M upstream
of its point, runs on up the current at TRIAL_UP_MPS or more for TRIAL_UP_S (net): the drift does
not even slow it.  Arriving at 1.6-2.4 m/s with wind against the current, the boat ran on up at
1.1-1.5 m/s, and the trial, given up only after 3 s of not being set back, let it coast 5-6 m
past its point.  Replayed on the truth logs of the tuning grid's 24 GUIDED trials, the rule fired
in 16 of the 18 that failed (2-6 m from the point) and in none of the 6 that held
(``docs/tuning.md``)."""


CREEP_UP_MPS = 0.1
"""A keeper bow into the current gives up when the idling boat, more than TRIAL_PAST_M upstream
of its point, goes on up the current at this or more (:func:`creeping_up`)."""


def creeping_up(host: ModeHost, nav: NavState, task: CurrentStationTask, watch: CreepWatch,
                dt_s: float) -> bool:
    """The idling boat, more than :data:`TRIAL_PAST_M` upstream of its point, goes on up the current
    at :data:`CREEP_UP_MPS` or more for :data:`ORBIT_AFTER_S` (net): wind against the current has
    left a drift weaker than the idle creep, whatever the bow does.  LOITER's keeper in a current
    stronger than the creep counts this beside the creep signature, which needs the bow on the
    keeper's heading: a keeper clamped 70 deg off upstream, first on one side and then on the
    other, never holds it, and in 0.8 m/s against 6 m/s of wind LOITER crept 9 m up the current
    before the signature showed (``docs/tuning.md``).  Going up the current, not merely not being
    set back: in 1.2 m/s against 6 m/s of wind the keeper holds within 1.2 m while the boat is
    set back at under 0.15 m/s, which the trial's test (:func:`trial_creeping`) takes for creep."""
    down_mps = speed_down_the_current_mps(nav, task)
    at_idle = idling(host)
    up = at_idle and down_mps <= -CREEP_UP_MPS and task.downstream_m < -TRIAL_PAST_M
    return watch.count(up, dt_s, ORBIT_AFTER_S)


def trial_creeping(host: ModeHost, nav: NavState, task: CurrentStationTask, watch: CreepWatch,
                   dt_s: float) -> bool:
    """A station keeping trial (:func:`~companion.modes.holding.tries_station`) fails: with the jet
    idling more than :data:`TRIAL_PAST_M` upstream of its point, the boat is not set back down the
    current (:data:`SET_BACK_MPS`) for :data:`ORBIT_AFTER_S` (net): it creeps on up, or the keeper
    ferries it to and fro across; or it runs on up at :data:`TRIAL_UP_MPS` for :data:`TRIAL_UP_S`
    (net); or it is not standing on its point after :data:`TRIAL_SETTLE_S`.
    Not the creep signature of a keeper on its point: arriving at 1-2 m/s, the boat runs a few
    metres up past the point, and the keeper ferries it back down at 0.4 m/s with its bow 70 deg
    off upstream and the jet idling, which that signature takes for creep."""
    if not task.trial:
        return False
    if nav.t_s - task.started_s > TRIAL_SETTLE_S and task.distance_m > TRIAL_SETTLED_M:
        return True
    down_mps = speed_down_the_current_mps(nav, task)
    at_idle = idling(host)
    above = at_idle and task.downstream_m < -TRIAL_PAST_M
    if watch.count(above and down_mps <= -TRIAL_UP_MPS, dt_s, TRIAL_UP_S, watch.running_up):
        return True
    return watch.count(above and down_mps < SET_BACK_MPS, dt_s, ORBIT_AFTER_S)
