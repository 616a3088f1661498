"""Unit tests of the fence geometry (clearance of polygons and circles) and of the breach logic."""

from __future__ import annotations

import math

import pytest

from companion.fence.monitor import CLEAR_HYSTERESIS_M, FenceMonitor, check_fence, lookahead_m
from companion.fence.zones import CircleZone, PolygonZone, ZoneKind, fence_from_plan
from companion.guidance.geo import LocalFrame
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from companion.mission.validate import BUILT_IN, INVALID_PARAM1

ORIGIN = (41.77, 123.43)
FRAME = LocalFrame(*ORIGIN)


def fence_item(seq: int, command: int, north_m: float, east_m: float, param1: float) -> MissionItem:
    lat, lon = FRAME.to_lat_lon(north_m, east_m)
    item = MissionItem.at(seq, command, lat, lon, param1=param1)
    return MissionItem(**{**item.to_dict(), "mission_type": MissionType.FENCE})


def square(seq0: int, half_m: float, command: int = mi.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
           centre: tuple[float, float] = (0.0, 0.0)) -> list[MissionItem]:
    corners = [(-half_m, -half_m), (-half_m, half_m), (half_m, half_m), (half_m, -half_m)]
    return [fence_item(seq0 + i, command, centre[0] + n, centre[1] + e, 4)
            for i, (n, e) in enumerate(corners)]


def test_square_clearance_is_the_distance_to_the_nearest_edge_signed_by_inside() -> None:
    zone = PolygonZone(ZoneKind.INCLUSION, ((-50, -50), (-50, 50), (50, 50), (50, -50)))
    assert zone.clearance_m((0.0, 0.0)) == pytest.approx(50.0)
    assert zone.clearance_m((0.0, 40.0)) == pytest.approx(10.0)
    assert zone.clearance_m((0.0, 60.0)) == pytest.approx(-10.0)
    assert zone.clearance_m((60.0, 60.0)) == pytest.approx(-math.hypot(10, 10))
    hole = PolygonZone(ZoneKind.EXCLUSION, zone.vertices_ne)
    assert hole.clearance_m((0.0, 40.0)) == pytest.approx(-10.0)
    assert hole.clearance_m((0.0, 60.0)) == pytest.approx(10.0)


def test_concave_polygon_inside_test() -> None:
    # a U shape: the notch between the arms is outside
    u_shape = PolygonZone(ZoneKind.INCLUSION, ((0, 0), (0, 30), (30, 30), (30, 20), (10, 20), (10, 10),
                                                (30, 10), (30, 0)))
    assert u_shape.contains((5.0, 15.0)) and u_shape.contains((20.0, 5.0))
    assert not u_shape.contains((20.0, 15.0))  # in the notch
    assert u_shape.clearance_m((20.0, 15.0)) == pytest.approx(-5.0)


def test_circles() -> None:
    keep_in = CircleZone(ZoneKind.INCLUSION, (0.0, 0.0), 100.0)
    keep_out = CircleZone(ZoneKind.EXCLUSION, (0.0, 0.0), 100.0)
    assert keep_in.clearance_m((60.0, 0.0)) == pytest.approx(40.0)
    assert keep_out.clearance_m((60.0, 0.0)) == pytest.approx(-40.0)
    assert keep_in.clearance_m((0.0, 130.0)) == pytest.approx(-30.0)


def test_fence_from_plan_combines_every_zone_by_the_smallest_clearance() -> None:
    plan = [*square(0, 100.0),
            fence_item(4, mi.CMD_NAV_FENCE_CIRCLE_EXCLUSION, 50.0, 0.0, 10.0),
            *square(5, 5.0, mi.CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, centre=(-50.0, 0.0))]
    assert BUILT_IN.validate_plan(plan, home_first=False) is None
    fence = fence_from_plan(plan)
    assert len(fence.zones) == 3
    lat, lon = FRAME.to_lat_lon(0.0, 0.0)
    clearance, zone = fence.clearance_at_m(lat, lon)
    assert clearance == pytest.approx(40.0, abs=0.05) and isinstance(zone, CircleZone)
    lat, lon = FRAME.to_lat_lon(50.0, 5.0)  # inside the exclusion circle
    assert fence.clearance_at_m(lat, lon)[0] == pytest.approx(-5.0, abs=0.05)
    lat, lon = FRAME.to_lat_lon(-50.0, 0.0)  # centre of the exclusion square
    assert fence.clearance_at_m(lat, lon)[0] == pytest.approx(-5.0, abs=0.05)
    lat, lon = FRAME.to_lat_lon(0.0, 120.0)  # beyond the inclusion square
    clearance, zone = fence.clearance_at_m(lat, lon)
    assert clearance == pytest.approx(-20.0, abs=0.05) and isinstance(zone, PolygonZone)


def test_incomplete_polygon_is_refused_at_upload() -> None:
    plan = square(0, 50.0)[:3]  # says 4 vertices, has 3
    problem = BUILT_IN.validate_plan(plan, home_first=False)
    assert problem is not None and problem.code == INVALID_PARAM1 and "incomplete" in problem.reason


def test_lookahead_is_reaction_travel_plus_turning_radius() -> None:
    assert lookahead_m(0.0, 1.0, 0.5) == 0.0
    assert lookahead_m(5.0, 1.0, 0.5) == pytest.approx(5.0 + 10.0)
    assert lookahead_m(math.nan, 1.0, 0.5) == 0.0


def test_predicted_point_follows_the_course_over_ground() -> None:
    fence = fence_from_plan(square(0, 100.0))
    lat, lon = FRAME.to_lat_lon(0.0, 80.0)  # 20 m from the east edge
    toward = check_fence(fence, lat, lon, 0.0, 5.0, 1.0, 0.5)  # east at 5 m/s: 15 m lookahead
    assert toward.clearance_m == pytest.approx(20.0, abs=0.05)
    assert toward.predicted_clearance_m == pytest.approx(5.0, abs=0.05)
    away = check_fence(fence, lat, lon, 0.0, -5.0, 1.0, 0.5)
    assert away.worst_m == pytest.approx(20.0, abs=0.05)
    along = check_fence(fence, lat, lon, 5.0, 0.0, 1.0, 0.5)  # parallel to the edge
    assert along.worst_m == pytest.approx(20.0, abs=0.05)


def test_breach_episodes_count_once_and_clear_with_hysteresis() -> None:
    fence = fence_from_plan(square(0, 100.0))
    monitor = FenceMonitor()
    monitor.set_fence(fence)
    margin = 2.0
    events = []
    for t, east in enumerate([90.0, 97.0, 97.5, 99.0, 98.5, 97.5, 96.0, 97.9, 90.0]):
        lat, lon = FRAME.to_lat_lon(0.0, east)
        events.append(monitor.update(check_fence(fence, lat, lon, 0.0, 0.0, 1.0, 0.5), margin, float(t)))
    # 97.5 m: 2.5 m clearance; 99 m: 1 m < margin -> breach; clears only at >= margin + hysteresis (3 m)
    assert events == [False, False, False, True, False, False, False, False, False]
    assert monitor.breach_count == 1 and monitor.breach_time_s == 3.0
    assert not monitor.breached
    assert CLEAR_HYSTERESIS_M == 1.0
    lat, lon = FRAME.to_lat_lon(0.0, 101.0)
    assert monitor.update(check_fence(fence, lat, lon, 0.0, 0.0, 1.0, 0.5), margin, 9.0)
    assert monitor.breach_count == 2 and monitor.last is not None and monitor.last.outside


def test_a_breach_return_point_is_accepted_and_not_a_zone() -> None:
    """QGC uploads a breach return point (MAV_CMD_NAV_FENCE_RETURN_POINT) with the zones if the user
    places one: the plan is accepted, the point stored and not used (RTL goes home, as on Rover)."""
    plan = [fence_item(0, mi.CMD_NAV_FENCE_RETURN_POINT, 10.0, 10.0, 0.0), *square(1, 50.0)]
    assert BUILT_IN.validate_plan(plan, home_first=False) is None
    assert len(fence_from_plan(plan).zones) == 1
