"""GUIDED and RTL on their point in a current (:mod:`companion.modes.holding`), fast, without a plant.

The approach in a current to be stemmed (:class:`~companion.modes.holding.ApproachTask`): from
downstream the boat joins the line that runs up the current into its goal; from upstream it hands
over to the station keeper at once, which lets the current set it back onto the goal.  The
evidence that a station keeper cannot hold the point (:class:`~companion.modes.holding.CreepWatch`)."""

from __future__ import annotations

import math

from companion.guidance.geo import LocalFrame, distance_bearing
from companion.messages import NavState
from companion.modes.creep import CreepWatch
from companion.modes.holding import ApproachTask
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


class _Control:
    mapper = _Mapper()


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
