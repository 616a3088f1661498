"""GUIDED and RTL on their point in a current (:mod:`companion.modes.holding`), fast, without a plant.

The approach in a current to be stemmed (:class:`~companion.modes.holding.ApproachTask`): from
downstream the boat joins the line that runs up the current into its goal; from upstream it hands
over to the station keeper at once, which lets the current set it back onto the goal.  The
evidence that a station keeper cannot hold the point (:class:`~companion.modes.holding.CreepWatch`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from companion.control.actuator import IDLE_THROTTLE
from companion.guidance.geo import LocalFrame, distance_bearing
from companion.guidance.holding import HoldStrategy
from companion.messages import CurrentEstimate, NavState
from companion.modes.creep import (
    ORBIT_AFTER_S,
    POINT_ORBIT_AFTER_S,
    TRIAL_UP_S,
    CreepWatch,
    creeping_up,
    orbit_if_creeping,
    trial_creeping,
)
from companion.modes.holding import (
    ApproachTask,
    CurrentStationTask,
    OrbitTask,
    hold_task,
    strategy,
)
from companion.modes.station_trials import StationTrials
from companion.param_table import all_param_defs
from companion.params import ParamStore

HOME = (41.77, 123.43)
FRAME = LocalFrame(*HOME)
CURRENT_NE_MPS = (0.8, 0.0)
"""Toward north: upstream is south."""


def _nav(t_s: float, north_m: float, east_m: float, heading_rad: float, speed_mps: float) -> NavState:
    lat, lon = FRAME.to_lat_lon(north_m, east_m)
    return NavState(t_s=t_s, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=heading_rad, roll_rad=0.0,
                    pitch_rad=0.0, vel_north_mps=speed_mps * math.cos(heading_rad),
                    vel_east_mps=speed_mps * math.sin(heading_rad), u_mps=speed_mps, v_mps=0.0, r_radps=0.0)


def _angle(a_rad: float, b_rad: float) -> float:
    return abs(math.remainder(a_rad - b_rad, 2 * math.pi))


def test_from_downstream_the_boat_joins_the_line_up_the_current_and_hands_over_near_the_goal() -> None:
    """Current toward south, goal 20 m N / 40 m E (upstream, 63 deg off it): the boat heads for
    the line running north into the goal, then up it, and is handed over within
    USV_HOLD_BRAKE x 0.75 of the goal, not before."""
    params = ParamStore(all_param_defs())
    task = ApproachTask(params, HOME, FRAME.to_lat_lon(20.0, 40.0), 3.0, (-0.8, 0.0))
    brake_m = params.get("USV_HOLD_BRAKE")
    first = task.step(_nav(0.0, 0.0, 0.0, 0.0, 2.0), 0.1)
    # the line runs north from (20 - brake, 40): the boat steers right of the bearing to the goal
    assert distance_bearing(20.0, 40.0)[1] + math.radians(5.0) < first.course_rad < math.radians(100.0)
    assert not task.reached
    target = task.step(_nav(0.1, 20.0 - brake_m - 2.0, 40.0, 0.0, 2.0), 0.1)
    assert _angle(target.course_rad, 0.0) < math.radians(20.0) and not task.reached
    task.step(_nav(0.2, 20.0 - 0.7 * brake_m, 40.0, 0.0, 2.0), 0.1)
    assert task.reached


def test_from_upstream_the_station_keeper_takes_over_at_once() -> None:
    """The goal downstream of the boat (current toward north, goal to the north-east): no leg past
    the goal; the station keeper holds the bow into the current and drops back onto it."""
    params = ParamStore(all_param_defs())
    task = ApproachTask(params, HOME, FRAME.to_lat_lon(30.0, 30.0), 3.0, CURRENT_NE_MPS)
    assert task.reached and task.leg is None
    target = task.step(_nav(0.0, 0.0, 0.0, 0.0, 2.0), 0.1)
    assert target.is_heading and _angle(target.course_rad, math.pi) < 1e-9


def test_a_leg_within_60_degrees_of_upstream_is_flown_as_it_is() -> None:
    params = ParamStore(all_param_defs())
    task = ApproachTask(params, HOME, FRAME.to_lat_lon(-30.0, -10.0), 3.0, CURRENT_NE_MPS)
    target = task.step(_nav(0.0, 0.0, 0.0, math.pi, 2.0), 0.1)
    assert _angle(target.course_rad, distance_bearing(-30.0, -10.0)[1]) < math.radians(10.0)
    assert not task.reached
    task.step(_nav(0.1, -25.0, -8.0, math.pi, 2.0), 0.1)
    assert task.reached


class _Mapper:
    throttle = 0.0

    def idling(self) -> bool:
        return self.throttle <= IDLE_THROTTLE


class _Control:
    def __init__(self) -> None:
        self.mapper = _Mapper()


class _Host:
    """What :class:`CreepWatch` reads of the mode host: the throttle the controller commands."""

    control = _Control()


def test_a_keeper_idling_far_off_its_point_without_closing_is_given_up_for_the_orbit() -> None:
    """GUIDED/RTL's station keeper idling 12 m off its point for 20 s without coming 1 m closer:
    the current does not set the boat back onto the point (wind against it), so the watch says
    stalled; closing in, or motoring (not idle), is not stalled."""
    host = _Host()
    watch = CreepWatch()
    results = [watch.stalled(host, _nav(0.1 * k, 0.0, 0.0, 0.0, 0.5), 12.0 - 0.002 * k)  # type: ignore[arg-type]
               for k in range(260)]
    assert not any(results[:200]) and results[-1]
    closing = CreepWatch()
    assert not any(closing.stalled(host, _nav(0.1 * k, 0.0, 0.0, 0.0, 0.5), 12.0 - 0.02 * k)  # type: ignore[arg-type]
                   for k in range(400))
    host.control.mapper.throttle = 0.3
    motoring = CreepWatch()
    assert not any(motoring.stalled(host, _nav(0.1 * k, 0.0, 0.0, 0.0, 0.5), 12.0)  # type: ignore[arg-type]
                   for k in range(400))


class _TrialHost:
    """What the hold choice reads of the mode host: parameters, the current estimate, the vehicle's
    memory of failed station keeping, the clock and the jet's throttle."""

    def __init__(self, current_ne_mps: tuple[float, float], confidence: float = 0.95) -> None:
        self.params = ParamStore(all_param_defs())
        self.control = _Control()
        self.water_current: CurrentEstimate | None = CurrentEstimate.from_components(
            0.0, *current_ne_mps, 0.001, 0.001, confidence)
        self.station_trials = StationTrials()
        self.t_s = 100.0

    def now_s(self) -> float:
        return self.t_s


def _trial(host: _TrialHost, nav: NavState, try_station: bool = True) -> bool:
    task = hold_task(host, HOME, nav, try_station)  # type: ignore[arg-type]
    if isinstance(task, CurrentStationTask):
        assert task.trial
        return True
    assert isinstance(task, OrbitTask)
    return False


def test_a_weak_current_is_first_held_bow_on_unless_that_failed_in_it_or_the_boat_is_orbiting() -> None:
    """0.4 m/s, weaker than the idle creep: LOITER or GUIDED on a straight course first keeps
    station bow into it (wind from ahead can hold it there), a boat turning like an orbit keeps
    orbiting, RTL orbits, and once station keeping was given up in this current the next hold
    orbits at once, for 10 min."""
    host = _TrialHost((0.4, 0.0))
    straight = _nav(100.0, 0.0, 0.0, math.pi / 4, 1.2)
    orbiting = replace(straight, r_radps=math.radians(35.0))
    assert _trial(host, straight)
    assert not _trial(host, orbiting)
    assert not _trial(host, straight, try_station=False)  # RTL orbits
    host.station_trials.failed((0.42, 0.05), 100.0)
    assert not _trial(host, straight)
    other = _TrialHost((0.0, -0.4))  # another current (the same memory): tried again
    other.station_trials = host.station_trials
    assert _trial(other, straight)
    host.t_s = 100.0 + 601.0
    assert _trial(host, straight)


def test_no_try_below_usv_hold_try_without_confidence_or_when_switched_off() -> None:
    straight = _nav(100.0, 0.0, 0.0, 0.0, 1.0)
    assert not _trial(_TrialHost((0.2, 0.0)), straight)
    assert not _trial(_TrialHost((0.4, 0.0), confidence=0.3), straight)
    off = _TrialHost((0.4, 0.0))
    off.params.set("USV_HOLD_TRY", 0.7)
    assert not _trial(off, straight)


def test_a_current_stronger_than_the_creep_is_orbited_where_station_keeping_failed_in_it() -> None:
    """0.8 m/s with wind against it: the creep watch gave station keeping up; the next LOITER,
    GUIDED or RTL hold in the same current orbits at once instead of creeping first."""
    host = _TrialHost((0.0, 0.8))
    straight = _nav(100.0, 0.0, 0.0, -math.pi / 2, 0.3)
    task = hold_task(host, HOME, straight)  # type: ignore[arg-type]
    assert isinstance(task, CurrentStationTask) and not task.trial
    host.station_trials.failed((0.0, 0.8), 90.0)
    assert strategy(host) == HoldStrategy.ORBIT  # type: ignore[arg-type]
    assert isinstance(hold_task(host, HOME, straight), OrbitTask)  # type: ignore[arg-type]


def _idling_given_up_after_s(current_ne_mps: tuple[float, float], try_station: bool, start_north_m: float,
                             bow_rad: float, vel_north_mps: Callable[[float], float], seconds: float,
                             rule: Callable[..., bool], along_bow: bool) -> float | None:
    """The hold on the point (``try_station``: a station keeping trial) in ``current_ne_mps``, the
    jet idling, the boat ``start_north_m`` north of the point with its bow at ``bow_rad``, moving
    north at ``vel_north_mps(t)`` (``along_bow``: that is its surge; else it idles sideways, surge 0):
    when ``rule`` (:func:`creeping_up` or :func:`trial_creeping`)
    gives the hold up (s), ``None`` if not within ``seconds``."""
    host = _TrialHost(current_ne_mps)
    host.control.mapper.throttle = 0.0
    task = hold_task(host, HOME, _nav(100.0, start_north_m, 0.0, math.pi, 1.0), try_station)  # type: ignore[arg-type]
    assert isinstance(task, CurrentStationTask) and task.trial is try_station
    watch = CreepWatch()
    north_m = start_north_m
    for k in range(round(seconds / 0.1)):
        t = 0.1 * k
        v = vel_north_mps(t)
        north_m += 0.1 * v
        nav = replace(_nav(100.0 + t, north_m, 0.0, bow_rad, abs(v) if along_bow else 0.0), vel_north_mps=v,
                      vel_east_mps=0.0)
        task.step(nav, 0.1)
        if rule(host, nav, task, watch, 0.1):
            return t
    return None


def _creeps_up(vel_north_mps: float, seconds: float) -> bool:
    """LOITER's keeper bow into 0.8 m/s toward north (stronger than the creep), the boat idling
    2 m upstream of its point with its bow 70 deg off upstream, moving north at ``vel_north_mps``:
    whether :func:`creeping_up` gives the keeper up within ``seconds``."""
    return _idling_given_up_after_s((0.8, 0.0), False, -2.0, math.pi + math.radians(70.0),
                                    lambda t: vel_north_mps, seconds, creeping_up, False) is not None


def test_a_keeper_the_wind_pushes_up_the_current_is_given_up_whatever_its_bow_does() -> None:
    """0.8 m/s with 6 m/s of wind against it: the idling boat goes on up the current (0.3 m/s)
    with its bow 70 deg off upstream, where the creep signature (bow on the keeper's heading) does
    not count; it is given up after ORBIT_AFTER_S.  A boat the current sets back, however slowly,
    keeps station (in 1.2 m/s against 6 m/s of wind that keeper holds within 1.2 m)."""
    assert not _creeps_up(-0.3, 0.8 * ORBIT_AFTER_S)
    assert _creeps_up(-0.3, 1.5 * ORBIT_AFTER_S)
    assert not _creeps_up(0.05, 10.0 * ORBIT_AFTER_S)
    assert not _creeps_up(-0.05, 10.0 * ORBIT_AFTER_S)


def _trial_given_up_after_s(speed_up_mps: Callable[[float], float], seconds: float) -> float | None:
    """A station keeping trial in 0.4 m/s toward north (weaker than the creep), the idling boat
    1.5 m upstream of its point, bow upstream, going up the current (south) at ``speed_up_mps(t)``:
    when :func:`trial_creeping` gives it up (s), ``None`` if not within ``seconds``."""
    return _idling_given_up_after_s((0.4, 0.0), True, -1.5, math.pi, lambda t: -speed_up_mps(t), seconds,
                                    trial_creeping, True)


def test_a_trial_the_boat_runs_on_up_the_current_from_is_given_up_at_once() -> None:
    """Arriving fast with wind against a weak current, the idling boat runs on up the current past
    its point at 1.2 m/s: the trial is given up after TRIAL_UP_S (before: after ORBIT_AFTER_S of
    not being set back, 5-6 m past the point).  A boat that slows and is set back, or creeps up
    slowly (0.2 m/s), is judged as before: only after ORBIT_AFTER_S, or never."""
    running = _trial_given_up_after_s(lambda t: 1.2, 10.0)
    assert running is not None and running <= TRIAL_UP_S + 0.3 < ORBIT_AFTER_S
    creeping = _trial_given_up_after_s(lambda t: 0.2, 10.0)
    assert creeping is not None and creeping >= ORBIT_AFTER_S - 0.2
    assert _trial_given_up_after_s(lambda t: 1.2 - 1.5 * t, 10.0) is None  # stopped and set back


def _keeper_from_upstream_given_up_after_s(vel_ne_mps: Callable[[float, float], tuple[float, float]],
                                          start_north_m: float, seconds: float) -> float | None:
    """RTL's station keeper in 1.2 m/s toward south (stronger than the creep), the idling boat
    ``start_north_m`` up the current and 8 m east of its point on the keeper's heading (clamped
    70 deg off upstream to ferry it across) with 0.8 m/s of headway along the bow, moving over
    ground at ``vel_ne_mps(t, bow_rad)``: when :func:`orbit_if_creeping` gives the keeper up for the
    orbit (s), ``None`` if not within ``seconds``."""
    host = _TrialHost((-1.2, 0.0))
    host.control.mapper.throttle = 0.0
    north_m, east_m = start_north_m, 8.0
    task = hold_task(host, HOME, _nav(100.0, north_m, east_m, 0.0, 0.5))  # type: ignore[arg-type]
    assert isinstance(task, CurrentStationTask) and not task.trial
    watch = CreepWatch()
    for k in range(round(seconds / 0.1)):
        t, bow_rad = 0.1 * k, task.keeper.heading_rad
        vel = vel_ne_mps(t, bow_rad)
        north_m, east_m = north_m + 0.1 * vel[0], east_m + 0.1 * vel[1]
        nav = replace(_nav(100.0 + t, north_m, east_m, bow_rad, 0.8),
                      vel_north_mps=vel[0], vel_east_mps=vel[1])
        task.step(nav, 0.1)
        if isinstance(orbit_if_creeping(host, nav, task, watch, 0.1), OrbitTask):  # type: ignore[arg-type]
            return t
    return None


def test_a_keeper_the_current_carries_down_onto_its_point_is_not_creeping() -> None:
    """From upstream the keeper lets a strong current carry the idling boat down onto its point,
    the bow clamped 70 deg off upstream: its headway along the bow is across the current, and
    while the current carries the boat down (0.7 m/s here, from 30 m up) that is not creep (RTL
    from 42 m up a 1.2 m/s current: given up 13 m out before, and the orbit swung 11 m off home).
    The same headway with the boat going along its bow, on up the current, is creep: given up
    after POINT_ORBIT_AFTER_S; and so is a keeper ferrying to and fro 3 m up the current of its
    point, carried down and back up at 0.5 m/s by turns (0.8 m/s with 6 m/s of wind against it:
    for 120 s it never reached its point when those spells did not count)."""
    def down_the_current(t: float, bow_rad: float) -> tuple[float, float]:
        return (-0.7, 0.8 * math.sin(bow_rad))

    def along_bow(t: float, bow_rad: float) -> tuple[float, float]:
        return (0.8 * math.cos(bow_rad), 0.8 * math.sin(bow_rad))

    def bobbing(t: float, bow_rad: float) -> tuple[float, float]:
        return (-0.5 if int(t) % 2 == 0 else 0.5, 0.8 * math.sin(bow_rad))

    assert _keeper_from_upstream_given_up_after_s(down_the_current, 30.0, 2.0 * POINT_ORBIT_AFTER_S) is None
    creeping = _keeper_from_upstream_given_up_after_s(along_bow, 30.0, 2.0 * POINT_ORBIT_AFTER_S)
    assert creeping is not None and creeping >= POINT_ORBIT_AFTER_S - 0.2
    ferrying = _keeper_from_upstream_given_up_after_s(bobbing, 3.0, 3.0 * POINT_ORBIT_AFTER_S)
    assert ferrying is not None and ferrying <= 1.5 * POINT_ORBIT_AFTER_S


def _keeper_heading_deg(throttle: float, trial: bool) -> float:
    """LOITER's keeper on its point in 1.2 m/s toward N, bow up the current (S), the boat making
    1.5 m/s through the water (wind from astern) for 10 s with the jet at ``throttle``; a station
    keeping trial when ``trial``: the heading it commands last (deg)."""
    host = _TrialHost((1.2, 0.0))
    host.control.mapper.throttle = throttle
    water_mps = 1.5
    nav = replace(_nav(100.0, 0.0, 0.0, math.pi, water_mps), vel_north_mps=1.2 - water_mps)
    task = hold_task(host, HOME, nav)  # type: ignore[arg-type]
    assert isinstance(task, CurrentStationTask)
    task.trial = trial
    for k in range(100):
        target = task.step(replace(nav, t_s=100.0 + 0.1 * k), 0.1)
    return math.degrees(target.course_rad) % 360.0


def test_a_keeper_whose_idling_jet_outruns_the_current_sets_its_bow_off_upstream() -> None:
    """The idling boat outruns the current by 0.3 m/s: the bow goes 20 deg off upstream (the ferry
    glide's largest angle), so the boat no longer creeps up past its point; with the jet pushing
    (the speed loop still has authority) or in a trial (a current weaker than the creep), it stays
    dead upstream."""
    assert abs(abs(_keeper_heading_deg(0.0, trial=False) - 180.0) - 20.0) < 0.5
    assert abs(_keeper_heading_deg(0.3, trial=False) - 180.0) < 0.5
    assert abs(_keeper_heading_deg(0.0, trial=True) - 180.0) < 0.5
