"""The ferry glide of a station keeper whose idling jet outruns the current (issue 14,
:mod:`companion.guidance.ferry`)."""

from __future__ import annotations

import math

import pytest

from companion.guidance.ferry import FERRY_MARGIN_MPS, FERRY_MAX_RAD, IdleDrift, IdleWater, ferry_heading
from companion.guidance.geo import LocalFrame
from companion.messages import NavState
from companion.modes.stem_hold import StemHold
from companion.param_table import all_param_defs
from companion.params import ParamStore

UPSTREAM = math.radians(270.0)
"""A current toward east: upstream is west."""
KP = 0.25


def _off_deg(heading: float | None) -> float:
    assert heading is not None
    return math.degrees(math.remainder(heading - UPSTREAM, 2 * math.pi))


def test_a_keeper_that_wants_more_than_the_idle_speed_keeps_its_own_heading() -> None:
    w_west = (0.0, -1.0)
    assert ferry_heading(UPSTREAM, w_west, 0.0, IdleDrift(1.05, (0.0, 0.0)), KP) is None  # within the margin
    assert ferry_heading(UPSTREAM, (0.0, 0.5), 0.0, IdleDrift(1.2, (0.0, 0.0)), KP) is None  # downstream


@pytest.mark.parametrize(("w_up_mps", "idle_mps"), [(1.0, 1.2), (0.95, 1.15), (0.6, 1.2)])
def test_the_bow_is_set_off_upstream_so_the_idling_boat_makes_good_what_the_keeper_wants(
        w_up_mps: float, idle_mps: float) -> None:
    """Upstream component of the idling boat's water velocity: the keeper's wish plus the margin,
    up to the largest ferry angle."""
    drift = IdleDrift(idle_mps, (0.0, 0.0))
    heading = ferry_heading(UPSTREAM, (0.0, -w_up_mps), math.radians(5.0), drift, KP)
    off = math.radians(abs(_off_deg(heading)))
    expected = min(math.acos((w_up_mps + FERRY_MARGIN_MPS) / idle_mps), FERRY_MAX_RAD)
    assert off == pytest.approx(expected)
    assert 0.0 < off <= FERRY_MAX_RAD


def test_the_side_follows_the_keeper_across_the_current_and_else_stays_the_bows() -> None:
    """North of the line through the point the keeper wants to go south; near it (within the
    side's dead band) the bow stays on its side; a boat already crossing fast toward the line
    turns to the other side before it gets there (the lead)."""
    still = IdleDrift(1.2, (0.0, 0.0))
    # heading 270 - off points south-west (bow counter-clockwise of upstream): off < 0
    assert _off_deg(ferry_heading(UPSTREAM, (-0.3, -1.0), 0.0, still, KP)) < 0.0
    assert _off_deg(ferry_heading(UPSTREAM, (0.3, -1.0), 0.0, still, KP)) > 0.0
    for bow_deg in (-10.0, 10.0):
        out = ferry_heading(UPSTREAM, (0.02, -1.0), math.radians(bow_deg), still, KP)
        assert math.copysign(1.0, _off_deg(out)) == math.copysign(1.0, bow_deg)
    crossing_south = IdleDrift(1.2, (-0.4, 0.0))  # 1 m north of the line, coming south at 0.4 m/s
    assert _off_deg(ferry_heading(UPSTREAM, (-KP * 1.0, -1.0), 0.0, crossing_south, KP)) > 0.0


def test_a_keeper_started_under_power_takes_the_idle_speed_from_its_first_idling_sample() -> None:
    """A keeper that starts while the jet pushes (LOITER entered during GUIDED's powered turn)
    knows the wind-driven idle speed at the first idling sample, not seconds later: the ferry
    glide then sets the bow off at once, before the boat creeps up its current.  Later samples
    are low-passed, and a first sample slower than the creep does not lower it."""
    current = (0.0, 1.2)  # toward east
    water = IdleWater(0.7)
    assert water.update(False, (0.0, 0.5), current, 0.01) is None  # pushing: no ferry input
    assert water.speed_mps == 0.7
    first = water.update(True, (0.0, -0.3), current, 0.01)  # 1.5 m/s west through the water
    assert first is not None and first.idle_water_mps == pytest.approx(1.5)
    later = water.update(True, (0.0, 0.2), current, 0.01)  # 1.0 m/s through the water
    assert later is not None and 1.0 < later.idle_water_mps < 1.5
    assert later.idle_water_mps == pytest.approx(1.5 - 0.5 * 0.01 / 2.0)
    slow = IdleWater(0.7).update(True, (0.0, 0.8), current, 0.01)  # 0.4 m/s through the water
    assert slow is not None and slow.idle_water_mps == 0.7


def _stem_hold_heading_off_deg(current_mps: float, up_mps: float, idling: bool | None) -> float:
    """The heading a sampling circle's hold above the idle creep asks, off upstream, for a boat
    1 m up the current (toward east) from its hold point, bow upstream, going up at ``up_mps``
    over ground (``idling``: what the jet says; ``None``: the hold is not told)."""
    params = ParamStore(all_param_defs())
    current = (0.0, current_mps)
    hold = StemHold(params, 2.0, current, (0.0, -6.0), UPSTREAM,
                    idling=None if idling is None else (lambda: idling))
    assert not hold.below_creep
    hold.holding = True  # on the keeper (the legs to the abeam point flown)
    frame = LocalFrame(41.77, 123.43)
    here = (hold.hold_ne[0], hold.hold_ne[1] - 1.0)
    lat, lon = frame.to_lat_lon(*here)
    going_up = NavState(t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=0.0, heading_rad=UPSTREAM, roll_rad=0.0,
                        pitch_rad=0.0, vel_north_mps=0.0, vel_east_mps=-up_mps, u_mps=up_mps, v_mps=0.0,
                        r_radps=0.0)
    target = hold.step(here, going_up, 0.01)
    assert target.is_heading
    return _off_deg(target.course_rad)


def test_a_sampling_circles_hold_ferry_glides_where_the_ferry_can_stand_it_on_its_point() -> None:
    """The hold on a sampling circle in 1.2 m/s, its idling boat making 1.3 m/s through the water
    (wind from astern) and a metre up the current from its point: the bow is set off upstream by
    the ferry angle, as LOITER's keeper does, so the boat stops creeping up; not told the jet
    idles, or with the jet pushing, the bow stays straight upstream.  In 0.8 m/s with the idling
    boat making 1.25 m/s through the water no angle up to the largest stands it on its point, and
    the bow stays straight upstream too: ferrying there only swept the boat across the current
    (``docs/tuning.md``)."""
    assert abs(_stem_hold_heading_off_deg(1.2, 0.1, True)) == pytest.approx(math.degrees(FERRY_MAX_RAD))
    assert _stem_hold_heading_off_deg(1.2, 0.1, False) == pytest.approx(0.0, abs=1.0)
    assert _stem_hold_heading_off_deg(1.2, 0.1, None) == pytest.approx(0.0, abs=1.0)
    assert _stem_hold_heading_off_deg(0.8, 0.45, True) == pytest.approx(0.0, abs=1.0)
