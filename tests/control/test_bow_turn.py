"""How the bow turns onto the station keeper's heading (issue 14): the rules LOITER, GUIDED and RTL
on their point share with the hold on a sampling circle (companion/guidance/bow_turn.py)."""

from __future__ import annotations

import math

import pytest

from companion.guidance.bow_turn import KeeperTurn, downstream_speed_mps
from companion.guidance.geo import LocalFrame, along_across_m
from companion.messages import NavState
from companion.modes.holding import CurrentStationTask
from companion.param_table import all_param_defs
from companion.params import ParamStore


def test_a_large_turn_is_powered_only_while_the_current_carries_the_boat_off() -> None:
    """Keeper wants north (0 deg), bow south: on or below the point, carried downstream, the turn
    runs at the powered speed; moving upstream (an arrival running on past its point), more than
    1 m upstream, or below the creep, at the keeper's own surge (the current brings it back)."""
    assert KeeperTurn(2.5).command(0.0, 0.0, math.pi, 0.0, 0.0, downstream_mps=0.5)[1] == 2.5
    assert KeeperTurn(2.5).command(0.0, 0.0, math.pi, 0.0, 3.0, downstream_mps=0.5)[1] == 2.5
    assert KeeperTurn(2.5).command(0.0, 0.2, math.pi, 0.0, 0.0, downstream_mps=-1.0)[1] == 0.2
    assert KeeperTurn(2.5).command(0.0, -0.4, math.pi, 0.0, -3.0, downstream_mps=0.5)[1] == -0.4
    assert KeeperTurn(None).command(0.0, 0.1, math.pi, 0.0, 0.0, downstream_mps=0.5)[1] == 0.1
    # a small correction is not powered
    assert KeeperTurn(2.5).command(0.0, 0.1, math.radians(30.0), 0.0, 0.0, downstream_mps=0.5)[1] == 0.1


def test_a_powered_turn_runs_through_the_water_under_the_making_way_controller() -> None:
    """The powered turn is USV_WP_TURN_SPD through the water: bow down a 1.2 m/s current, 3.2 m/s
    over ground (a boat running down the current at 3-4 m/s was asked 2 m/s over ground, and the
    speed loop idled the jet, which then hardly turned); bow up it, 0.8 m/s.  The turn is flagged
    for the controller of a boat making way; a small correction is not."""
    turn = KeeperTurn(2.0)
    assert turn.command(0.0, 0.0, math.pi, 0.0, 0.0, 0.5, current_along_bow_mps=1.2)[1] == pytest.approx(3.2)
    assert turn.powered
    assert turn.command(0.0, 0.0, math.pi, 0.0, 0.0, 0.5, current_along_bow_mps=-1.2)[1] == pytest.approx(0.8)
    assert turn.powered
    assert turn.command(0.0, 0.1, math.radians(30.0), 0.0, 0.0, 0.5, current_along_bow_mps=1.2)[1] == 0.1
    assert not turn.powered
    assert turn.command(0.0, 0.2, math.pi, 0.0, 0.0, -1.0, current_along_bow_mps=1.2)[1] == 0.2
    assert not turn.powered


@pytest.mark.parametrize(("yaw_rate_degps", "turn_sign"), [(-30.0, -1.0), (30.0, 1.0), (0.0, 1.0)])
def test_a_u_turn_goes_the_way_the_boat_already_turns(yaw_rate_degps: float, turn_sign: float) -> None:
    """Keeper heading 150 deg clockwise of the bow: a boat turning counter-clockwise keeps turning
    that way (the long way round) instead of reversing its turn at speed; a boat running straight
    turns the short way; either keeps its direction while the error flips sign near 180 deg."""
    turn = KeeperTurn(2.5)
    heading, _ = turn.command(math.radians(150.0), 0.0, 0.0, math.radians(yaw_rate_degps), 0.0, 0.5)
    assert turn.u_turn.sign == turn_sign
    assert math.remainder(heading, 2 * math.pi) * turn_sign > 0.0
    # 20 deg later the error is 190 deg the other way (-170 deg): the turn goes on as started
    later, _ = turn.command(math.radians(150.0 + 40.0 * turn_sign), 0.0, math.radians(-20.0 * turn_sign),
                            math.radians(yaw_rate_degps), 0.0, 0.5)
    assert math.remainder(later - math.radians(-20.0 * turn_sign), 2 * math.pi) * turn_sign > 0.0
    # near the keeper's heading the keeper steers again
    done, _ = turn.command(0.3, 0.0, 0.2, 0.0, 0.0, 0.5)
    assert done == 0.3 and turn.u_turn.sign == 0.0


def test_along_across_is_measured_on_the_current() -> None:
    assert along_across_m((3.0, 1.0), (0.0, 0.0), (0.8, 0.0)) == pytest.approx((3.0, 1.0))  # right: east
    assert along_across_m((0.0, -2.0), (0.0, 0.0), (0.0, 0.5)) == pytest.approx((-2.0, 0.0))
    assert downstream_speed_mps((1.0, -1.5), (0.0, 0.5)) == pytest.approx(-1.5)


def _nav(frame: LocalFrame, n: float, e: float, heading_deg: float, speed_mps: float) -> NavState:
    lat, lon = frame.to_lat_lon(n, e)
    h = math.radians(heading_deg)
    return NavState(t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=h, roll_rad=0.0,
                    pitch_rad=0.0, vel_north_mps=speed_mps * math.cos(h),
                    vel_east_mps=speed_mps * math.sin(h), u_mps=speed_mps, v_mps=0.0, r_radps=0.0)


def test_loiter_entered_bow_downstream_turns_into_the_current_under_power() -> None:
    """LOITER, GUIDED or RTL on their point in 0.8 m/s toward east, bow downstream at 2 m/s (LOITER
    entered from an orbit): the turn into the current runs at USV_WP_TURN_SPD (at idle the current
    swept the boat 12 m downstream of its point on usv bench nav's grid); 3 m upstream the boat
    turns at idle and the current brings it back."""
    params = ParamStore(all_param_defs())
    point = (41.77, 123.43)
    frame = LocalFrame(*point)
    upstream_rad = math.radians(270.0)  # the keeper's first heading (hold_task: bow into the current)
    task = CurrentStationTask(params, point, upstream_rad, lambda: (0.0, 0.8), (0.0, 0.8))
    on_point = task.step(_nav(frame, 0.0, 0.0, 90.0, 2.0), 0.01)
    assert on_point.speed_mps >= params.get("USV_WP_TURN_SPD") + 0.8  # through the water, bow downstream
    assert not on_point.hold_station  # steered as a boat making way
    upstream = CurrentStationTask(params, point, upstream_rad, lambda: (0.0, 0.8), (0.0, 0.8))
    upstream_target = upstream.step(_nav(frame, 0.0, -3.0, 90.0, 2.0), 0.01)
    assert upstream_target.speed_mps <= 0.0 and upstream_target.hold_station
    # running on upstream past the point (an arrival), bow 60+ deg off the keeper's heading: at idle
    overrun = CurrentStationTask(params, point, upstream_rad, lambda: (0.0, 0.8), (0.0, 0.8))
    overrun_target = overrun.step(_nav(frame, 0.0, -0.5, 190.0, 1.7), 0.01)
    assert overrun_target.speed_mps < 1.0 and overrun_target.hold_station
