"""Where the rescue script plans to stop and fire (``missions/rescue.py``, no vehicle needed): in
moving water downstream of the casualty with the bow into the current, on the direct line in
slack water or when the estimate is unsure, and never on a route over the person."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest

from companion.guidance.geo import LocalFrame
from missions import rescue
from missions.common import MissionError, WaterCurrent

FRAME = LocalFrame(41.77, 123.43)
HOME = (0.0, 0.0)


def plan(casualty: tuple[float, float], drift: tuple[float, float, float] | None,
         *extra: str) -> dict[str, Any]:
    """The plan in water drifting at ``drift`` (north m/s, east m/s, confidence)."""
    current = None if drift is None else WaterCurrent(*drift)
    return rescue.plan_from(FRAME, HOME, casualty, rescue.parse_args(list(extra)), current)


def route(p: dict[str, Any]) -> list[tuple[float, float]]:
    return [HOME, *([p["detour_ne"]] if p["detour_ne"] else []), p["slow_ne"], p["launch_ne"]]


def closest_approach_m(points: list[tuple[float, float]], to: tuple[float, float]) -> float:
    best = math.inf
    for (an, ae), (bn, be) in itertools.pairwise(points):
        dn, de = bn - an, be - ae
        s = max(0.0, min(1.0, ((to[0] - an) * dn + (to[1] - ae) * de) / (dn * dn + de * de)))
        best = min(best, math.dist((an + s * dn, ae + s * de), to))
    return best


def test_in_a_current_the_boat_stops_downstream_with_its_bow_into_the_current() -> None:
    p = plan((100.0, 30.0), (0.0, 0.5, 0.9))  # 0.5 m/s flowing east
    assert p["approach"] == "upstream"
    assert p["bearing_deg"] == pytest.approx(270.0)  # bow west, into the current, onto the casualty
    assert p["launch_ne"] == pytest.approx((100.0, 45.0))  # 15 m downstream (the default standoff)
    assert p["slow_ne"] == pytest.approx((100.0, 85.0))  # the last 40 m against the current
    assert closest_approach_m(route(p), (100.0, 30.0)) >= 15.0 - 1e-9


def test_slack_water_an_unsure_estimate_or_direct_keep_the_straight_line() -> None:
    straight = (100.0 - 15.0 * 100.0 / math.hypot(100, 30), 30.0 - 15.0 * 30.0 / math.hypot(100, 30))
    for drift, extra in [(None, ()), ((0.0, 0.05, 0.9), ()), ((0.0, 0.5, 0.2), ()),
                         ((0.0, 0.5, 0.9), ("--approach", "direct"))]:
        p = plan((100.0, 30.0), drift, *extra)
        assert p["approach"] == "direct", (drift, extra)
        assert p["launch_ne"] == pytest.approx(straight)
        assert p["bearing_deg"] == pytest.approx(math.degrees(math.atan2(30, 100)))


def test_a_route_that_would_cross_the_casualty_goes_round_them() -> None:
    # the casualty 100 m north, water flowing north: the launch point is beyond them
    p = plan((100.0, 0.0), (0.6, 0.0, 0.8))
    assert p["launch_ne"] == pytest.approx((115.0, 0.0)) and p["bearing_deg"] == pytest.approx(180.0)
    assert p["detour_ne"] is not None and math.dist(p["detour_ne"], (100.0, 0.0)) == pytest.approx(30.0)
    assert closest_approach_m(route(p), (100.0, 0.0)) >= 15.0 - 1e-9
    names = p["names"]
    assert names[p["seq"]["slow"] - 1] == "round the casualty"
    assert [item.seq for item in p["items"]] == list(range(len(names)))
    launch = p["items"][p["seq"]["launch"]]
    assert launch.param1 == pytest.approx(180.0) and launch.param3 == 15.0  # aimed at the casualty
    assert plan((100.0, 30.0), (0.0, 0.5, 0.9))["detour_ne"] is None


def test_a_casualty_inside_the_standoff_is_refused() -> None:
    with pytest.raises(MissionError, match="closer than the standoff"):
        plan((10.0, 0.0), (0.0, 0.5, 0.9))
