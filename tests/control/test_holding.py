"""Holding a point from the current estimate (issue 14), one part at a time: the strategy picked
from the estimate, the bow-into-current keeper and the drift-compensated orbit's crab."""

from __future__ import annotations

import math

import pytest

from companion.guidance.holding import (
    CurrentStationGains,
    CurrentStationKeeper,
    DriftOrbit,
    HoldStrategy,
    OrbitGains,
    clamped_surge_cap_mps,
    going_round_clockwise,
    orbit_clockwise,
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


def test_keeper_upstream_of_its_point_keeps_its_bow_on_one_side_of_upstream() -> None:
    """Straight upstream of its point in 0.8 m/s, the keeper wants to go downstream: the bow is
    clamped 70 deg off upstream, on the side it is already on, however the position jitters
    across the line (the side picked by the sign of a near-180 deg angle flipped with every wave;
    each flip a powered turn that took the boat upstream, 170 m in 700 s)."""
    current = (0.0, 0.8)  # toward east: upstream is west (270 deg)
    for start_deg, side in ((200.0, -1.0), (340.0, 1.0)):
        keeper = CurrentStationKeeper((0.0, 0.0), math.radians(start_deg), CurrentStationGains(ki_per_s2=0.0))
        for k in range(200):
            jitter_m = 0.3 if k % 2 else -0.3  # across the line through the point along the current
            out = keeper.update((jitter_m, -20.0), current, 0.1)
            off = math.degrees(math.remainder(out.heading_rad - math.radians(270.0), 2 * math.pi))
            assert off == pytest.approx(side * 70.0), (start_deg, k)


@pytest.mark.parametrize("off_deg", [-70.0, -40.0, 20.0, 70.0])
@pytest.mark.parametrize("along_mps", [-0.4, -0.1, 0.2])
def test_clamped_surge_cap_makes_good_the_desired_speed_along_the_current(off_deg: float,
                                                                          along_mps: float) -> None:
    current = (0.0, 0.5)  # toward east: upstream is west (270 deg)
    heading = math.radians(270.0 + off_deg)
    u = clamped_surge_cap_mps(heading, (0.3, -along_mps), current)  # v_g: 0.3 north, along_mps west
    water_mps = u - (current[0] * math.cos(heading) + current[1] * math.sin(heading))
    made_good_west = -(water_mps * math.sin(heading) + current[1])
    assert made_good_west == pytest.approx(along_mps)


def test_keeper_upstream_of_its_point_caps_its_surge_to_come_down_instead_of_ferrying_across() -> None:
    """2.5 m upstream and 4 m across from its point in 0.5 m/s the desired water velocity points
    downstream, past the 70 deg clamp: the projection of v_g on the clamped heading asks for speed
    (whose upstream component would cancel the current), the cap for none (idle: the bow 70 deg off
    upstream makes way downstream).  Not clamped (downstream of the point), no cap."""
    current = (-0.5, 0.0)  # toward south
    keeper = CurrentStationKeeper((0.0, 0.0), 0.0, CurrentStationGains(ki_per_s2=0.0))
    out = keeper.update((2.5, 4.0), current, 0.1)  # upstream, and east of the point
    assert math.degrees(abs(math.remainder(out.heading_rad, 2 * math.pi))) == pytest.approx(70.0)
    assert out.surge_cap_mps <= 0.0 < out.surge_speed_mps
    assert keeper.update((-2.5, 1.0), current, 0.1).surge_cap_mps == math.inf


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


def test_orbit_entered_at_its_centre_turns_at_once_the_orbits_way_until_the_bow_joins_it() -> None:
    """LOITER starts on its point: the boat turns the orbit's way at once (the bow led by 90 deg,
    whatever GPS noise says the bearing from the point is), then the vector field takes over."""
    for clockwise, sign in ((True, 1.0), (False, -1.0)):
        orbit = DriftOrbit((0.0, 0.0), 2.0, clockwise=clockwise)
        first = orbit.update((0.1, -0.05), (0.3, 0.0), 0.01, heading_rad=1.0)
        again = orbit.update((-0.2, 0.3), (0.3, 0.0), 0.01, heading_rad=1.1)  # noise moved the bearing
        for out, heading in ((first, 1.0), (again, 1.1)):
            lead = math.remainder(out.heading_rad - heading, 2 * math.pi)
            assert lead == pytest.approx(sign * math.pi / 2)
        assert sign * first.turn_rate_radps > 0.0
    # 1.5 m east of the point the orbit's heading is 159 deg: a bow at 150 deg (turning clockwise
    # onto it) joins, and the field steers from there on (it does not go back to the entry turn)
    orbit = DriftOrbit((0.0, 0.0), 2.0, clockwise=True)
    orbit.update((0.0, 0.0), (0.0, 0.0), 0.01, heading_rad=0.0)
    joined = orbit.update((0.0, 1.5), (0.0, 0.0), 0.01, heading_rad=math.radians(150.0))
    assert math.degrees(joined.heading_rad) == pytest.approx(_orbit_heading_deg(clockwise=True), abs=0.1)
    later = orbit.update((0.0, 0.2), (0.0, 0.0), 0.01, heading_rad=math.pi)
    assert abs(math.remainder(later.heading_rad - 1.5 * math.pi, 2 * math.pi)) > 0.1
    with pytest.raises(ValueError, match="radius"):
        DriftOrbit((0.0, 0.0), 0.0)


def _orbit_heading_deg(clockwise: bool) -> float:
    """The heading of a 2 m orbit 1.5 m east (counter-clockwise: west) of its point, 0.5 m inside
    the circle: the tangent turned atan(k |e_r| / R) outward, onto the circle (159 / 201 deg)."""
    sign = 1.0 if clockwise else -1.0
    return 180.0 - sign * math.degrees(math.atan(OrbitGains().k_orbit * 0.5 / 2.0))


@pytest.mark.parametrize("clockwise", [True, False])
def test_orbit_entry_turn_goes_on_when_the_bow_has_turned_past_the_orbits_heading(clockwise: bool) -> None:
    """A bow already turned past the orbit's heading (LOITER entered while the boat circles) would
    have to reverse its turn to join the field; it keeps turning the orbit's way instead."""
    sign = 1.0 if clockwise else -1.0
    orbit = DriftOrbit((0.0, 0.0), 2.0, clockwise=clockwise)
    orbit.update((0.0, 0.0), (0.0, 0.0), 0.01, heading_rad=0.0)
    field_deg = _orbit_heading_deg(clockwise)
    past = math.radians(field_deg + sign * 20.0)  # 20 deg past it, within entry_join_rad
    out = orbit.update((0.0, sign * 1.5), (0.0, 0.0), 0.01, heading_rad=past)
    assert math.remainder(out.heading_rad - past, 2 * math.pi) == pytest.approx(sign * math.pi / 2)


def test_orbit_entry_turn_ends_after_three_quarters_of_a_turn_inside_the_circle() -> None:
    """A turn that stays inside the circle would loop through the point and out the other side."""
    orbit = DriftOrbit((0.0, 0.0), 2.0, clockwise=True)
    heading = 0.0
    out = orbit.update((0.0, 0.0), (0.0, 0.0), 0.01, heading_rad=heading)
    for _ in range(30):  # 300 deg in 10 deg steps, staying 0.6 m from the point
        heading += math.radians(10.0)
        pos = (0.6 * math.cos(heading - math.pi / 2), 0.6 * math.sin(heading - math.pi / 2))
        out = orbit.update(pos, (0.0, 0.0), 0.01, heading_rad=heading)
    assert abs(math.remainder(out.heading_rad - (heading + math.pi / 2), 2 * math.pi)) > 0.1


def test_orbit_entry_turn_goes_on_past_the_circle_until_the_bow_joins_and_not_from_outside() -> None:
    orbit = DriftOrbit((0.0, 0.0), 2.0, clockwise=True)
    orbit.update((0.0, 0.0), (0.0, 0.0), 0.01, heading_rad=0.0)
    # 3 m north of the point still heading north (fast entry): keep turning to starboard
    out = orbit.update((3.0, 0.0), (0.0, 0.0), 0.01, heading_rad=0.1)
    assert math.remainder(out.heading_rad - 0.1, 2 * math.pi) == pytest.approx(math.pi / 2)
    # a GUIDED hand-over 3 m out: the field at once (toward the circle, not a lead on the bow)
    outside = DriftOrbit((0.0, 0.0), 2.0, clockwise=True)
    out = outside.update((3.0, 0.0), (0.0, 0.0), 0.01, heading_rad=0.1)
    assert math.remainder(out.heading_rad - 0.1, 2 * math.pi) != pytest.approx(math.pi / 2)
    assert math.cos(out.heading_rad - math.pi) > 0.0  # southward, back toward the circle


@pytest.mark.parametrize(("heading_deg", "current", "clockwise"), [
    (90.0, (-0.5, 0.0), False),  # heading east, current toward south: turn left, centre upstream (north)
    (90.0, (0.5, 0.0), True),    # current toward north: turn right, centre south (upstream)
    (0.0, (0.0, -0.4), True),    # heading north, current toward west: upstream is east, to starboard
])
def test_orbit_direction_puts_the_entry_turn_upstream_in_a_current(
        heading_deg: float, current: tuple[float, float], clockwise: bool) -> None:
    """A boat running straight (or turning slower than KEEP_TURN_RADPS) either way."""
    for yaw_rate_radps in (0.0, 0.1, -0.1):
        assert orbit_clockwise(math.radians(heading_deg), yaw_rate_radps, current) is clockwise


@pytest.mark.parametrize("yaw_rate_radps", [0.2, -0.2, 0.9, -0.9])
def test_orbit_direction_of_a_boat_already_turning_is_its_turn_in_any_current(yaw_rate_radps: float) -> None:
    """LOITER entered from GUIDED's orbit: the boat keeps turning its way whichever side is upstream
    (reversing the turn ran it 8-12 m downstream on usv bench nav's grid, docs/tuning.md)."""
    for current in ((0.5, 0.0), (-0.5, 0.0), (0.0, 0.8), (0.05, 0.0)):
        assert orbit_clockwise(math.radians(90.0), yaw_rate_radps, current) is (yaw_rate_radps > 0.0)


def test_orbit_direction_in_slack_water_is_the_way_the_boat_already_turns() -> None:
    assert orbit_clockwise(1.0, 0.05, (0.05, 0.0)) is True
    assert orbit_clockwise(1.0, -0.05, (0.05, 0.0)) is False


@pytest.mark.parametrize(("offset_ne", "velocity_ne", "clockwise"), [
    ((-5.0, 0.0), (0.0, -1.0), True),    # south of the centre heading west: round it clockwise
    ((-5.0, 0.0), (0.0, 1.0), False),    # heading east: counter-clockwise
    ((0.0, 4.0), (-1.0, 0.3), True),     # east of it heading (mostly) south
    ((-5.0, 0.0), (-1.6, -0.5), None),   # running away from it faster than round it
    ((-5.0, 0.0), (0.4, 0.2), None),     # round it at 0.2 m/s: too slow to say
    ((-1.0, 0.0), (0.0, -1.5), None),    # inside the 2 m circle: the entry rules decide
])
def test_an_orbit_taken_up_off_its_circle_goes_round_the_way_the_boat_goes(
        offset_ne: tuple[float, float], velocity_ne: tuple[float, float], clockwise: bool | None) -> None:
    assert going_round_clockwise(offset_ne, velocity_ne, 2.0) is clockwise
