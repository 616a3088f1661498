"""Guidance building blocks: geodesy, ILOS/ALOS crabbing into current, circling, station keeping."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from companion.guidance.circle import CircleTracker
from companion.guidance.geo import (
    Coordinate,
    LocalFrame,
    distance_bearing,
    distance_m,
    distance_to_segment_m,
    lat_lon_problem,
    valid_lat_lon,
    wrap_pi,
)
from companion.guidance.los import LosFollower, LosGains, LosType, leg_errors, lookahead
from companion.guidance.station import StationKeeper
from companion.guidance.waypoints import LegConfig, LegNavigator


def test_one_degree_of_latitude_is_the_wgs84_meridian_arc() -> None:
    # length of 1 degree of latitude at the equator: 110.574 km; at 60 deg: 111.412 km (WGS-84)
    assert LocalFrame(0.0, 0.0).to_ne(1.0, 0.0)[0] == pytest.approx(110574, rel=2e-3)
    assert LocalFrame(60.0, 10.0).to_ne(61.0, 10.0)[0] == pytest.approx(111412, rel=2e-3)
    # 1 degree of longitude at 60 deg is about half that at the equator
    assert LocalFrame(60.0, 10.0).to_ne(60.0, 11.0)[1] == pytest.approx(55800, rel=5e-3)


@given(st.floats(-80, 80), st.floats(-179.9, 179.9), st.floats(-5000, 5000), st.floats(-5000, 5000))
def test_local_frame_round_trip(lat0: float, lon0: float, n: float, e: float) -> None:
    f = LocalFrame(lat0, lon0)
    lat, lon = f.to_lat_lon(n, e)
    n2, e2 = f.to_ne(lat, lon)
    assert n2 == pytest.approx(n, abs=1e-6) and e2 == pytest.approx(e, abs=1e-6)


def test_invalid_coordinates_are_refused() -> None:
    assert not valid_lat_lon(float("nan"), 0.0)
    assert not valid_lat_lon(91.0, 0.0)
    assert not valid_lat_lon(0.0, 181.0)
    with pytest.raises(ValueError):
        LocalFrame(float("nan"), 0.0)


def test_leg_errors_sign_convention() -> None:
    # leg due north; a boat east of it is right of the path: positive cross-track error
    err = leg_errors((0.0, 0.0), (100.0, 0.0), (30.0, 2.0))
    assert err.along_m == pytest.approx(30.0) and err.cross_m == pytest.approx(2.0)
    assert err.remaining_m == pytest.approx(70.0)
    assert distance_bearing(0.0, 1.0)[1] == pytest.approx(math.pi / 2)


def _run_los(los: LosFollower, current_ne: tuple[float, float], speed_mps: float = 5.0,
             duration_s: float = 120.0, give_course: bool = False) -> list[float]:
    """Kinematic boat: heading follows the commanded course with a 0.5 s lag (no crab
    compensation), velocity over ground = through-water velocity + current; ``give_course``: the
    follower gets the course over ground (its integral's course gate)."""
    los.set_leg((0.0, 0.0), (10_000.0, 0.0))
    x, y, psi, dt = 0.0, 5.0, 0.0, 0.05
    course = None
    cross = []
    for _ in range(int(duration_s / dt)):
        out = los.update((x, y), speed_mps, dt, course)
        psi += wrap_pi(out.course_rad - psi) * dt / 0.5
        vx, vy = speed_mps * math.cos(psi) + current_ne[0], speed_mps * math.sin(psi) + current_ne[1]
        x, y = x + vx * dt, y + vy * dt
        course = math.atan2(vy, vx) if give_course else None
        cross.append(out.errors.cross_m)
    return cross


@pytest.mark.parametrize("give_course", [False, True])
@pytest.mark.parametrize("los_type", [LosType.ILOS, LosType.ALOS])
def test_integral_and_adaptive_los_crab_into_cross_current(los_type: LosType, give_course: bool) -> None:
    """With the course over ground given, the integral's course gate still lets it take out the
    steady offset: that offset is flown with the course along the leg."""
    cross = _run_los(LosFollower(LosGains(lookahead_m=8.0, ki=0.05, gamma=0.01), los_type), (0.0, 0.5),
                     give_course=give_course)
    assert max(abs(c) for c in cross[-200:]) < 0.05


def test_plain_los_without_integral_drifts_off_the_line() -> None:
    cross = _run_los(LosFollower(LosGains(lookahead_m=8.0, ki=0.0), LosType.ILOS), (0.0, 0.5))
    assert abs(cross[-1]) > 0.5  # steady offset of about Delta * tan(asin(c / U))


def test_look_ahead_shrinks_off_the_line_and_is_long_on_it() -> None:
    g = LosGains(lookahead_m=9.0, lookahead_min_m=4.0, lookahead_gamma_per_m2=1.0)
    assert lookahead(g, 0.0) == pytest.approx(9.0)
    assert lookahead(g, 0.2) > 8.5  # wave-sized errors: the calm long look-ahead
    assert lookahead(g, 3.0) == pytest.approx(4.0, abs=0.01)  # after a corner: converge fast
    assert lookahead(g, -3.0) == lookahead(g, 3.0)
    # Delta_min >= Delta_max: the constant look-ahead of the plain laws
    assert lookahead(LosGains(lookahead_m=8.0, lookahead_min_m=8.0), 5.0) == pytest.approx(8.0)


def test_shorter_look_ahead_off_the_line_brings_the_boat_back_in_fewer_metres() -> None:
    def metres_to_half_a_metre(gains: LosGains) -> float:
        los = LosFollower(gains, LosType.ILOS)
        los.set_leg((0.0, 0.0), (1000.0, 0.0))
        x, y, psi, dt, u = 0.0, 2.5, 0.0, 0.02, 3.0
        while abs(y) > 0.5:
            out = los.update((x, y), u, dt)
            psi += wrap_pi(out.course_rad - psi) * dt / 0.5
            x, y = x + u * math.cos(psi) * dt, y + u * math.sin(psi) * dt
        return x

    constant = metres_to_half_a_metre(LosGains(lookahead_m=9.0, lookahead_min_m=9.0, ki=0.0))
    varying = metres_to_half_a_metre(LosGains(lookahead_m=9.0, lookahead_min_m=4.0, ki=0.0))
    assert varying < 0.7 * constant


@pytest.mark.parametrize("los_type", [LosType.ILOS, LosType.ALOS])
def test_integral_state_does_not_wind_up_before_the_leg_starts(los_type: LosType) -> None:
    """Turn anticipation switches to the next leg before the corner: the boat is then metres
    beside the new leg but before its start; that is the corner, not a current."""
    los = LosFollower(LosGains(lookahead_m=8.0, ki=0.05, gamma=0.01), los_type)
    los.set_leg((0.0, 0.0), (50.0, 0.0))
    for _ in range(200):
        los.update((-3.0, 4.0), 2.0, 0.01)
    assert los.y_int_m == 0.0 and los.beta_hat_rad == 0.0
    los.update((1.0, 4.0), 2.0, 0.01)  # on the leg: integrates again
    assert los.y_int_m != 0.0 or los.beta_hat_rad != 0.0


@pytest.mark.parametrize("los_type", [LosType.ILOS, LosType.ALOS])
def test_the_turn_onto_a_leg_winds_up_no_integral(los_type: LosType) -> None:
    """After a corner the boat is metres beside the new leg, its course still swinging round onto
    it (or back from overshooting it): that error is the turn, and an integral wound up on it held
    the boat 0.3-0.4 m off the line for 60 m of the next leg.  With the course along the leg the
    integral runs."""
    los = LosFollower(LosGains(lookahead_m=8.0, ki=0.05, gamma=0.01), los_type)
    los.set_leg((0.0, 0.0), (100.0, 0.0))
    turning = math.radians(-40.0)  # 40 deg off the leg, heading for it
    for k in range(300):
        los.update((1.0 + 0.02 * k, 4.0 - 0.01 * k), 2.0, 0.01, turning)
    assert los.y_int_m == 0.0 and los.beta_hat_rad == 0.0
    los.update((7.0, 1.0), 2.0, 0.01, math.radians(5.0))
    assert los.y_int_m != 0.0 or los.beta_hat_rad != 0.0


def test_distance_to_a_segment_including_one_of_zero_length() -> None:
    assert distance_to_segment_m((3.0, 4.0), (0.0, 0.0), (10.0, 0.0)) == pytest.approx(4.0)
    assert distance_to_segment_m((-3.0, 4.0), (0.0, 0.0), (10.0, 0.0)) == pytest.approx(5.0)
    assert distance_to_segment_m((3.0, 4.0), (1.0, 1.0), (1.0, 1.0)) == pytest.approx(math.hypot(2.0, 3.0))


def test_turn_anticipation_is_sized_for_the_speed_the_boat_actually_has() -> None:
    """A boat arriving at a right-angle corner faster than the planned corner speed turns on a
    wider circle, so it must start the turn earlier; at the planned speed it keeps the leg."""
    def reached_at(remaining_m: float, sog_mps: float) -> bool:
        nav = LegNavigator(LosFollower(LosGains()), LegConfig(speed_mps=5.0, turn_speed_mps=2.0,
                                                              turn_rate_max_radps=math.radians(45.0),
                                                              yaw_lag_s=2.5, accept_radius_m=1.0))
        nav.set_leg((0.0, 0.0), (50.0, 0.0), (50.0, 50.0))
        return nav.update((50.0 - remaining_m, 0.0), sog_mps, 0.01).reached

    # planned 2 m/s: radius 2.5 m + 2.5 m of yaw lag -> switch 5.0 m before the corner
    assert not reached_at(5.5, 2.0) and reached_at(4.5, 2.0)
    # 3.5 m/s over ground at the same place: radius 4.5 m -> switch 7.0 m before
    assert reached_at(5.5, 3.5) and reached_at(6.5, 3.5) and not reached_at(7.5, 3.5)


def test_a_waypoints_own_acceptance_radius_holds_the_turn_until_the_boat_can_pass_within_it() -> None:
    """A mission item with its own acceptance radius (MAVSDK sends one with every item) is passed
    within it: the turn anticipation, 5 m before a right angle at 2 m/s, starts later, so that
    even a boat turning at once at the full turn rate passes the corner within the radius."""
    rate_radps, speed_mps, accept_m = math.radians(45.0), 2.0, 1.5

    def reached_at(remaining_m: float, corner_cut_max_m: float | None) -> bool:
        nav = LegNavigator(LosFollower(LosGains()), LegConfig(
            speed_mps=5.0, turn_speed_mps=speed_mps, turn_rate_max_radps=rate_radps, yaw_lag_s=2.5,
            accept_radius_m=accept_m, corner_cut_max_m=corner_cut_max_m))
        nav.set_leg((0.0, 0.0), (50.0, 0.0), (50.0, 50.0))
        return nav.update((50.0 - remaining_m, 0.0), speed_mps, 0.01).reached

    def switch_m(corner_cut_max_m: float | None) -> float:
        """How far before the corner the boat, coming along the leg, goes on to the next leg."""
        return next(r for r in (10.0 - k * 0.02 for k in range(500)) if reached_at(r, corner_cut_max_m))

    assert switch_m(None) > 4.9  # WP_RADIUS: the corner is planned for the boat's turn
    lead_m = switch_m(accept_m)
    # from the switch, turn at once at the full rate toward the new leg (east) and keep turning
    radius_m = speed_mps / rate_radps
    arc = [(50.0 - lead_m + radius_m * math.sin(a), radius_m * (1.0 - math.cos(a)))
           for a in (k * math.pi / 400 for k in range(201))]
    closest_m = min(math.dist(p, (50.0, 0.0)) for p in arc)
    assert accept_m - 0.1 <= closest_m <= accept_m


def test_only_the_last_leg_of_a_route_slows_the_boat_down_to_stop() -> None:
    def stopping(next_point: tuple[float, float] | None) -> bool:
        nav = LegNavigator(LosFollower(LosGains()), LegConfig(speed_mps=5.0, turn_speed_mps=2.0))
        nav.set_leg((0.0, 0.0), (50.0, 0.0), next_point)
        return nav.update((40.0, 0.0), 4.0, 0.01).target.stopping

    assert stopping(None) and not stopping((50.0, 50.0))


def test_a_last_point_handed_over_short_of_it_is_reached_at_the_corner_speed_there() -> None:
    """A circle item is taken over 15 m out (the circle law or the hold on the circle, whose first
    leg may turn sharply): the approach is down to the corner speed there, not still braking toward
    the centre (3.4 m/s at 15 m with 0.25 m/s^2)."""
    def speed_at(remaining_m: float, arrive_short_m: float) -> float:
        nav = LegNavigator(LosFollower(LosGains()), LegConfig(speed_mps=5.0, turn_speed_mps=2.0,
                                                              arrive_short_m=arrive_short_m))
        nav.set_leg((0.0, 0.0), (100.0, 0.0))
        return nav.update((100.0 - remaining_m, 0.0), 5.0, 0.01).target.speed_mps

    assert speed_at(15.0, 0.0) > 3.3
    assert speed_at(15.0, 15.0) == pytest.approx(2.0)
    assert speed_at(40.0, 15.0) < 5.0  # it still brakes on the way (0.25 m/s^2)
    assert speed_at(100.0, 15.0) == pytest.approx(5.0)


def _run_circle(tracker: CircleTracker, start_ne: tuple[float, float], current_ne: tuple[float, float],
                speed_mps: float, duration_s: float) -> list[float]:
    x, y = start_ne
    psi, dt = 0.0, 0.02
    radial = []
    for _ in range(int(duration_s / dt)):
        out = tracker.update((x, y), speed_mps, dt)
        # ideal course keeping: the ground course follows the command with a 0.3 s lag
        psi += wrap_pi(out.course_rad - psi) * dt / 0.3
        x += (speed_mps * math.cos(psi) + current_ne[0]) * dt
        y += (speed_mps * math.sin(psi) + current_ne[1]) * dt
        radial.append(out.radial_error_m)
    return radial


def test_point_tracking_approaches_then_circles_at_the_radius() -> None:
    tracker = CircleTracker((50.0, 40.0), radius_m=3.0, clockwise=True)
    radial = _run_circle(tracker, (0.0, 0.0), (0.0, 0.0), 2.0, 90.0)
    assert radial[0] > 50.0
    assert max(abs(r) for r in radial[-1500:]) < 0.2


def test_point_tracking_in_current_keeps_the_radius() -> None:
    tracker = CircleTracker((0.0, 0.0), radius_m=3.0, clockwise=False)
    radial = _run_circle(tracker, (-20.0, 5.0), (0.3, 0.0), 2.0, 120.0)
    assert max(abs(r) for r in radial[-2500:]) < 0.6


def test_station_keeping_points_into_current_and_stays_close() -> None:
    """A jet boat that can only push forward: heading lags the command; current sets it south."""
    keeper = StationKeeper((0.0, 0.0))
    x, y, psi, u, dt = 8.0, -6.0, 0.0, 0.0, 0.05
    current = (-0.4, 0.1)
    dists = []
    for _ in range(int(300 / dt)):
        out = keeper.update((x, y), dt)
        psi += wrap_pi(out.heading_rad - psi) * dt / 1.0
        # speed over ground along the heading follows the command (surge >= -current component)
        u += (out.surge_speed_mps - u) * dt / 1.0
        x += (u * math.cos(psi)) * dt + 0.0 * current[0]
        y += (u * math.sin(psi)) * dt
        # the part of the current the boat does not stem perpendicular to its heading
        cross = -current[0] * math.sin(psi) + current[1] * math.cos(psi)
        x += -cross * math.sin(psi) * dt
        y += cross * math.cos(psi) * dt
        dists.append(out.distance_m)
    assert max(dists[-2000:]) < 1.0
    # bow into the current (current towards the south-east-ish: bow points north-west-ish)
    into = math.atan2(-current[1], -current[0])
    assert abs(wrap_pi(keeper.heading_rad - into)) < math.radians(20)


def test_distance_between_positions_is_the_local_frame_distance() -> None:
    frame = LocalFrame(41.77, 123.43)
    lat, lon = frame.to_lat_lon(30.0, -40.0)
    assert distance_m(41.77, 123.43, lat, lon) == pytest.approx(50.0, abs=0.01)
    assert distance_m(lat, lon, 41.77, 123.43) == pytest.approx(50.0, abs=0.01)
    assert distance_m(0.0, 179.99999, 0.0, -179.99999) == pytest.approx(2.2, abs=0.1)  # across the date line


def test_position_validator_names_the_wrong_coordinate() -> None:
    assert lat_lon_problem(41.77, 123.43) is None and lat_lon_problem(0.0, 0.0) is None
    lat = lat_lon_problem(float("nan"), 0.0)
    assert lat is not None and lat.coordinate is Coordinate.LATITUDE and "latitude nan" in lat.text
    lon = lat_lon_problem(45.0, -180.5)
    assert lon is not None and lon.coordinate is Coordinate.LONGITUDE and "outside [-180, 180]" in lon.text
    zero = lat_lon_problem(0.0, 0.0, zero_is_missing=True)
    assert zero is not None and "missing coordinates" in zero.text
