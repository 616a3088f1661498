"""Unit tests of legs against the fence (:mod:`companion.fence.legs`) and of a mission's route
(:mod:`companion.mission.route`): crossings, the margin along a leg, coming back in, DO_JUMP,
RTL items and DO_SET_HOME legs."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from companion.fence.legs import LegClearances, leg_clearances, leg_problem, legs_problem
from companion.fence.zones import CircleZone, Fence, PolygonZone, ZoneKind
from companion.guidance.geo import LocalFrame
from companion.mission import items as mi
from companion.mission import validate as v
from companion.mission.items import MissionItem
from companion.mission.route import mission_legs, route_problem

FRAME = LocalFrame(41.77, 123.43)
U_SHAPE = PolygonZone(ZoneKind.INCLUSION, ((0, 0), (0, 30), (30, 30), (30, 20), (10, 20), (10, 10),
                                           (30, 10), (30, 0)))
"""Arms along north at east 0-10 and 20-30, joined at the south (north 0-10); the notch is outside."""
ROCK = PolygonZone(ZoneKind.EXCLUSION, ((40, -10), (40, 10), (60, 10), (60, -10)))
BIG = PolygonZone(ZoneKind.INCLUSION, ((-100, -100), (-100, 100), (100, 100), (100, -100)))


def leg_clearance_1(zone: PolygonZone | CircleZone, a: tuple[float, float],
                    b: tuple[float, float]) -> LegClearances:
    """One leg through the batched geometry."""
    return leg_clearances(zone, np.array([a], dtype=float), np.array([b], dtype=float))


def fence(*zones: PolygonZone | CircleZone) -> Fence:
    return Fence(FRAME, zones)


def test_a_leg_across_the_notch_of_a_concave_inclusion_leaves_it() -> None:
    leg = leg_clearance_1(U_SHAPE, (25.0, 5.0), (25.0, 25.0))  # from one arm to the other, straight
    assert leg.crossings == 2 and leg.start_m > 0 and leg.end_m > 0
    assert leg_problem(fence(U_SHAPE), (25.0, 5.0), (25.0, 25.0), 1.0) == "leaves the inclusion polygon"
    # the way round (down one arm, across the base) is fine with a 1 m margin
    assert leg_problem(fence(U_SHAPE), (25.0, 5.0), (5.0, 5.0), 1.0) is None
    assert leg_problem(fence(U_SHAPE), (5.0, 5.0), (5.0, 25.0), 1.0) is None


def test_a_leg_through_an_exclusion_polygon_crosses_it_and_one_beside_it_keeps_the_margin() -> None:
    f = fence(BIG, ROCK)
    assert leg_problem(f, (0.0, 0.0), (90.0, 0.0), 2.0) == "crosses the exclusion polygon"
    assert leg_problem(f, (0.0, 15.0), (90.0, 15.0), 2.0) is None  # 5 m beside the rock
    why = leg_problem(f, (0.0, 11.0), (90.0, 11.0), 2.0)  # 1 m beside it: within a 2 m margin
    assert why is not None and why.startswith("passes within FENCE_MARGIN of the exclusion polygon")
    assert leg_clearance_1(ROCK, (0.0, 11.0), (90.0, 11.0)).min_m == pytest.approx(1.0)


def test_a_boat_inside_the_margin_may_move_away_from_the_edge_but_not_closer() -> None:
    f = fence(BIG, ROCK)
    assert leg_problem(f, (0.0, 99.0), (0.0, 0.0), 2.0) is None  # 1 m from the edge, going inwards
    assert leg_problem(f, (39.0, 0.0), (39.0, -30.0), 2.0) is None  # 1 m south of the rock, along it
    why = leg_problem(f, (39.0, 0.0), (39.5, -30.0), 2.0)  # closing on the rock's corner: 0.83 m
    assert why == "passes within FENCE_MARGIN of the exclusion polygon (1 m)"


def test_coming_back_in_crosses_once_and_the_end_must_be_allowed() -> None:
    f = fence(BIG, ROCK)
    assert leg_problem(f, (0.0, 150.0), (0.0, 0.0), 2.0) is None  # pushed out, sent back in
    assert leg_problem(f, (0.0, 0.0), (0.0, 150.0), 2.0) == "ends outside the inclusion polygon (-50 m)"
    assert leg_problem(f, (0.0, 0.0), (50.0, 0.0), 2.0, keep_margin=False) == \
        "ends inside the exclusion polygon (-10 m)"
    # a U-shaped inclusion entered through the notch's mouth and left again: crosses twice
    assert leg_problem(fence(U_SHAPE), (25.0, -5.0), (25.0, 35.0), 0.0) is not None


def test_circles_inclusion_and_exclusion() -> None:
    keep_in = CircleZone(ZoneKind.INCLUSION, (0.0, 0.0), 100.0)
    buoy = CircleZone(ZoneKind.EXCLUSION, (50.0, 0.0), 10.0)
    f = fence(keep_in, buoy)
    assert leg_problem(f, (0.0, 0.0), (90.0, 0.0), 2.0) == "crosses the exclusion circle"
    assert leg_clearance_1(buoy, (0.0, 0.0), (90.0, 0.0)).crossings == 2
    assert leg_clearance_1(buoy, (0.0, 20.0), (90.0, 20.0)).min_m == pytest.approx(10.0)
    assert leg_problem(f, (0.0, 20.0), (90.0, 20.0), 2.0) is None
    assert leg_clearance_1(keep_in, (0.0, 0.0), (60.0, 0.0)).min_m == pytest.approx(40.0)
    assert leg_problem(f, (0.0, -150.0), (0.0, -50.0), 2.0) is None  # from outside, in once


def waypoint(seq: int, north_m: float, east_m: float) -> MissionItem:
    return MissionItem.waypoint(seq, *FRAME.to_lat_lon(north_m, east_m))


def command(seq: int, cmd: int, param1: float = 0.0, param2: float = 0.0) -> MissionItem:
    return MissionItem(seq=seq, frame=mi.FRAME_MISSION, command=cmd, param1=param1, param2=param2, param3=0,
                       param4=0, x=0, y=0, z=0, current=0, autocontinue=1)


def test_mission_legs_from_home_with_rtl_jump_and_set_home() -> None:
    home = FRAME.to_lat_lon(0.0, 0.0)
    items = [waypoint(1, 10, 0), waypoint(2, 20, 0), command(3, mi.CMD_DO_JUMP, 1, 2),
             command(4, mi.CMD_NAV_RETURN_TO_LAUNCH), command(5, mi.CMD_DO_SET_HOME, 0),
             waypoint(6, 30, 0), command(7, mi.CMD_DO_SET_HOME, 1), command(8, mi.CMD_NAV_RETURN_TO_LAUNCH)]
    legs = mission_legs(items, home, v.BUILT_IN.needs_position)
    assert [leg.name for leg in legs] == ["leg home-1", "leg 1-2", "leg 2-1 (DO_JUMP 3)", "leg 2-home",
                                          "leg home-6", "leg 6-home"]
    assert legs[-1].end == pytest.approx(FRAME.to_lat_lon(30.0, 0.0))  # DO_SET_HOME 1: home moved to item 6
    no_home = mission_legs(items[:2], None, v.BUILT_IN.needs_position)
    assert [leg.name for leg in no_home] == ["leg 1-2"]


def test_route_problem_names_the_item_or_the_leg() -> None:
    f = fence(BIG, ROCK)

    def place(lat: float, lon: float) -> str | None:
        c, _ = f.clearance_at_m(lat, lon)
        return None if c >= 2.0 else "outside"

    def legs(pairs: Sequence[tuple[tuple[float, float], tuple[float, float]]]) -> tuple[int, str] | None:
        return legs_problem(f, [(f.to_ne(*a), f.to_ne(*b)) for a, b in pairs], 2.0)

    home = FRAME.to_lat_lon(0.0, 0.0)
    through = [waypoint(1, 20, 0), waypoint(2, 80, 0)]
    problem = route_problem(through, home, v.BUILT_IN.needs_position, place, legs)
    assert problem == v.ItemProblem(v.INVALID, "leg 1-2: crosses the exclusion polygon")
    outside = [waypoint(1, 20, 0), waypoint(2, 200, 0)]
    problem = route_problem(outside, home, v.BUILT_IN.needs_position, place, legs)
    assert problem == v.ItemProblem(v.INVALID_PARAM5_X, "item 2: outside")
    around = [waypoint(1, 20, 30), waypoint(2, 80, 30), waypoint(3, 80, 0)]
    assert route_problem(around, home, v.BUILT_IN.needs_position, place, legs) is None


def test_batched_ends_agree_with_the_zone_clearance_and_the_first_bad_leg_is_named() -> None:
    rng = np.random.default_rng(7)
    a, b = rng.uniform(-120, 120, (300, 2)), rng.uniform(-120, 120, (300, 2))
    for zone in (U_SHAPE, ROCK, BIG, CircleZone(ZoneKind.EXCLUSION, (10.0, -5.0), 30.0)):
        legs = leg_clearances(zone, a, b)
        assert legs.start_m == pytest.approx([zone.clearance_m((n, e)) for n, e in a])
        assert legs.end_m == pytest.approx([zone.clearance_m((n, e)) for n, e in b])
        assert np.all(legs.min_m <= np.minimum(legs.start_m, legs.end_m) + 1e-9)
    f = fence(BIG, ROCK)
    route = [((0.0, 0.0), (0.0, 30.0)), ((0.0, 30.0), (90.0, 30.0)), ((90.0, 30.0), (90.0, -30.0)),
             ((90.0, -30.0), (20.0, 0.0))]  # round the rock, then back through its corner
    assert legs_problem(f, route, 2.0) == (3, "crosses the exclusion polygon")
    assert legs_problem(f, route[:3], 2.0) is None
