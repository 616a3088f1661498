"""Navigating modes on the full companion stack against the simulated boat (lockstep SITL).

Every test runs the companion as on the boat (GPS-INS bytes -> parser -> estimator -> mode ->
controller -> servo frames -> plant) with :class:`sim_bridge.sitl.SitlHarness`, faster than
real time.  The vehicle API (arm, set_mode, mission store) is what the MAVLink services call.
"""

from __future__ import annotations

import itertools
import math

import pytest

from companion.config import default_config
from companion.control.params import CTRL_ACTIVE_MODEL, CTRL_PID
from companion.guidance.geo import LocalFrame, distance_to_segment_m
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from companion.mission.validate import validate_plan
from companion.vehicle import MissionState, Vehicle
from sim_bridge.sitl import SitlHarness

HOME = (41.77, 123.43)


def _pos(h: SitlHarness) -> tuple[float, float]:
    return h.plant.state.north_m, h.plant.state.east_m


async def _start(h: SitlHarness) -> Vehicle:
    await h.run_for(2.0)
    vehicle = h.services.vehicle
    assert vehicle.arm() is None
    return vehicle


def _plan(frame: LocalFrame, items: list[tuple[int, tuple[float, float] | None, dict[str, float]]]
          ) -> list[MissionItem]:
    plan = [MissionItem.home(*HOME)]
    for seq, (cmd, ne, params) in enumerate(items, start=1):
        if ne is None:
            plan.append(MissionItem(seq=seq, frame=mi.FRAME_MISSION, command=cmd, **params))
        else:
            plan.append(MissionItem.at(seq, cmd, *frame.to_lat_lon(*ne), **params))
    return plan


@pytest.mark.parametrize("ctrl_type", [CTRL_PID, CTRL_ACTIVE_MODEL])
async def test_auto_mission_runs_every_item_and_reports_complete(ctrl_type: int) -> None:
    async with SitlHarness(seed=3, wind="3,45", current="0.3,90", full_stack=True,
                           params={"USV_CTRL_TYPE": ctrl_type}) as h:
        vehicle = await _start(h)
        frame = LocalFrame(*HOME)
        plan = _plan(frame, [
            (mi.CMD_NAV_WAYPOINT, (40.0, 0.0), {}),
            (mi.CMD_DO_CHANGE_SPEED, None, {"param2": 3.0}),
            (mi.CMD_NAV_WAYPOINT, (40.0, 40.0), {}),
            (mi.CMD_NAV_LOITER_TIME, (40.0, 40.0), {"param1": 10.0}),
            (mi.CMD_NAV_WAYPOINT, (0.0, 40.0), {}),
        ])
        assert validate_plan(plan, home_first=True) is None
        vehicle.missions.replace(MissionType.MISSION, plan)
        reached: list[int] = []
        vehicle.reached_listeners.append(reached.append)
        assert vehicle.set_mode(10) is None
        await h.run_until(lambda: vehicle.mission_state == MissionState.COMPLETE, 180.0)
        assert reached == [1, 3, 4, 5]
        assert vehicle.mission_state == MissionState.COMPLETE
        assert vehicle.modes.current.name == "HOLD"  # MIS_DONE_BEHAVE 0
        n, e = _pos(h)
        assert math.hypot(n - 0.0, e - 40.0) < 6.0  # at the last waypoint (WP_RADIUS + stopping)


async def test_auto_passes_every_waypoint_within_the_acceptance_radius_the_mission_gives() -> None:
    """A survey as MAVSDK uploads it (every item with its own acceptance radius, here 1.5 m; 20 m
    lines 8 m apart, fly-through at 4 m/s): each right-angle corner is passed within its radius;
    turning onto the next leg as early as the corner planning does for ``WP_RADIUS``, the boat cut
    every other corner by more than the radius."""
    accept_m = 1.5
    async with SitlHarness(seed=1, full_stack=True) as h:
        vehicle = await _start(h)
        frame = LocalFrame(*HOME)
        points = [(15.0 + 8.0 * (i // 2), (0.0 if i % 4 in (0, 3) else 20.0)) for i in range(12)]
        plan = _plan(frame, [(mi.CMD_DO_CHANGE_SPEED, None, {"param1": 1.0, "param2": 4.0, "param3": -1.0}),
                             *[(mi.CMD_NAV_WAYPOINT, ne, {"param2": accept_m}) for ne in points]])
        vehicle.missions.replace(MissionType.MISSION, plan)
        assert vehicle.set_mode(10) is None
        track = [_pos(h)]
        for _ in range(1500):
            await h.run_for(0.1)
            track.append(_pos(h))
            if vehicle.mission_state == MissionState.COMPLETE:
                break
        assert vehicle.mission_state == MissionState.COMPLETE
        passed = {i + 1: round(min(distance_to_segment_m(p, a, b) for a, b in itertools.pairwise(track)), 2)
                  for i, p in enumerate(points)}
        assert max(passed.values()) <= accept_m, passed


async def test_auto_is_refused_without_a_mission_and_says_why() -> None:
    async with SitlHarness(seed=1, full_stack=True) as h:
        vehicle = await _start(h)
        reason = vehicle.set_mode(10)
        assert reason is not None and "no mission" in reason
        assert vehicle.modes.current.name == "HOLD"


def test_mission_items_with_bad_coordinates_are_refused_at_upload() -> None:
    frame = LocalFrame(*HOME)
    good = _plan(frame, [(mi.CMD_NAV_WAYPOINT, (10.0, 0.0), {})])
    assert validate_plan(good, home_first=True) is None
    out_of_range = [good[0], MissionItem(seq=1, frame=mi.FRAME_GLOBAL_INT, command=mi.CMD_NAV_WAYPOINT,
                                         x=round(91.0 * 1e7), y=round(HOME[1] * 1e7))]
    problem = validate_plan(out_of_range, home_first=True)
    assert problem is not None and "latitude" in problem.reason
    missing = [good[0], MissionItem(seq=1, frame=mi.FRAME_GLOBAL_INT, command=mi.CMD_NAV_LOITER_TURNS,
                                    param1=float("nan"), x=good[1].x, y=good[1].y)]
    assert validate_plan(missing, home_first=True) is not None


async def test_guided_goes_to_the_target_and_stays_there() -> None:
    """A flood current with wind and waves; station keeping runs the PID family (USV_STN_CTRL 0)
    although USV_CTRL_TYPE is the active model: the active-model law lets the boat wander 5-7 m
    off the point here."""
    async with SitlHarness(seed=2, current="1.2,0", wind="3,45", waves="0.3", full_stack=True) as h:
        vehicle = await _start(h)
        from companion.messages import GuidedTarget

        lat, lon = LocalFrame(*HOME).to_lat_lon(0.0, 40.0)
        assert vehicle.set_mode(15) is None
        vehicle.guided_target = GuidedTarget(lat, lon, t_s=h.ctx.clock.now_s())
        await h.run_for(60.0)
        dists = []
        for _ in range(20):
            await h.run_for(1.0)
            n, e = _pos(h)
            dists.append(math.hypot(n, e - 40.0))
        assert max(dists) < 1.0  # measured 0.22-0.55 m, seeds 1-3


async def test_rtl_returns_home_and_keeps_station_against_the_current() -> None:
    async with SitlHarness(seed=4, current="1.2,90", full_stack=True) as h:
        vehicle = await _start(h)
        assert vehicle.set_mode(20) is None  # CRUISE with the heading of the moment
        vehicle.speed_override_mps = 4.0
        await h.run_for(15.0)
        assert math.hypot(*_pos(h)) > 30.0
        assert vehicle.set_mode(11) is None
        assert vehicle.home is not None
        home = LocalFrame(*HOME).to_ne(vehicle.home.lat_deg, vehicle.home.lon_deg)  # set at arming
        await h.run_for(50.0)
        dists = []
        for _ in range(20):
            await h.run_for(1.0)
            dists.append(math.dist(_pos(h), home))
        assert max(dists) < 2.0  # WP_RADIUS (measured 1.2-1.9 m, seeds 1-5: the arrival loop settling)


async def _loiter_for_a_minute(h: SitlHarness, vehicle: Vehicle) -> list[float]:
    """Enter LOITER where the boat is; its distance from there once a second for 60 s."""
    start = _pos(h)
    assert vehicle.set_mode(5) is None
    dists = []
    for _ in range(60):
        await h.run_for(1.0)
        dists.append(math.dist(_pos(h), start))
    return dists


async def test_loiter_keeps_station_where_hold_drifts() -> None:
    async with SitlHarness(seed=5, current="1.5,90", wind="3,0", full_stack=True) as h:
        vehicle = await _start(h)
        dists = await _loiter_for_a_minute(h, vehicle)
        assert max(dists[20:]) < 2.0  # LOIT_RADIUS
        assert vehicle.set_mode(4) is None
        before = _pos(h)
        await h.run_for(20.0)
        n, e = _pos(h)
        assert math.hypot(n - before[0], e - before[1]) > 8.0  # HOLD drifts with the current


async def test_loiter_entered_facing_downstream_turns_round_and_holds_the_point() -> None:
    """A flood: 1.2 m/s current from behind, 3 m/s wind, Hs 0.3 m waves.  The boat has to turn
    round into the current, drifting off meanwhile; that is not slack water, so LOITER keeps
    station instead of switching to an orbit that the current sweeps away (measured 6.8-7.1 m
    with the earlier rule, 1.1-1.3 m now, seeds 1-3)."""
    async with SitlHarness(seed=2, current="1.2,0", wind="3,45", waves="0.3", full_stack=True) as h:
        dists = await _loiter_for_a_minute(h, await _start(h))
        assert max(dists[20:]) < 2.0  # LOIT_RADIUS


async def test_cruise_holds_heading_and_speed_and_switches_controller_family_while_moving() -> None:
    async with SitlHarness(seed=6, wind="3,90", waves="0.3", psi0_deg=30.0, full_stack=True,
                           params={"USV_CTRL_TYPE": CTRL_PID}) as h:
        vehicle = await _start(h)
        assert vehicle.set_mode(20) is None
        vehicle.speed_override_mps = 4.0
        await h.run_for(20.0)
        control = h.services.control
        errors = []
        for k in range(40):
            if k == 20:
                h.ctx.params.set("USV_CTRL_TYPE", CTRL_ACTIVE_MODEL)
            await h.run_for(0.5)
            s = h.plant.state
            errors.append(abs(math.degrees(math.remainder(s.psi_rad - math.radians(30.0), 2 * math.pi))))
            assert abs(s.u_mps - 4.0) < 0.6
        assert control.family_type() == CTRL_ACTIVE_MODEL  # type: ignore[attr-defined]
        assert max(errors) < 4.0


async def test_auto_samples_water_while_circling_each_point_in_current() -> None:
    """The chapter's water-sampling run (section 4.2): circle each point, fill one bottle there."""
    async with SitlHarness(seed=7, current="0.3,30", full_stack=True,
                           params={"USV_CTRL_TYPE": CTRL_ACTIVE_MODEL, "USV_SMPL_FILL_S": 10.0}) as h:
        vehicle = await _start(h)
        frame = LocalFrame(*HOME)
        points = [(30.0, 0.0), (30.0, 30.0)]
        plan = _plan(frame, [(31001, ne, {"param1": k + 1}) for k, ne in enumerate(points)])
        assert validate_plan(plan, home_first=True) is None
        vehicle.missions.replace(MissionType.MISSION, plan)
        assert vehicle.set_mode(10) is None
        far_while_pumping = 0.0
        for _ in range(3000):
            await h.run_for(0.1)
            if h.sampler.pump_on:
                n, e = _pos(h)
                nearest = min(math.hypot(n - p[0], e - p[1]) for p in points)
                far_while_pumping = max(far_while_pumping, nearest)
            if vehicle.mission_state == MissionState.COMPLETE:
                break
        assert vehicle.mission_state == MissionState.COMPLETE
        assert h.sampler.bottles_ml[0] > 0 and h.sampler.bottles_ml[1] > 0
        # the sampler gates the pump on the *measured* position (USV_SMPL_ACC_M 2.5 m); the true
        # distance may exceed it by the GPS-INS error and one control period (measured: 2.55-2.6 m)
        assert far_while_pumping <= 2.75


def _mid_leg_cross_track_m(track: list[tuple[float, float]], a: tuple[float, float],
                           b: tuple[float, float]) -> list[float]:
    """Distances from the line a -> b of the points (flown on that leg) 10 m after a to 10 m
    before b."""
    length = math.dist(a, b)
    ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    out = []
    for n, e in track:
        along = (n - a[0]) * ux + (e - a[1]) * uy
        if 10.0 <= along <= length - 10.0:
            out.append(abs(-(n - a[0]) * uy + (e - a[1]) * ux))
    return out


async def _fly_waypoints(h: SitlHarness,
                         points: list[tuple[float, float]]) -> dict[int, list[tuple[float, float]]]:
    """Arm, fly ``points`` (north, east m from home) as an AUTO mission of waypoints to completion;
    the boat's positions by the mission item being flown."""
    vehicle = await _start(h)
    plan = _plan(LocalFrame(*HOME), [(mi.CMD_NAV_WAYPOINT, ne, {}) for ne in points])
    vehicle.missions.replace(MissionType.MISSION, plan)
    assert vehicle.set_mode(10) is None
    legs: dict[int, list[tuple[float, float]]] = {}
    for _ in range(1200):
        await h.run_for(0.1)
        legs.setdefault(vehicle.current_seq, []).append(_pos(h))
        if vehicle.mission_state == MissionState.COMPLETE:
            break
    assert vehicle.mission_state == MissionState.COMPLETE
    return legs


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3])
async def test_auto_square_in_cross_current_holds_the_middle_of_every_leg(seed: int) -> None:
    """The issue's square, flown as an AUTO mission on the full stack (active model, shipped
    default model): 50 m at 5 m/s, 0.5 m/s current across the first leg, 3 m/s wind, Hs 0.3 m
    waves.  The middle of every leg is held within 0.5 m (RMS over the middles 0.2 m) and the
    boat never gets 2 m off the square, corners included."""
    async with SitlHarness(seed=seed, wind="3,45", current="0.5,90", waves="0.3", full_stack=True,
                           params={"USV_CTRL_TYPE": CTRL_ACTIVE_MODEL, "WP_SPEED": 5.0}) as h:
        corners = [(0.0, 0.0), (50.0, 0.0), (50.0, 50.0), (0.0, 50.0), (0.0, 0.0)]
        legs = await _fly_waypoints(h, corners)
        mid = [_mid_leg_cross_track_m(legs[seq], corners[seq - 2], corners[seq - 1]) for seq in (2, 3, 4, 5)]
        assert max(max(leg) for leg in mid) <= 0.5, [max(leg) for leg in mid]
        pooled = [x for leg in mid for x in leg]  # as usv bench pools the middles of the legs
        assert math.sqrt(sum(x * x for x in pooled) / len(pooled)) <= 0.2
        flown = [p for seq in (2, 3, 4, 5) for p in legs[seq]][50:]  # from 5 s after the start
        legs_ne = list(itertools.pairwise(corners))
        assert max(min(distance_to_segment_m(p, a, b) for a, b in legs_ne) for p in flown) <= 2.0


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
async def test_auto_square_in_calm_water_comes_out_of_every_corner_onto_the_next_leg(seed: int) -> None:
    """The bench's 50 m square as an AUTO mission from rest in calm water (full stack, default
    parameters): from 10 m after each corner every leg is held within 0.4 m, RMS 0.15 m (the
    issue's mid-leg targets).  Removing a turn's sideslip as crab in full swung the bow 10-15 deg
    past the next leg: 0.41-0.50 m inside it 10 m on (``STEADY_CRAB_MARGIN_RAD``); the second
    corner comes before guidance's observer has converged, and there the steady crab is the
    estimator's settled current (without it 0.45-0.49 m; with it 0.20-0.23 m with an 8 deg margin,
    0.09-0.16 m on legs 2-4 with 5 deg)."""
    async with SitlHarness(seed=seed, current="0,0", wind="0,0", waves="0", full_stack=True) as h:
        corners = [(0.0, 0.0), (50.0, 0.0), (50.0, 50.0), (0.0, 50.0), (0.0, 0.0)]
        legs = await _fly_waypoints(h, corners[1:])
        mid = [_mid_leg_cross_track_m(legs[seq], corners[seq - 1], corners[seq]) for seq in (1, 2, 3, 4)]
        assert max(max(leg) for leg in mid) <= 0.4, [max(leg) for leg in mid]
        pooled = [x for leg in mid for x in leg]
        assert math.sqrt(sum(x * x for x in pooled) / len(pooled)) <= 0.15


async def _leg_across_a_flood_m(h: SitlHarness) -> list[float]:
    """A 150 m leg east across the current after a 90 deg corner (60 m north first); the distances
    from its line from 30 m after the corner to 20 m before its end."""
    vehicle = await _start(h)
    frame = LocalFrame(*HOME)
    corner, end = (60.0, 0.0), (60.0, 150.0)
    legs: list[tuple[int, tuple[float, float] | None, dict[str, float]]] = [
        (mi.CMD_NAV_WAYPOINT, corner, {}), (mi.CMD_NAV_WAYPOINT, end, {})]
    vehicle.missions.replace(MissionType.MISSION, _plan(frame, legs))
    assert vehicle.set_mode(10) is None
    track: list[tuple[float, float]] = []
    for _ in range(900):
        await h.run_for(0.1)
        if vehicle.current_seq == 2:
            track.append(_pos(h))
        if vehicle.mission_state == MissionState.COMPLETE:
            break
    assert vehicle.mission_state == MissionState.COMPLETE
    middle = [abs(n - corner[0]) for n, e in track if 30.0 <= e <= end[1] - 20.0]
    assert len(middle) > 100
    return middle


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
async def test_auto_leg_across_a_flood_current_is_flown_on_its_line_without_snaking(seed: int) -> None:
    """A 150 m leg east across a 1.2 m/s current toward north, after a 90 deg corner, at 5 m/s with
    the current-augmented UKF alone (``models.ukf = "current"``: its model error is the water-relative
    model's, so the active-model law runs the model on the velocity through the water) and the ILOS
    integral off (``USV_LOS_KI`` 0).  From 30 m after the corner to 20 m before the end the boat
    stays within 0.5 m of the line (RMS 0.25 m; measured 0.26-0.28 / 0.14 m).  The same filter with the
    law on over-ground velocities read the cross-current as sway and snaked the boat 2-5 m off the
    line; the shipped law on the chapter's filter without its coupling correction (``USV_AM_CPL_TC``
    0) snakes 0.7-0.85 m (RMS 0.35-0.39 m)."""
    config = default_config().with_overrides({"models.ukf": "current"})
    async with SitlHarness(seed=seed, current="1.2,0", full_stack=True, config=config,
                           params={"WP_SPEED": 5.0, "USV_LOS_KI": 0.0}) as h:
        middle = await _leg_across_a_flood_m(h)
    assert max(middle) <= 0.5, max(middle)
    assert math.sqrt(sum(x * x for x in middle) / len(middle)) <= 0.25


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
async def test_auto_leg_across_a_flood_current_holds_its_line_as_shipped(seed: int) -> None:
    """The same leg as shipped (the chapter's filter, ``USV_LOS_KI`` 0.04): on a leg the law takes
    the fast part of the current's yaw coupling out of its over-ground model (``USV_AM_CPL_TC``
    0.5 s), so a heading wobble across the current no longer reads as a yaw moment.  The middle of
    the leg is within the issue's mid-leg targets, 0.4 m (RMS 0.15 m); measured 0.21 m (RMS
    0.10-0.11 m), where ``USV_AM_CPL_TC`` 0 (the law before) snakes 0.71-0.84 m (RMS 0.35-0.39 m),
    and an ILOS integral wound up on the turn onto the leg held it 0.3-0.4 m up the current (0.41 m,
    RMS 0.22 m; ``LosGains.course_gate_rad``)."""
    async with SitlHarness(seed=seed, current="1.2,0", full_stack=True, params={"WP_SPEED": 5.0}) as h:
        middle = await _leg_across_a_flood_m(h)
    assert max(middle) <= 0.4, max(middle)
    assert math.sqrt(sum(x * x for x in middle) / len(middle)) <= 0.15
