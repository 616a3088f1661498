"""Guidance in a current: the current observer, the crab heading, and holding on a circle the boat
cannot circle in (issue 14)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from companion.control.target import ControlTarget
from companion.guidance.current import (
    MAX_CRAB_SIN,
    CurrentObserver,
    crab_heading,
    steady_crab_rad,
    water_speed_mps,
)
from companion.guidance.geo import LocalFrame, distance_to_segment_m, wrap_pi
from companion.guidance.sidestep import sidestep_point
from companion.guidance.stem import stem_route
from companion.guidance.waypoints import (
    UTurnLatch,
    drift_lead_m,
    pivot_speed_mps,
    u_turn_sign,
    water_corner_lead_m,
)
from companion.messages import CurrentEstimate, NavState
from companion.modes.circle_item import CircleTask, circling_clockwise
from companion.modes.navigation import GotoTask, settled_current, with_steady_crab
from companion.modes.station_trials import StationTrials
from companion.param_table import all_param_defs
from companion.params import ParamStore


def _run(obs: CurrentObserver, heading_rad: float, water_mps: float, current: tuple[float, float],
         seconds: float, r_radps: float = 0.0) -> None:
    """A boat running straight through the water at ``water_mps`` on ``heading_rad`` in ``current``."""
    vn = water_mps * math.cos(heading_rad) + current[0]
    ve = water_mps * math.sin(heading_rad) + current[1]
    for _ in range(int(seconds / 0.1)):
        obs.update(vn, ve, heading_rad, r_radps, 0.1)


def test_observer_learns_the_current_from_two_legs_and_skips_turns() -> None:
    current = (0.3, -1.1)
    obs = CurrentObserver()
    _run(obs, 0.0, 4.0, current, 30.0)
    assert not obs.converged  # one heading sees only the component across it
    assert obs.east_mps == pytest.approx(-1.1, abs=0.02)
    _run(obs, math.pi / 2, 4.0, current, 30.0)
    assert obs.converged
    assert obs.north_mps == pytest.approx(0.3, abs=0.02) and obs.east_mps == pytest.approx(-1.1, abs=0.03)
    before = obs.current_ne_mps
    _run(obs, 1.0, 4.0, (2.0, 2.0), 20.0, r_radps=0.5)  # turning: sideslip, not current
    assert obs.current_ne_mps == before


@given(st.floats(0.0, 2 * math.pi), st.floats(2.0, 6.0), st.floats(-1.2, 1.2), st.floats(-1.2, 1.2))
@example(2.5, 2.0, 1.125, 1.1875)  # more current across than the capped crab stems (found on main)
def test_crab_heading_makes_good_the_course(course: float, water: float, cn: float, ce: float) -> None:
    psi = crab_heading(course, water, (cn, ce))
    vn, ve = water * math.cos(psi) + cn, water * math.sin(psi) + ce
    across_mps = -vn * math.sin(course) + ve * math.cos(course)
    current_across_mps = -cn * math.sin(course) + ce * math.cos(course)
    crab_rad = abs(math.remainder(course - psi, 2 * math.pi))
    if abs(current_across_mps) <= MAX_CRAB_SIN * water:
        assert across_mps == pytest.approx(0.0, abs=1e-9)  # nothing across the desired course
    else:  # more current across than the capped crab can stem: the full crab, set the current's way
        assert crab_rad == pytest.approx(math.asin(MAX_CRAB_SIN))
        assert across_mps * current_across_mps > 0.0
        assert abs(across_mps) < abs(current_across_mps)
    assert crab_rad <= math.asin(MAX_CRAB_SIN) + 1e-12
    assert water_speed_mps(vn, ve, (cn, ce)) == pytest.approx(water)


@pytest.mark.parametrize("pos", [(-14.0, 3.0), (14.0, -3.0), (0.0, -15.0), (3.0, 15.0), (-10.0, -10.0)])
def test_stem_route_ends_on_the_circle_across_the_current_without_crossing_it(
        pos: tuple[float, float]) -> None:
    current = (0.0, 1.2)  # toward east
    abeam, hold = stem_route((0.0, 0.0), 2.0, current, pos)
    assert math.hypot(*hold) == pytest.approx(2.0)
    assert hold[1] == pytest.approx(0.0, abs=1e-9)  # across the current from the centre
    assert math.copysign(1.0, hold[0]) == math.copysign(1.0, pos[0] or 1.0)  # on the boat's side
    for k in range(101):  # the ferry from abeam to the hold point stays outside the circle
        t = k / 100
        n, e = abeam[0] + t * (hold[0] - abeam[0]), abeam[1] + t * (hold[1] - abeam[1])
        assert math.hypot(n, e) >= 2.0 - 1e-9


def _observer_after_two_legs(current: tuple[float, float], water_mps: float = 3.0) -> CurrentObserver:
    """An observer that has seen the boat run 30 s north, then 30 s east, in ``current``: converged."""
    obs = CurrentObserver()
    _run(obs, 0.0, water_mps, current, 30.0)
    _run(obs, math.pi / 2, water_mps, current, 30.0)
    return obs


def _nav(frame: LocalFrame, n: float, e: float, vn: float, ve: float) -> NavState:
    lat, lon = frame.to_lat_lon(n, e)
    return NavState(t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=math.atan2(ve, vn),
                    roll_rad=0.0, pitch_rad=0.0, vel_north_mps=vn, vel_east_mps=ve,
                    u_mps=math.hypot(vn, ve), v_mps=0.0,
                    r_radps=0.0)


@pytest.mark.parametrize(("current_mps", "holds"), [(1.2, True), (0.3, False)])
def test_circle_item_holds_on_the_circle_only_in_a_current_it_cannot_circle_in(current_mps: float,
                                                                              holds: bool) -> None:
    params = ParamStore(all_param_defs())
    obs = _observer_after_two_legs((0.0, current_mps))
    point = (41.77, 123.43)
    task = CircleTask(params, point, 2.0, drift=obs)
    frame = LocalFrame(*point)
    target = task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert (task.stem is not None) is holds
    if holds:
        assert task.stem is not None
        assert task.stem.hold_ne[0] == pytest.approx(-2.0, abs=0.05)  # the south point, the boat's side
        assert not target.hold_station  # first the leg abeam of the circle
    params.set("USV_CIRC_HOLD_C", 0.0)  # 0: always circle
    again = CircleTask(params, point, 2.0, drift=obs)
    again.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert again.stem is None


def test_circle_item_picks_the_hold_from_the_estimator_before_the_observer_has_converged() -> None:
    """After one straight leg the observer knows only the current across it: the estimator's
    (confident, agreeing) current below the idle creep decides, so the first sampling point is held
    too (USV_CIRC_HOLD_C below the creep); with USV_CIRC_HOLD_C at the creep (0.7 m/s) an estimate
    above the creep is left to the observer unless it is 0.3 m/s above USV_CIRC_HOLD_C: the boat then
    holds at once, also when the converged observer reads less (it learns the drift only across the
    bow, and after a hold it read under the threshold: the boat ran through the next point at 4 m/s
    before it held)."""
    params = ParamStore(all_param_defs())
    params.set("USV_CIRC_HOLD_C", 0.4)
    obs = CurrentObserver()
    _run(obs, 0.0, 3.0, (0.0, 0.5), 30.0)
    assert not obs.converged
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    blind = CircleTask(params, point, 2.0, drift=obs)
    blind.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert blind.stem is None
    task = CircleTask(params, point, 2.0, drift=obs, water_current=lambda: (0.0, 0.5))
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert task.stem is not None and task.stem.hold_ne[0] == pytest.approx(-1.73, abs=0.05)
    disagrees = CircleTask(params, point, 2.0, drift=obs, water_current=lambda: (0.0, 0.1))
    disagrees.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert disagrees.stem is None
    above_creep = CircleTask(_creep_params(0.7), point, 2.0, drift=CurrentObserver(),
                             water_current=lambda: (0.0, 0.9))
    above_creep.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert above_creep.stem is None
    strong = CircleTask(_creep_params(0.7), point, 2.0, drift=CurrentObserver(),
                        water_current=lambda: (0.0, 1.2))
    strong.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert strong.stem is not None and strong.stem.current_ne_mps == (0.0, 1.2)
    weak_reading = _observer_after_two_legs((0.0, 0.5))
    assert weak_reading.converged
    after_hold = CircleTask(_creep_params(0.7), point, 2.0, drift=weak_reading,
                            water_current=lambda: (0.0, 1.2))
    after_hold.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert after_hold.stem is not None
    assert after_hold.stem.current_ne_mps == pytest.approx(weak_reading.current_ne_mps)  # the drift it sees


def test_circle_item_holds_when_the_observer_reads_the_current_weak_but_in_the_estimators_direction() -> None:
    """After the first hold the converged observer read 0.24-0.35 m/s where the estimator read
    0.45-0.55 m/s 10 deg away (issue 15's 0.5 m/s flood), and the boat circled the next point in
    the current: the estimator now counts when the two point the same way (within 25 deg); the hold
    is flown on the observer's current (the drift it sees).  Pointing 60 deg apart, it does not."""
    obs = _observer_after_two_legs((0.05, 0.3))
    assert obs.converged
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    for estimate, holds in (((-0.05, 0.5), True), ((0.43, 0.25), False)):
        task = CircleTask(ParamStore(all_param_defs()), point, 2.0, drift=obs,
                          water_current=_latest([estimate]))
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
        assert (task.stem is not None) is holds, estimate
        if task.stem is not None:
            assert task.stem.current_ne_mps == pytest.approx(obs.current_ne_mps)
            assert task.stem.below_creep


def test_circle_item_keeps_circling_once_on_the_circle_when_the_estimate_arrives_late() -> None:
    """A hold picked in the middle of a lap swept the boat 9 m off the circle: the choice is made
    before the boat reaches the circle and not revisited."""
    params = ParamStore(all_param_defs())
    params.set("USV_CIRC_HOLD_C", 0.4)
    current: list[tuple[float, float] | None] = [None]
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    task = CircleTask(params, point, 2.0, water_current=lambda: current[0])
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    current[0] = (0.0, 0.5)  # known before the circle: still chosen
    task.step(_nav(frame, -11.0, -3.0, 2.0, 0.0), 0.1)
    assert task.stem is not None
    late = CircleTask(params, point, 2.0, water_current=lambda: current[0])
    current[0] = None
    late.step(_nav(frame, -2.1, 0.0, 0.0, 1.6), 0.1)  # on the circle, no estimate yet
    current[0] = (0.0, 0.5)
    late.step(_nav(frame, -2.0, 0.2, 0.0, 1.6), 0.1)
    assert late.stem is None and late.circling


def test_observer_agrees_only_on_the_axes_it_has_seen() -> None:
    obs = CurrentObserver()
    _run(obs, 0.0, 3.0, (0.0, 0.5), 30.0)  # heading north: the east component is known
    assert obs.agrees((0.4, 0.45), 0.15)  # north not yet seen: anything goes there
    assert not obs.agrees((0.0, 0.2), 0.15)  # east off by 0.3 m/s


def test_stem_route_below_creep_turns_the_hold_point_downstream_on_the_circle() -> None:
    centre, current = (0.0, 0.0), (0.0, 0.5)  # flowing east
    abeam, hold = stem_route(centre, 2.0, current, (-12.0, -3.0), abeam_m=8.0,
                             downstream_rad=math.radians(30.0))
    assert math.hypot(*hold) == pytest.approx(2.0)
    assert hold == pytest.approx((-2.0 * math.cos(math.radians(30.0)), 1.0))  # south side, 1 m downstream
    assert abeam == pytest.approx((-10.0, 0.0))
    # creeping 2 m upstream from the hold point keeps within 0.3 m of the circle (a chord)
    for k in range(21):
        assert abs(math.hypot(hold[0], hold[1] - 0.1 * k) - 2.0) <= 0.3


def test_hold_on_the_circle_turns_under_power_only_where_the_current_sweeps_the_boat_off() -> None:
    """Bow downstream, 180 deg off the keeper's heading, in 1.2 m/s (above the idle creep): 4 m
    downstream of its hold point the boat turns at the corner speed (at idle the current sweeps it
    away while the bow comes round); 4 m upstream it turns at idle, and the current brings it back
    (a powered turn there drove it farther upstream, turn after turn, and the item never ended)."""
    params = ParamStore(all_param_defs())
    turn_speed_mps = params.get("USV_WP_TURN_SPD")
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    speeds = {}
    for side, east_m in (("downstream", 4.0), ("upstream", -4.0)):
        obs = _observer_after_two_legs((0.0, 1.2))
        task = CircleTask(params, point, 2.0, drift=obs)
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
        assert task.stem is not None and not task.stem.below_creep
        task.stem.holding = True  # as if the leg to the abeam point were done
        hold_n, hold_e = task.stem.hold_ne
        speeds[side] = task.step(_nav(frame, hold_n, hold_e + east_m, 0.0, 0.5), 0.1).speed_mps
    assert speeds["downstream"] >= turn_speed_mps
    assert speeds["upstream"] < 0.5 * turn_speed_mps


@pytest.mark.parametrize(("north_m", "bow_deg", "drops_back"), [
    (-20.0, 270.0, True),   # 20 m upstream, bow across: the keeper at once, bow into the current
    (-20.0, 0.0, False),    # running down the current: the legs round the circle, not a coast through it
    (-3.0, 270.0, False),   # not far enough upstream to turn
    (15.0, 270.0, False),   # downstream: the legs to the abeam point
])
def test_hold_on_the_circle_drops_back_from_upstream_under_the_keeper(north_m: float, bow_deg: float,
                                                                     drops_back: bool) -> None:
    """Current 1.2 m/s toward north.  A boat well upstream of the circle, its bow not pointing down
    the current, is handed to the station keeper at once and the current sets it back onto the
    hold point (the legs to the abeam point ran it past the circle at speed and it was swept 20 m
    off while turning into the current)."""
    params = ParamStore(all_param_defs())
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    obs = _observer_after_two_legs((1.2, 0.0))
    task = CircleTask(params, point, 2.0, drift=obs)
    bow = math.radians(bow_deg)
    target = task.step(_nav(frame, north_m, -1.0, 0.5 * math.cos(bow), 0.5 * math.sin(bow)), 0.1)
    assert task.stem is not None and not task.stem.below_creep
    assert target.hold_station is drops_back
    if drops_back:
        assert math.cos(target.course_rad) < -0.3  # bow into the current (upstream is south)


@pytest.mark.parametrize(("north_m", "east_m", "bow_deg", "side"), [
    (-14.0, 1.0, 330.0, -1.0),  # from upstream, east of the line, bow 30 deg west of downstream: west
    (-14.0, 1.0, 30.0, 1.0),    # the same, bow 30 deg east of downstream: east
    (-14.0, -1.0, 30.0, 1.0),   # west of the line heading east of it: east
    (0.0, 15.0, 270.0, 1.0),    # across the current, heading for the circle: the near side
    (14.0, 1.0, 210.0, 1.0),    # from downstream, bow up the current: the side it is on
])
def test_hold_on_the_circle_is_on_the_side_the_boat_is_heading_for(north_m: float, east_m: float,
                                                                    bow_deg: float, side: float) -> None:
    """Current 1.2 m/s toward north; the boat at 3.5 m/s.  With the bow down the current, the hold (and
    its abeam point) is on the side of the current's line where the boat will be 2 s ahead along its
    bow, else on the side it is on: a boat arriving from
    upstream 1 m east of the line with its bow 30 deg west of downstream was sent east, and its turn
    onto that leg ran through the circle (the hold then ended 10 m off it)."""
    params = ParamStore(all_param_defs())
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    task = CircleTask(params, point, 2.0, drift=_observer_after_two_legs((1.2, 0.0)))
    bow = math.radians(bow_deg)
    task.step(_nav(frame, north_m, east_m, 3.5 * math.cos(bow), 3.5 * math.sin(bow)), 0.1)
    assert task.stem is not None
    assert task.stem.hold_ne[1] * side > 1.5 and task.stem.route[0][1] * side > 5.0


def test_hold_on_the_circle_arrives_slowly_at_the_abeam_point() -> None:
    """1.2 m/s across the leg: the leg to the abeam point (5 m outside the circle) brakes to
    1 m/s at its end, where the station keeper takes over (at the corner speed, 2.5 m/s,
    the boat came in at 4 m/s, ran through the circle while the bow came round and was swept
    8 m off); it runs faster far from it."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    obs = _observer_after_two_legs((0.0, 1.2))
    task = CircleTask(ParamStore(all_param_defs()), point, 2.0, drift=obs)
    task.step(_nav(frame, -30.0, 0.0, 2.0, 0.0), 0.1)  # 30 m south, across the current
    stem = task.stem
    assert stem is not None and not stem.holding
    abeam_n, abeam_e = stem.route[0]
    assert abeam_n == pytest.approx(-7.0) and abeam_e == pytest.approx(0.0, abs=1e-9)
    far = task.step(_nav(frame, -25.0, 0.0, 2.0, 0.0), 0.1).speed_mps
    near = task.step(_nav(frame, abeam_n - 1.5, 0.0, 1.0, 0.0), 0.1).speed_mps
    assert far > 2.0 and near < 1.5  # the braking profile down to 1 m/s at the point (2.6 m/s before)


def _creep_params(limit_mps: float) -> ParamStore:
    params = ParamStore(all_param_defs())
    params.set("USV_CIRC_HOLD_C", limit_mps)
    return params


def test_circle_item_below_the_idle_creep_holds_by_default_and_circles_when_the_hold_is_lost() -> None:
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    at_creep = CircleTask(_creep_params(0.7), point, 2.0, water_current=lambda: (0.0, 0.5))
    at_creep.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert at_creep.stem is None  # USV_CIRC_HOLD_C 0.7 (the idle creep): 0.5 m/s is circled
    task = CircleTask(ParamStore(all_param_defs()), point, 2.0, water_current=lambda: (0.0, 0.5))
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    stem = task.stem
    assert stem is not None and stem.below_creep
    assert stem.hold_ne == pytest.approx((-1.73, 1.0), abs=0.01)
    stem.holding = True  # as if the leg to the abeam point were done
    task.step(_nav(frame, *stem.hold_ne, 0.0, -0.2), 0.1)
    assert stem.on_hold and not stem.lost
    target = task.step(_nav(frame, stem.hold_ne[0], stem.hold_ne[1] - 5.0, 0.0, -0.2), 0.1)  # crept 5 m
    assert task.stem is None and task.circling  # given up near the circle: circling the point
    assert not target.hold_station
    far = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5))
    far.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    first = far.stem
    assert first is not None
    first.holding = True
    far.step(_nav(frame, -12.0, -25.0, 0.0, -0.2), 0.1)  # 20+ m upstream, never near the circle
    assert far.stem is not None and far.stem is not first and not far.circling  # flown once more


def test_hold_below_the_creep_counts_as_reached_once_the_boat_is_near_the_circle() -> None:
    """A boat that came onto the circle 1.1 m from its hold point (never within 1 m of it) and then
    ferried off at idle, wind against the current, gives the hold up 4 m off, as one that reached
    its point does (it went on 50 s to 16 m off: Fig. 13 error 12.3 m in-process, 0.5 m/s with
    6 m/s of wind against it); and the run-up rule counts from there too."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)

    def on_circle_then(north_m: float, east_m: float, vel_ne: tuple[float, float]) -> CircleTask:
        task = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, -0.5))
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)  # current toward west
        stem = task.stem
        assert stem is not None and stem.below_creep
        stem.holding = True
        near = (stem.hold_ne[0] + 1.1, stem.hold_ne[1])  # inside the circle, 1.1 m from the point
        for _ in range(40):
            task.step(_nav(frame, *near, 0.0, 0.0), 0.1)
        assert task.stem is stem and not stem.on_hold
        for _ in range(40):
            task.step(_nav(frame, north_m, east_m, *vel_ne), 0.1)
        return task

    crept = on_circle_then(-6.0, -1.0, (0.0, 0.0))  # 4.3 m off its point
    assert crept.stem is None and crept.circling
    ran_up = on_circle_then(-0.63, -1.0, (0.0, 0.8))  # 1.1 m off, running up (east) at 0.8 m/s
    assert ran_up.stem is None and ran_up.circling
    slow = on_circle_then(-0.63, -1.0, (0.0, 0.2))  # creeping up at 0.2 m/s: holding
    assert slow.stem is not None and not slow.circling


def test_hold_below_the_creep_is_reached_from_downstream_bow_into_the_current() -> None:
    """Below the idle creep the legs end 8 m straight downstream of the hold point and the station
    keeper brings the boat up the current onto it (handed over across the current, a boat running
    with the wind coasted through the hold point and the circle); a boat upstream of the circle
    goes round it by the abeam point first."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    across = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5))
    across.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)  # south of the circle, current toward east
    stem = across.stem
    assert stem is not None and stem.below_creep
    assert stem.route == [pytest.approx((stem.hold_ne[0], stem.hold_ne[1] + 8.0))]
    upstream = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5))
    upstream.step(_nav(frame, -1.0, -14.0, 0.0, 2.0), 0.1)  # west of the circle, heading for it
    stem = upstream.stem
    assert stem is not None and len(stem.route) == 2
    abeam, below = stem.route
    assert abeam[1] == pytest.approx(0.0, abs=1e-9) and abs(abeam[0]) == pytest.approx(10.0)
    assert below == pytest.approx((stem.hold_ne[0], stem.hold_ne[1] + 8.0))
    upstream.step(_nav(frame, *abeam, 1.0, 1.0), 0.1)  # at the abeam point: on to below the hold
    assert not stem.holding
    target = upstream.step(_nav(frame, *below, 0.0, -0.3), 0.1)  # there: the keeper, bow upstream
    assert stem.holding and abs(wrap_pi(target.course_rad - math.radians(270.0))) < math.radians(45.0)


@pytest.mark.parametrize(("north_m", "east_m"), [(-7.5, -13.0), (-10.0, -12.0), (-4.0, -14.5), (-13.0, -5.0)])
def test_hold_below_the_creep_routes_its_legs_clear_of_the_sampling_circle(north_m: float,
                                                                           east_m: float) -> None:
    """Every leg of a hold below the idle creep, from where the boat is, passes at least 1 m
    outside the sampler's 2.5 m circle round a 2 m circle item: a boat cutting inside a leg that
    grazed it started the pump there, and the loop onto the hold counted in Fig. 13 (the
    water-sampling script's second point, 16 m, about one flight in ten)."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    toward = math.radians(80.0)  # 0.5 m/s, the flood's current toward the east, turned 10 deg north
    current = (0.5 * math.cos(toward), 0.5 * math.sin(toward))
    task = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: current)
    heading = math.atan2(-east_m, -north_m)  # running at the point at 2.5 m/s, from the first one
    task.step(_nav(frame, north_m, east_m, 2.5 * math.cos(heading), 2.5 * math.sin(heading)), 0.1)
    stem = task.stem
    assert stem is not None and stem.below_creep
    ends = [(north_m, east_m), *stem.route]
    clearance = [distance_to_segment_m((0.0, 0.0), a, b) for a, b in itertools.pairwise(ends)]
    assert min(clearance) >= 3.5, f"legs {stem.route} pass {min(clearance):.2f} m from the point"


def test_hold_below_the_creep_that_the_boat_runs_up_the_current_from_is_given_up_and_remembered() -> None:
    """On its hold below the idle creep, a boat running up the current faster than 0.45 m/s for 3 s
    (wind against the current: the drift is weaker than the creep) gives the hold up for circling,
    and the vehicle's record makes the next circle item in that current circle at once; creeping
    up at 0.2 m/s (the hold's design: along a chord of the circle) goes on holding."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)

    def hold_for(upstream_mps: float, trials: StationTrials) -> CircleTask:
        task = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5), trials=trials)
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
        stem = task.stem
        assert stem is not None and stem.below_creep
        stem.holding = True  # as if the legs were done
        for _ in range(40):  # 4 s on the hold point, the current toward east
            task.step(_nav(frame, *stem.hold_ne, 0.0, -upstream_mps), 0.1)
        return task

    trials = StationTrials()
    creeping = hold_for(0.2, trials)
    assert creeping.stem is not None and not creeping.circling and not trials.ruled_out((0.0, 0.5), 0.0)
    running = hold_for(0.8, trials)
    assert running.stem is None and running.circling and trials.ruled_out((0.0, 0.5), 0.0)
    nxt = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5), trials=trials)
    nxt.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert nxt.stem is None  # the next item circles
    other = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.5, 0.0), trials=trials)
    other.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert other.stem is not None  # another current: held
    strong = CircleTask(_creep_params(0.4), point, 2.0, drift=_observer_after_two_legs((0.0, 1.2)),
                        water_current=lambda: (0.0, 1.2), trials=trials)
    strong.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    assert strong.stem is not None and not strong.stem.below_creep  # above the creep: stemmed


def test_circle_item_where_a_hold_above_the_creep_failed_circles_on_the_hold_orbit() -> None:
    """Wind against a current above the idle creep runs the idling boat up it, and holding there
    fails (LOITER's and GUIDED's station keeping, or a circle item's hold): the next circle item in
    that current circles at once, on LOITER's hold orbit, which turns the boat through the water
    with the thrust a turn needs (the circle tracker's loops reached 4-10 m off the circle).  A
    circle item in a current weaker than the creep keeps the tracker."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    trials = StationTrials()
    trials.failed((0.0, 0.8), 0.0)

    def first_target(current: tuple[float, float]) -> tuple[CircleTask, ControlTarget]:
        task = CircleTask(ParamStore(all_param_defs()), point, 2.0, drift=_observer_after_two_legs(current),
                          water_current=lambda: current, trials=trials)
        return task, task.step(_nav(frame, -5.0, -1.0, 2.0, 0.0), 0.1)

    circled, target = first_target((0.0, 0.8))
    assert circled.stem is None and circled.circling and target.circling
    other, target = first_target((0.8, 0.0))  # another current: held
    assert other.stem is not None and not target.circling
    weak, target = first_target((0.0, 0.3))  # below USV_CIRC_HOLD_C: the tracker circles
    assert weak.stem is None and weak.circling and not target.circling


def test_hold_above_the_creep_that_the_boat_runs_up_the_current_from_is_given_up_and_remembered() -> None:
    """Above the idle creep, with wind against the current, the idling boat ran up the current off
    its hold (0.8 m/s, 6 m/s of wind against it: 5 m upstream, then ferrying across it 4-8 m off for
    a minute).  Once near the circle, a boat more than 4 m upstream of its hold point gives the hold
    up for circling, and the vehicle records the current (LOITER and GUIDED then orbit in it); 3 m
    upstream it goes on holding."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    obs = _observer_after_two_legs((0.0, 0.8))
    trials = StationTrials()

    def hold_then_run_up(upstream_m: float) -> CircleTask:
        task = CircleTask(ParamStore(all_param_defs()), point, 2.0, drift=obs, trials=trials)
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
        stem = task.stem
        assert stem is not None and not stem.below_creep
        stem.holding = True  # as if the leg to the abeam point were done
        task.step(_nav(frame, *stem.hold_ne, 0.0, 0.0), 0.1)  # on the circle
        task.step(_nav(frame, stem.hold_ne[0], stem.hold_ne[1] - upstream_m, 0.0, -0.3), 0.1)
        return task

    held = hold_then_run_up(3.0)
    assert held.stem is not None and not held.circling and not trials.ruled_out(obs.current_ne_mps, 0.0)
    ran_up = hold_then_run_up(4.5)
    assert ran_up.stem is None and ran_up.circling and trials.ruled_out(obs.current_ne_mps, 0.0)


def test_hold_is_flown_above_the_creep_when_the_estimator_reads_above_it() -> None:
    """The hold's current is the observer's (0.6 m/s: it learns the drift only across the bow), the
    choice's strength the estimator's (0.79 m/s, 0.3 above USV_CIRC_HOLD_C 0.4): the hold is the one
    for a current the jet stems (abeam point, dropping back from upstream), not the one below the
    creep, whose legs from upstream ran the boat downstream through the circle at 3 m/s, 20 m past
    (0.8 m/s, wind along the current)."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    obs = _observer_after_two_legs((0.0, 0.6))
    task = CircleTask(_creep_params(0.4), point, 2.0, drift=obs, water_current=lambda: (0.0, 0.79))
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    stem = task.stem
    assert stem is not None and not stem.below_creep
    assert stem.current_ne_mps == pytest.approx(obs.current_ne_mps)
    stem.holding = True
    far = _nav(frame, -12.0, -25.0, 0.0, -0.2)  # never near the circle: flown once more
    for _ in range(601):
        task.step(far, 0.1)
    assert task.stem is not None and task.stem is not stem and not task.stem.below_creep


@pytest.mark.parametrize(("north_m", "east_m", "heading_deg", "clockwise"), [
    (2.0, 0.0, 90.0, True), (2.0, 0.0, 270.0, False), (0.0, 3.0, 180.0, True), (-2.5, 2.5, 100.0, False),
    (-10.0, 0.0, 0.0, True)])
def test_circling_direction_follows_the_bow_round_the_centre(north_m: float, east_m: float,
                                                              heading_deg: float, clockwise: bool) -> None:
    assert circling_clockwise((north_m, east_m), math.radians(heading_deg)) is clockwise


def test_a_circle_with_no_direction_turns_the_way_the_bow_goes_when_a_hold_is_given_up() -> None:
    """A sampling circle (the item has no direction) circles the way the boat is heading round the
    centre when its hold is given up: 3 m south-east of the centre with the bow east it circles
    anticlockwise (clockwise, the boat turned through 170 deg away from the circle and was swept
    9 m off it); a circle with a direction keeps it."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    for clockwise, lam in ((None, -1.0), (True, 1.0)):
        task = CircleTask(_creep_params(0.4), point, 2.0, clockwise=clockwise,
                          water_current=lambda: (0.0, -0.5))
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
        stem = task.stem
        assert stem is not None
        stem.holding = True
        task.step(_nav(frame, *stem.hold_ne, 0.0, 0.0), 0.1)  # on the circle
        stem.lost = True  # e.g. ran up the current
        task.step(_nav(frame, -2.8, 2.9, 0.0, 1.0), 0.1)
        assert task.circling and task.tracker.lam == lam


def test_hold_below_the_creep_does_not_wind_up_on_the_ferry_to_its_point() -> None:
    """Below the idle creep the keeper has no integral: 4 m off its point for 10 s (the ferry from
    the abeam point) it asks the same heading as at the start; above the creep the integral still
    learns what the estimate misses."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    for current, winds_up in (((0.0, 0.5), False), ((0.0, 1.2), True)):
        obs = _observer_after_two_legs(current, 4.0)
        task = CircleTask(_creep_params(0.4), point, 2.0, drift=obs)
        task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
        stem = task.stem
        assert stem is not None and stem.below_creep is not winds_up
        stem.holding = True
        off = _nav(frame, stem.hold_ne[0] - 3.0, stem.hold_ne[1] + 3.0, 0.0, -0.2)
        first = task.step(off, 0.1).course_rad
        for _ in range(100):
            last = task.step(off, 0.1).course_rad
        turned_deg = math.degrees(abs(math.remainder(last - first, 2 * math.pi)))
        assert turned_deg > 2.0 if winds_up else turned_deg < 0.1


def _stall_twice_then_circle(task: CircleTask, frame: LocalFrame, below_creep: bool) -> None:
    """The boat stalls 3 m off the hold point: the hold is given up after 60 s of the keeper (not
    after 59 s), flown once more, given up again, and the item circles."""
    for _attempt in range(2):
        stem = task.stem
        assert stem is not None and stem.below_creep is below_creep and not task.circling
        stem.holding = True  # as if the legs were done
        stalled = _nav(frame, stem.hold_ne[0] - 3.0, stem.hold_ne[1], 0.0, 0.0)
        for _ in range(590):
            task.step(stalled, 0.1)
        assert task.stem is stem  # 59 s: still trying
        for _ in range(20):
            task.step(stalled, 0.1)
        assert task.stem is not stem
    assert task.stem is None and task.circling


def test_hold_below_the_creep_that_never_reaches_its_point_is_given_up_after_a_minute() -> None:
    """A boat stalled 3 m from its hold point (creep, current and wind cancelling at idle) is
    neither on the hold nor 20 m off: after 60 s of the keeper the hold is flown once more, then
    the item circles instead of waiting for ever."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    task = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5))
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    _stall_twice_then_circle(task, frame, below_creep=True)


def test_hold_below_the_creep_held_off_the_circle_on_its_point_is_given_up_after_a_minute() -> None:
    """The keeper (no integral below the creep) can hold the boat still on its hold point but 1 m
    outside the circle, where the item never counts it on the circle and the bottle never fills:
    after 60 s it is flown once more, then the item circles.  Holding worked, so the current is
    not recorded as one the boat cannot hold in."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    trials = StationTrials()
    task = CircleTask(_creep_params(0.4), point, 2.0, water_current=lambda: (0.0, 0.5), trials=trials)
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    for _attempt in range(2):  # never on the circle: flown once more, as any hold that stalls
        stem = task.stem
        assert stem is not None and stem.below_creep
        stem.holding = True  # as if the legs were done
        scale = 3.0 / math.hypot(*stem.hold_ne)  # 0.65 m off the hold point, radially out
        off_circle = _nav(frame, stem.hold_ne[0] * scale, stem.hold_ne[1] * scale, 0.0, 0.0)
        for _ in range(590):
            task.step(off_circle, 0.1)
        assert task.stem is stem and stem.on_hold and not stem.near_circle
        for _ in range(20):
            task.step(off_circle, 0.1)
        assert task.stem is not stem
    assert task.stem is None and task.circling
    assert not trials.ruled_out((0.0, 0.5), 100.0)


def test_hold_above_the_creep_that_never_gets_near_the_circle_is_given_up_after_a_minute() -> None:
    """0.8 m/s (above the idle creep) with wind against it: the keeper stalls 3 m off its hold
    point, 2.5 m or more outside the circle, and the bottle would never fill.  After 60 s the hold
    is flown once more, then the item circles; a stalled boat that has once been near the circle
    (within 0.5 m of it) keeps its hold."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    obs = _observer_after_two_legs((0.0, 0.8))
    task = CircleTask(ParamStore(all_param_defs()), point, 2.0, drift=obs)
    task.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    _stall_twice_then_circle(task, frame, below_creep=False)
    kept = CircleTask(ParamStore(all_param_defs()), point, 2.0, drift=obs)
    kept.step(_nav(frame, -12.0, -3.0, 2.0, 0.0), 0.1)
    stem = kept.stem
    assert stem is not None
    stem.holding = True
    kept.step(_nav(frame, *stem.hold_ne, 0.0, 0.0), 0.1)  # on its point once
    stalled = _nav(frame, stem.hold_ne[0] - 3.0, stem.hold_ne[1], 0.0, 0.0)
    for _ in range(1200):
        kept.step(stalled, 0.1)
    assert kept.stem is stem and not kept.circling


@pytest.mark.parametrize(("heading_deg", "inside", "sign"), [(180.0, 1.0, -1.0), (180.0, -1.0, 1.0),
                                                             (170.0, 1.0, -1.0), (190.0, -1.0, 1.0)])
def test_u_turn_onto_a_leg_turns_toward_the_inside_of_the_route(heading_deg: float, inside: float,
                                                                  sign: float) -> None:
    # leg north; facing (about) south; the next corner turns right (inside = east) or left (west)
    s = u_turn_sign(math.radians(heading_deg), 0.0, inside)
    assert s == sign
    # the turning circle's centre (at heading + s * 90 deg) lies on the inside of the leg
    centre_east = math.sin(math.radians(heading_deg) + s * math.pi / 2)
    assert centre_east * inside > 0


def _heading_nav(frame: LocalFrame, heading_deg: float) -> NavState:
    """A boat at the frame's origin, at rest, bow on ``heading_deg``."""
    lat, lon = frame.to_lat_lon(0.0, 0.0)
    return NavState(t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=math.radians(heading_deg),
                    roll_rad=0.0, pitch_rad=0.0, vel_north_mps=0.0, vel_east_mps=0.0, u_mps=0.0,
                    v_mps=0.0, r_radps=0.0)


@pytest.mark.parametrize(("current_n_mps", "speeds"), [
    (1.2, (0.0, 1.0, 5.0)),    # bow into 1.2 m/s: held back by the current, then 1 m/s across it
    (0.0, (1.0, 1.0, 5.0)),    # slack water: 1 m/s through the turn
    (None, (1.0, 1.0, 5.0)),   # no estimate: the water speed over ground
])
def test_u_turn_onto_a_leg_runs_slowly_through_the_water_until_the_bow_is_near_the_leg(
        current_n_mps: float | None, speeds: tuple[float, float, float]) -> None:
    """AUTO started with the bow into the current and the first leg down it (north): the U-turn
    runs at USV_WP_UTURN_SPD (1 m/s) through the water, commanded over ground as 1 m/s plus the
    current along the bow (never below 0), until the bow is within 45 deg of the leg; then the
    leg's own speed as before (WP_SPEED here: at rest the course over ground reads along the leg,
    so the corner-speed rule does not apply).  Commanding 2 m/s over ground with the
    bow up a 1.2 m/s current asked 3.2 m/s through the water, and the turn spanned 5-7 m.  (The
    side step before it is off here: :func:`test_u_turn_from_station_keeping_first_steps_aside`.)"""
    params = ParamStore(all_param_defs())
    params.set("USV_WP_UTURN_OFS", 0.0, persist=False)
    home = (41.77, 123.43)
    frame = LocalFrame(*home)
    current = None if current_n_mps is None else (current_n_mps, 0.0)
    task = GotoTask(params, home, frame.to_lat_lon(50.0, 0.0), 5.0, next_point=frame.to_lat_lon(50.0, 50.0),
                    water_current=(lambda: current) if current is not None else None)
    targets = [task.step(_heading_nav(frame, hdg), 0.1) for hdg in (180.0, 90.0, 30.0)]
    assert [t.speed_mps for t in targets] == pytest.approx(list(speeds), abs=1e-6)
    # the PID family's throttle feed-forward sees the speed through the water (1.2 m/s bow-on)
    assert targets[0].current_along_mps == pytest.approx(-(current_n_mps or 0.0), abs=1e-6)
    assert task.step(_heading_nav(frame, 100.0), 0.1).speed_mps == pytest.approx(5.0)  # the U-turn is over
    assert pivot_speed_mps(1.0, 0.0, (1.2, 0.0)) == pytest.approx(2.2)  # down the current


def test_u_turn_onto_the_last_leg_runs_slowly_too() -> None:
    """GUIDED's and RTL's leg (no corner after it, so no inside to turn toward) pivots the same:
    bow into 1.2 m/s with the point down the current, 0 over ground until within 45 deg (the side
    step off)."""
    params = ParamStore(all_param_defs())
    params.set("USV_WP_UTURN_OFS", 0.0, persist=False)
    home = (41.77, 123.43)
    frame = LocalFrame(*home)
    task = GotoTask(params, home, frame.to_lat_lon(100.0, 0.0), 5.0, water_current=lambda: (1.2, 0.0))
    assert task.step(_heading_nav(frame, 180.0), 0.1).speed_mps == pytest.approx(0.0)
    assert task.step(_heading_nav(frame, 60.0), 0.1).speed_mps == pytest.approx(1.6)  # 1 + 1.2 cos 60
    assert task.pivoting
    assert task.step(_heading_nav(frame, 40.0), 0.1).speed_mps == pytest.approx(5.0)


def _nav_at(frame: LocalFrame, north_m: float, east_m: float, heading_deg: float) -> NavState:
    """A boat at rest ``north_m``/``east_m`` from the frame's origin, bow on ``heading_deg``."""
    lat, lon = frame.to_lat_lon(north_m, east_m)
    return NavState(t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=math.radians(heading_deg),
                    roll_rad=0.0, pitch_rad=0.0, vel_north_mps=0.0, vel_east_mps=0.0, u_mps=0.0,
                    v_mps=0.0, r_radps=0.0)


def test_side_step_point_lies_away_from_the_turning_circle() -> None:
    # bow south, turning to port (-1, via east): the turning circle lies east, so step west
    assert sidestep_point((0.0, 0.0), math.pi, -1.0, 2.0) == pytest.approx((0.0, -2.0), abs=1e-9)
    # bow east, turning to starboard (+1, via south): the circle lies south, so step north
    assert sidestep_point((1.0, 1.0), 0.5 * math.pi, 1.0, 1.5) == pytest.approx((2.5, 1.0), abs=1e-9)


def test_u_turn_from_station_keeping_first_steps_aside() -> None:
    """At rest bow into a 1.2 m/s current (south) with the route's first leg down it (north, then a
    corner to the east, the inside): the task first keeps station 2 m west (USV_WP_UTURN_OFS),
    bow still into the current; once the boat has moved there it pivots, to port (via east) as
    prepared, at the U-turn's speed."""
    params = ParamStore(all_param_defs())
    home = (41.77, 123.43)
    frame = LocalFrame(*home)
    task = GotoTask(params, home, frame.to_lat_lon(50.0, 0.0), 5.0, next_point=frame.to_lat_lon(50.0, 50.0),
                    water_current=lambda: (1.2, 0.0))
    first = task.step(_nav_at(frame, 0.0, 0.0, 180.0), 0.1)
    assert task.sidestep is not None and first.hold_station and first.is_heading
    assert task.sidestep.point_ne == pytest.approx((0.0, -2.0), abs=1e-6)
    assert math.cos(first.course_rad) < -0.9  # bow still into the current
    assert task.step(_nav_at(frame, 0.5, -1.0, 180.0), 0.1).hold_station  # not there yet
    assert task.sidestep is not None
    straighten = task.step(_nav_at(frame, 0.8, -1.8, 140.0), 0.1)  # aside, bow 40 deg off upstream
    assert task.sidestep is not None and straighten.hold_station
    assert math.cos(straighten.course_rad) == pytest.approx(-1.0, abs=1e-9)  # the bow up the current first
    turn = task.step(_nav_at(frame, 0.8, -1.8, 180.0), 0.1)  # aside, bow up the current
    assert task.sidestep is None and task.pivoting and not turn.hold_station
    assert turn.speed_mps == pytest.approx(0.0)  # 1 m/s through the water, bow into 1.2 m/s
    assert math.degrees(wrap_pi(turn.course_rad - math.pi)) < -90.0  # to port, via east


def test_a_u_turn_that_makes_no_headway_turns_the_other_way() -> None:
    """A latched U-turn whose heading error has not closed by 20 deg for 10 s goes the other way
    (wind from astern can hold the slow pivot); one that turns keeps its way."""
    latch = UTurnLatch()
    assert latch.heading(math.radians(150.0), 0.0, lambda: -1.0, 0.0) is not None
    for t in range(1, 11):
        latch.heading(math.radians(150.0 - t), 0.0, lambda: -1.0, float(t))
    assert latch.sign == -1.0  # 10 s, 10 deg: not yet
    latch.heading(math.radians(139.0), 0.0, lambda: -1.0, 10.5)
    assert latch.sign == 1.0
    turning = UTurnLatch()
    for t in range(0, 30):
        turning.heading(math.radians(179.0 - 3.0 * t), 0.0, lambda: -1.0, float(t))
    assert turning.sign in (-1.0, 0.0)  # kept its way until done (below 90 deg: released)


@pytest.mark.parametrize(("current_ne", "heading_deg"), [
    ((0.5, 0.0), 180.0),   # weaker than the idle creep: the boat cannot stand still to step aside
    ((1.2, 0.0), 0.0),     # the bow already along the leg: no U-turn
    (None, 180.0),         # no estimate
])
def test_no_side_step_without_station_to_step_from(current_ne: tuple[float, float] | None,
                                                   heading_deg: float) -> None:
    params = ParamStore(all_param_defs())
    home = (41.77, 123.43)
    frame = LocalFrame(*home)
    task = GotoTask(params, home, frame.to_lat_lon(50.0, 0.0), 5.0, water_current=lambda: current_ne)
    assert not task.step(_nav_at(frame, 0.0, 0.0, heading_deg), 0.1).hold_station
    assert task.sidestep is None


def test_corner_starts_earlier_when_the_current_sets_the_boat_past_the_new_leg() -> None:
    east_leg, south_leg = ((50.0, 0.0), (50.0, 50.0)), (0.0, 50.0)
    # current toward east (along the old leg, across the new one, away from the route): turn earlier
    assert drift_lead_m(*east_leg, south_leg, (0.0, 1.2), 3.0) == pytest.approx(3.6)
    # the same current on the next corner (south leg -> west leg) is along the new leg: no change
    assert drift_lead_m((50.0, 50.0), (0.0, 50.0), (0.0, 0.0), (0.0, 1.2), 3.0) == pytest.approx(0.0)
    # current toward west on the first corner: it sets the boat back from the new leg, turn later
    assert drift_lead_m(*east_leg, south_leg, (0.0, -0.5), 3.0) == pytest.approx(-1.5)


def test_corner_planned_in_the_water_turns_the_bow_from_crab_heading_to_crab_heading() -> None:
    north_then_east = ((0.0, 0.0), (50.0, 0.0), (50.0, 50.0))
    rate, lag = math.radians(45.0), 2.5

    def lead(current: tuple[float, float], entry_mps: float = 2.0) -> float | None:
        return water_corner_lead_m(*north_then_east, current, entry_mps, 2.0, rate, lag)

    # calm water: the calm-water anticipation, an arc of U / r tangent to both legs plus the yaw lag
    assert lead((0.0, 0.0)) == pytest.approx(2.0 / rate + 2.0 * lag * 0.5)
    assert lead((0.0, 0.0), 3.0) == pytest.approx(3.0 / rate + 2.0 * lag * 0.5)
    # 1.2 m/s toward east, along the new leg: no drift across it, but the bow crabs 31 deg west of
    # north on the old leg and turns 121 deg, not 90, ending at 0.8 m/s through the water (2.33 at
    # the start): a wider turn of the bow on a tighter arc, a little earlier
    along_new, calm_lead = lead((0.0, 1.2)), lead((0.0, 0.0))
    assert along_new is not None and calm_lead is not None and calm_lead + 0.2 < along_new < calm_lead + 1.0
    # toward north, down the old leg, it carries the boat past the new leg: earlier; up it, later
    calm, down_old, up_old = lead((0.0, 0.0)), lead((0.8, 0.0)), lead((-0.8, 0.0))
    assert calm is not None and down_old is not None and up_old is not None
    assert down_old > calm + 1.0 and up_old < calm - 0.5
    # not defined: straight on; a current as fast as the corner speed down the new leg
    assert water_corner_lead_m((0.0, 0.0), (50.0, 0.0), (100.0, 1.0), (0.5, 0.0), 2.0, 2.0, rate, lag) is None
    assert lead((0.0, 2.0)) is None


def test_a_leg_from_a_corner_keeps_its_crab_near_the_steady_crab_and_a_first_leg_does_not() -> None:
    """0.5 m/s toward east, observed on north and east legs; the next leg runs north at 4 m/s through
    the water: the bow must crab 7.2 deg west of it.  A leg that starts at a route's corner (the
    previous leg's follower carried over) hands the controllers that steady crab; a first leg
    (joined from a hold, from rest or by a go-to) leaves the measured crab alone."""
    observer = CurrentObserver()
    for heading_deg in (0.0, 90.0):
        h = math.radians(heading_deg)
        for _ in range(200):  # 20 s on each heading: converged
            observer.update(4.0 * math.cos(h), 4.0 * math.sin(h) + 0.5, h, 0.0, 0.1)
    assert observer.converged
    params = ParamStore(all_param_defs())
    home = (41.77, 123.43)
    frame = LocalFrame(*home)
    north = frame.to_lat_lon(50.0, 0.0)
    lat, lon = frame.to_lat_lon(10.0, 0.0)
    running = NavState(t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=math.radians(-7.2),
                       roll_rad=0.0, pitch_rad=0.0, vel_north_mps=4.0 * math.cos(math.radians(7.2)),
                       vel_east_mps=0.0, u_mps=4.0, v_mps=0.5, r_radps=0.0)
    first = GotoTask(params, home, north, 4.0, drift=observer)
    assert first.step(running, 0.1).steady_crab_rad is None
    after_corner = GotoTask(params, home, north, 4.0, follower=first.follower, drift=observer)
    crab_rad = after_corner.step(running, 0.1).steady_crab_rad
    assert crab_rad is not None and math.degrees(crab_rad) == pytest.approx(7.2, abs=0.3)


def _latest(readings: list[tuple[float, float]]) -> Callable[[], tuple[float, float]]:
    return lambda: readings[0]


def test_hold_not_yet_reached_is_planned_again_when_its_current_turns() -> None:
    """The first hold after arming is picked on an estimate still settling from the run-up: a
    hold whose current turns by more than 15 deg before the boat gets to it is planned again on
    the new one (its hold point turns with it), but not within 5 m of the circle, not on the other
    side of the circle and not as the other kind of hold."""
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    current = [(-0.2, 0.45)]  # read 114 deg during the run-up
    task = CircleTask(ParamStore(all_param_defs()), point, 2.0, water_current=lambda: current[0])
    task.step(_nav(frame, -14.0, 0.0, 3.0, 0.0), 0.1)
    first = task.stem
    assert first is not None and first.below_creep
    current[0] = (-0.02, 0.5)  # settled: 92 deg
    task.step(_nav(frame, -12.0, 1.0, 2.5, 1.0), 0.1)
    stem = task.stem
    assert stem is not None and stem is not first
    assert stem.current_ne_mps == (-0.02, 0.5)
    across_rad = math.atan2(stem.hold_ne[1], stem.hold_ne[0])  # 30 deg downstream of across
    assert math.degrees(across_rad) == pytest.approx(182.3 - 30.0, abs=1.0)
    stem.holding = True  # the keeper on the way up the current: not there yet, planned again too
    current[0] = (0.2, 0.45)  # another 26 deg
    task.step(_nav(frame, -12.0, 1.0, 2.5, 1.0), 0.1)
    assert task.stem is not stem and task.stem is not None
    stem = task.stem
    current[0] = (-0.02, 0.5)  # back by 26 deg, but the boat is 4 m outside the circle
    task.step(_nav(frame, -6.0, 0.0, 2.5, 1.0), 0.1)
    assert task.stem is stem
    for turned, why in (((0.5, 0.05), "the other side of the circle"), ((0.15, 0.2), "too weak to hold"),
                        ((0.45, 1.1), "above the idle creep")):
        reading = [(0.0, 0.5)]
        again = CircleTask(ParamStore(all_param_defs()), point, 2.0, water_current=_latest(reading))
        again.step(_nav(frame, -14.0, -3.0, 3.0, 0.0), 0.1)
        kept = again.stem
        assert kept is not None and kept.below_creep
        reading[0] = turned
        again.step(_nav(frame, -13.0, -3.0, 3.0, 0.0), 0.1)
        assert again.stem is kept, why


class _Host:
    def __init__(self, estimate: CurrentEstimate | None) -> None:
        self.water_current = estimate


def test_a_leg_from_a_corner_takes_its_steady_crab_from_a_settled_estimate_before_the_observer() -> None:
    """The square's first corners from rest come before guidance's observer has converged; the
    estimator's current stands in once its uncertainty has settled (slack water included, where the
    current does not stand out of it), so the turn's sideslip is not removed in full as crab (the bow
    swung 4 deg past the second leg, 0.45-0.49 m off it 10 m on, in calm water)."""
    nav = _nav(LocalFrame(41.77, 123.43), 0.0, 0.0, 3.0, 0.0)
    target = ControlTarget(course_rad=0.0, speed_mps=3.0)
    east = CurrentEstimate.from_components(0.0, 0.0, 0.5, 0.004, 0.004, 0.9)
    crabbed = with_steady_crab(target, nav, None, settled_current(_Host(east)))  # type: ignore[arg-type]
    expected = steady_crab_rad(0.0, max(water_speed_mps(3.0, 0.0, (0.0, 0.5)), 1.0), (0.0, 0.5))
    assert crabbed.steady_crab_rad == pytest.approx(expected) and expected > 0.1  # the bow west of the course
    slack = CurrentEstimate.from_components(0.0, 0.02, 0.0, 0.001, 0.001, 0.0)  # settled, not confident
    slack_crab = with_steady_crab(target, nav, None, settled_current(_Host(slack)))  # type: ignore[arg-type]
    assert slack_crab.steady_crab_rad is not None
    unsettled = CurrentEstimate.from_components(0.0, 0.0, 0.5, 0.05, 0.05, 0.9)
    assert with_steady_crab(target, nav, None, settled_current(_Host(unsettled))) == target  # type: ignore[arg-type]
    assert with_steady_crab(target, nav, None, settled_current(_Host(None))) == target  # type: ignore[arg-type]
