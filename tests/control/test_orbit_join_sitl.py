"""AUTO entered on RTL's hold orbit on the full companion stack (lockstep SITL, issue 14): it keeps
the orbit until the course points along the first leg, then runs up the leg from there, instead of
swinging wide in a fast turn onto it (``USV_WP_JOIN``, ``companion/modes/orbit_join.py``)."""

from __future__ import annotations

import math

import pytest

from companion.guidance.geo import LocalFrame, distance_to_segment_m, wrap_pi
from companion.messages import STATUS_TEXT_TOPIC
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from companion.modes.auto import AutoMode
from companion.modes.auto_items import Phase
from companion.modes.holding import OrbitTask
from sim_bridge.sitl import SitlHarness

HOME = (41.77, 123.43)
LEG_END = (40.0, 0.0)
"""The first waypoint, due north of home (north, east m)."""


def _pos(h: SitlHarness) -> tuple[float, float]:
    return h.plant.state.north_m, h.plant.state.east_m


@pytest.mark.parametrize(("seed", "current", "off_deg"), [(3, "0.4,90", 180.0), (5, "0.4,0", 180.0),
                                                        (3, "0.4,90", 330.0)])
async def test_auto_from_rtls_orbit_heading_away_keeps_it_until_the_bow_points_along_the_first_leg(
        seed: int, current: str, off_deg: float) -> None:
    """0.4 m/s current (weaker than the jet's idle creep) across the northbound first leg (toward
    east) or down it (toward north): RTL orbits home.  AUTO is entered when the orbit's course over
    ground points away from the leg (a U-turn, ``off_deg`` 180) or has just passed it (30 deg past,
    330; at 20 deg past, inside the orbit's circle at 0.9-1.1 m/s where the course over ground is
    noisy by +-10 deg, it once read within the join window 0.1 s after AUTO began).  It keeps
    circling home (about half an orbit; once round when just past), then runs up the leg from
    where it left the orbit.  Measured (``USV_WP_JOIN`` 70 deg), wait on the orbit and largest
    distance from the leg's line in the next 15 s: across, U-turn 3.3 s, 1.34 m (at most 3.1 m
    from home; ``USV_WP_JOIN`` 0, the turn at once: 4.2 m, before the hold orbit's full turn
    thrust); down the leg 5.1 s, 1.14 m; across, just past 7.2 s, 1.28 m.  Joined on the course
    over ground alone, as before the join rule of 118b8c0: down the leg 4.5 s, 2.10 m (the course
    points along the leg while the bow is still across it); 20 deg past, at once, 4.45 m (the leg
    reversed the orbit's turn)."""
    async with SitlHarness(seed=seed, current=current, full_stack=True) as h:
        await h.run_for(2.0)
        vehicle = h.services.vehicle
        texts: list[str] = []
        h.services.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: texts.append(s.text))
        assert vehicle.arm() is None
        assert vehicle.set_mode(20) is None  # CRUISE away: the estimator sees the current
        vehicle.speed_override_mps = 2.0
        await h.run_for(25.0)
        assert vehicle.set_mode(11) is None
        await h.run_for(50.0)
        rtl = vehicle.modes.current
        assert isinstance(rtl.task, OrbitTask)  # type: ignore[attr-defined]
        lam = rtl.task.orbit.lam  # type: ignore[attr-defined]
        frame = LocalFrame(*HOME)
        vehicle.missions.replace(MissionType.MISSION, [
            MissionItem.home(*HOME), MissionItem.at(1, mi.CMD_NAV_WAYPOINT, *frame.to_lat_lon(*LEG_END))])
        for _ in range(300):  # wait on the orbit for the phase wanted
            await h.run_for(0.1)
            nav = vehicle.nav()
            assert nav is not None
            n, e = frame.to_ne(nav.lat_deg, nav.lon_deg)
            to_go = lam * wrap_pi(math.atan2(LEG_END[1] - e, LEG_END[0] - n) - nav.course_over_ground_rad)
            if abs(wrap_pi(to_go - math.radians(off_deg))) < math.radians(10.0):
                break
        else:
            raise AssertionError("the orbit never had the course wanted")
        assert vehicle.set_mode(10) is None
        auto = vehicle.modes.current
        assert isinstance(auto, AutoMode)
        waiting, start = [], None
        for _ in range(200):
            await h.run_for(0.1)
            if auto.phase is Phase.JOIN:
                waiting.append(math.hypot(*_pos(h)))
            elif start is None:
                start = _pos(h)
                leg: list[float] = []
            else:
                leg.append(distance_to_segment_m(_pos(h), start, LEG_END))
                if len(leg) >= 150:
                    break
        assert any(t.startswith("AUTO: orbiting until the bow points along the first leg") for t in texts)
        assert start is not None and 2.0 <= len(waiting) * 0.1 <= 13.0  # at most one orbit
        assert max(waiting) < 3.5  # kept circling home
        assert any(t.startswith("AUTO: leaving the orbit onto the first leg") for t in texts)
        assert max(leg) < 1.5  # no swing off the leg
