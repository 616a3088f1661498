"""Holding a point from the current estimate (issue 14), one part at a time: the strategy picked
from the estimate, the bow-into-current keeper and the drift-compensated orbit's crab."""

from __future__ import annotations

import math

import pytest

from companion.guidance.holding import (
    CurrentStationKeeper,
    DriftOrbit,
    HoldStrategy,
    OrbitGains,
    pick_strategy,
)


@pytest.mark.parametrize(("current", "confidence", "expected"), [
    (None, 0.0, HoldStrategy.LEGACY),
    ((0.0, 1.2), 1.0, HoldStrategy.STATION),       # flood: stem it
    ((0.5, 0.0), 1.0, HoldStrategy.ORBIT),         # weaker than the 0.7 m/s idle creep
    ((0.0, 0.9), 0.2, HoldStrategy.ORBIT),         # does not stand out of its uncertainty
    ((0.0, 0.0), 0.0, HoldStrategy.ORBIT),         # slack water
])
def test_strategy_is_picked_from_the_estimate(current: tuple[float, float] | None, confidence: float,
                                              expected: HoldStrategy) -> None:
    assert pick_strategy(current, confidence, creep_mps=0.7) == expected


def test_station_keeper_stems_the_current_at_once_and_backs_down_onto_the_point() -> None:
    """1.2 m/s toward east: the bow points west (upstream) from the first step, even 3 m upstream
    of the point (where the boat must drift back: surge over ground negative), and never turns
    more than 70 degrees off upstream however the error lies."""
    keeper = CurrentStationKeeper((0.0, 0.0), heading_rad=0.0)
    out = keeper.update((0.0, -3.0), (0.0, 1.2), 0.01)
    assert math.degrees(out.heading_rad) == pytest.approx(270.0, abs=1.0)
    assert out.surge_speed_mps == pytest.approx(-0.75, abs=0.01) and out.distance_m == pytest.approx(3.0)
    for pos in [(10.0, 0.0), (-10.0, 0.0), (0.0, 10.0), (3.0, 3.0)]:
        out = keeper.update(pos, (0.0, 1.2), 0.01)
        assert abs((math.degrees(out.heading_rad) - 270.0 + 180.0) % 360.0 - 180.0) <= 70.0 + 1e-9


@pytest.mark.parametrize("current", [(0.0, 0.0), (0.5, 0.0), (0.0, -0.5), (0.3, 0.4)])
def test_orbit_heading_makes_good_the_tangent_through_the_current(current: tuple[float, float]) -> None:
    """On the circle, water velocity along the commanded heading plus the current is a ground
    velocity along the clockwise tangent, at every bearing (the wind triangle of the module)."""
    orbit = DriftOrbit((0.0, 0.0), 2.0, clockwise=True, gains=OrbitGains(ki_per_s=0.0))
    u_w = orbit.water_speed_mps(current)
    for k in range(12):
        phi = 2.0 * math.pi * k / 12
        pos = (2.0 * math.cos(phi), 2.0 * math.sin(phi))
        out = orbit.update(pos, current, 0.01, heading_rad=0.0)
        vg = (u_w * math.cos(out.heading_rad) + current[0], u_w * math.sin(out.heading_rad) + current[1])
        tangent = (-math.sin(phi), math.cos(phi))  # clockwise seen from above, north-east axes
        assert vg[0] * tangent[1] - vg[1] * tangent[0] == pytest.approx(0.0, abs=1e-9)
        assert vg[0] * tangent[0] + vg[1] * tangent[1] > 0.0
        # the surge over ground asked of the speed loop is the water speed plus the current along the bow
        along = current[0] * math.cos(out.heading_rad) + current[1] * math.sin(out.heading_rad)
        assert out.surge_speed_mps == pytest.approx(u_w + along)
        assert out.radial_error_m == pytest.approx(0.0, abs=1e-12) and out.turn_rate_radps > 0.0


def test_orbit_water_speed_rises_with_the_current_so_the_crab_stays_steerable() -> None:
    orbit = DriftOrbit((0.0, 0.0), 2.0, gains=OrbitGains(water_speed_mps=1.0, water_speed_margin_mps=0.2))
    assert orbit.water_speed_mps((0.0, 0.3)) == pytest.approx(1.0)
    assert orbit.water_speed_mps((0.0, 0.8)) == pytest.approx(0.8 / 0.8 + 0.2)


def test_orbit_entered_at_its_centre_keeps_the_boats_heading_until_half_the_radius() -> None:
    orbit = DriftOrbit((0.0, 0.0), 2.0)
    first = orbit.update((0.1, -0.05), (0.3, 0.0), 0.01, heading_rad=1.0)
    again = orbit.update((-0.2, 0.3), (0.3, 0.0), 0.01, heading_rad=2.5)  # GPS noise moved the bearing
    assert first.heading_rad == pytest.approx(1.0) and again.heading_rad == pytest.approx(1.0)
    with pytest.raises(ValueError, match="radius"):
        DriftOrbit((0.0, 0.0), 0.0)
