"""Issue 7: the "fire at a point" mission item (USV_CMD_NAV_LAUNCH_AT, 31000) run by AUTO in
lockstep SITL: the boat goes to the point, turns its bow to the commanded bearing, stops,
fires (the simulator registers the launch at that bearing), then continues the mission.
"""

from __future__ import annotations

import math

import pytest

from companion.guidance.geo import LocalFrame
from companion.mission.items import MissionItem, MissionType
from companion.mission.validate import validate_plan
from companion.vehicle import MissionState
from mavlink_dialect import UsvCmd
from sim_bridge.sitl import SitlHarness

pytestmark = pytest.mark.integration

HOME = (41.77, 123.43)
LAUNCH_NE = (30.0, 10.0)
AFTER_NE = (0.0, 30.0)


@pytest.mark.parametrize(("seed", "current", "bearing_deg"), [(4, "0.2,120", 250.0), (7, "0.3,0", 90.0),
                                                             (11, "0.1,200", 10.0)])
async def test_launch_at_point_orients_to_the_bearing_stops_fires_and_continues(
        seed: int, current: str, bearing_deg: float) -> None:
    async with SitlHarness(seed=seed, current=current, full_stack=True) as h:
        await h.run_for(2.0)
        vehicle = h.services.vehicle
        frame = LocalFrame(*HOME)
        plan = [MissionItem.home(*HOME),
                MissionItem.at(1, UsvCmd.NAV_LAUNCH_AT, *frame.to_lat_lon(*LAUNCH_NE), param1=bearing_deg),
                MissionItem.waypoint(2, *frame.to_lat_lon(*AFTER_NE))]
        assert validate_plan(plan, home_first=True) is None
        vehicle.missions.replace(MissionType.MISSION, plan)
        pressure_before = h.launcher.pressure_mpa
        reached: list[int] = []
        vehicle.reached_listeners.append(reached.append)
        assert vehicle.arm() is None
        assert vehicle.set_mode(10) is None
        await h.run_until(lambda: vehicle.mission_state == MissionState.COMPLETE, 300.0)
        assert vehicle.mission_state == MissionState.COMPLETE

        assert len(h.launcher.events) == 1, "exactly one launch"
        launch = h.launcher.events[0]
        bearing_err_deg = math.degrees(abs(math.remainder(launch.bearing_rad - math.radians(bearing_deg),
                                                          2 * math.pi)))
        assert bearing_err_deg <= 10.0
        # fired near the point (a jet boat turning on the spot wanders a few metres; the throw is 150 m)
        assert math.hypot(launch.north_m - LAUNCH_NE[0], launch.east_m - LAUNCH_NE[1]) <= 10.0
        assert h.launcher.pressure_mpa < pressure_before
        # ... and the mission went on: the launch item, then the next waypoint, were reached
        assert reached[:2] == [1, 2]
