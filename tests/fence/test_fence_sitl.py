"""Geofence end to end in lockstep SITL (full companion) with a MAVLink ground station on UDP.

* A GUIDED target beyond the inclusion fence is refused: DO_REPOSITION DENIED, a guided
  MISSION_ITEM_INT (current = 2) answered INVALID_PARAM5_X, SET_POSITION_TARGET_GLOBAL_INT ignored,
  a mission with a waypoint outside refused at upload; each with a STATUSTEXT saying why.
* A current pushing an armed boat in HOLD (engine idle: it drifts) toward the fence edge starts the
  fence action (RTL) before the boat crosses, checked against the simulator's true position.
"""

from __future__ import annotations

import asyncio

import pytest

from companion.fence.zones import fence_from_plan
from companion.guidance.geo import LocalFrame
from companion.link.dialect import mav
from companion.messages import ModeNumber
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs
from tests.mavlink.test_params_missions import upload

pytestmark = pytest.mark.integration

HOME = (41.77, 123.43)
"""The simulator's start point (SitlHarness default)."""


def inclusion_square(frame: LocalFrame, south_m: float, north_m: float, west_m: float,
                     east_m: float) -> list[MissionItem]:
    corners = [(south_m, west_m), (south_m, east_m), (north_m, east_m), (north_m, west_m)]
    plan = []
    for seq, (n, e) in enumerate(corners):
        lat, lon = frame.to_lat_lon(n, e)
        item = MissionItem.at(seq, mi.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, lat, lon, param1=4)
        plan.append(MissionItem(**{**item.to_dict(), "mission_type": MissionType.FENCE}))
    return plan


def int_position(frame: LocalFrame, north_m: float, east_m: float) -> tuple[int, int]:
    lat, lon = frame.to_lat_lon(north_m, east_m)
    return round(lat * 1e7), round(lon * 1e7)


def guided_item(lat_int: int, lon_int: int) -> object:
    """ArduPilot's guided-mode waypoint: MISSION_ITEM_INT with current = 2 (MAVProxy's ``guided``)."""
    return mav.MAVLink_mission_item_int_message(1, 1, 0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                                mav.MAV_CMD_NAV_WAYPOINT, 2, 1, 0, 0, 0, 0, lat_int, lon_int,
                                                0, 0)


async def test_targets_and_mission_items_beyond_the_fence_are_refused() -> None:
    frame = LocalFrame(*HOME)
    async with sitl_with_gcs(params={"FENCE_ENABLE": 1}) as (h, gcs):
        await h.run_for(1.0)
        ack = await run_until_done(h, upload(gcs, inclusion_square(frame, -100, 100, -100, 100), 1))
        assert ack.type == mav.MAV_MISSION_ACCEPTED
        status = await run_until_done(h, gcs.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_present
                                                  & mav.MAV_SYS_STATUS_GEOFENCE, 5))
        assert status.onboard_control_sensors_enabled & mav.MAV_SYS_STATUS_GEOFENCE
        assert status.onboard_control_sensors_health & mav.MAV_SYS_STATUS_GEOFENCE
        fence_status = await run_until_done(h, gcs.wait("FENCE_STATUS", None, 5))
        assert fence_status.breach_status == 0 and fence_status.breach_count == 0
        assert (await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1))).result == 0
        vehicle = h.services.vehicle

        # DO_REPOSITION 300 m north: DENIED, the boat stays in HOLD
        why = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "Reposition refused" in m.text, 5))
        lat, lon = int_position(frame, 300.0, 0.0)
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_REPOSITION, -1,
                                                  mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0, lat, lon, 0,
                                                  as_int=True, frame=mav.MAV_FRAME_GLOBAL_INT))
        assert ack.result == mav.MAV_RESULT_DENIED
        assert "outside the inclusion polygon" in (await run_until_done(h, why)).text
        assert vehicle.modes.current.number == ModeNumber.HOLD and vehicle.guided_target is None

        # 50 m north is inside: accepted, GUIDED
        lat, lon = int_position(frame, 50.0, 0.0)
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_REPOSITION, -1,
                                                  mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0, lat, lon, 0,
                                                  as_int=True, frame=mav.MAV_FRAME_GLOBAL_INT))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        accepted_target = vehicle.guided_target
        assert vehicle.modes.current.number == ModeNumber.GUIDED and accepted_target is not None

        # SET_POSITION_TARGET_GLOBAL_INT 99 m east (inside, but within FENCE_MARGIN 2 m): ignored
        why = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "Position target refused" in m.text, 5))
        lat, lon = int_position(frame, 0.0, 99.0)
        gcs.send(mav.MAVLink_set_position_target_global_int_message(
            0, 1, 1, mav.MAV_FRAME_GLOBAL_INT, 0b110111111000, lat, lon, 0, 0, 0, 0, 0, 0, 0, 0, 0))
        assert "within FENCE_MARGIN" in (await run_until_done(h, why)).text
        assert vehicle.guided_target is accepted_target

        # MAVProxy's "guided" (MISSION_ITEM_INT, current = 2) beyond the fence: INVALID_PARAM5_X
        lat, lon = int_position(frame, 0.0, -250.0)
        gcs.send(guided_item(lat, lon))
        ack = await run_until_done(h, gcs.wait("MISSION_ACK", None, 5))
        assert ack.type == mav.MAV_MISSION_INVALID_PARAM5_X and vehicle.guided_target is accepted_target
        lat, lon = int_position(frame, 0.0, -50.0)  # inside: a new target
        gcs.send(guided_item(lat, lon))
        ack = await run_until_done(h, gcs.wait("MISSION_ACK", None, 5))
        assert ack.type == mav.MAV_MISSION_ACCEPTED and vehicle.guided_target is not accepted_target

        # A mission whose second waypoint is outside: refused at upload, nothing stored
        inside_lat, inside_lon = frame.to_lat_lon(30.0, 30.0)
        outside_lat, outside_lon = frame.to_lat_lon(150.0, 0.0)
        plan = [MissionItem.home(*HOME), MissionItem.waypoint(1, inside_lat, inside_lon),
                MissionItem.waypoint(2, outside_lat, outside_lon)]
        why = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "upload refused" in m.text, 10))
        ack = await run_until_done(h, upload(gcs, plan, 0))
        assert ack.type == mav.MAV_MISSION_INVALID_PARAM5_X
        assert "refused: item 2: outside the inclus" in (await run_until_done(h, why)).text  # 1st chunk
        assert vehicle.missions.count(MissionType.MISSION) == 0


async def test_current_pushing_a_holding_boat_triggers_rtl_before_it_crosses() -> None:
    """Current 0.6 m/s toward east; the inclusion fence's east edge 25 m east of the start."""
    frame = LocalFrame(*HOME)
    edge_east_m = 25.0
    params = {"FENCE_ENABLE": 1, "FENCE_ACTION": 1, "FENCE_MARGIN": 2.0, "WP_SPEED": 3.0}
    async with sitl_with_gcs(params=params, current="0.6,90") as (h, gcs):
        plan = inclusion_square(frame, -200, 200, -200, edge_east_m)
        truth_fence = fence_from_plan(plan)
        ack = await run_until_done(h, upload(gcs, plan, 1))
        assert ack.type == mav.MAV_MISSION_ACCEPTED
        assert (await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1))).result == 0
        vehicle = h.services.vehicle
        assert vehicle.modes.current.number == ModeNumber.HOLD

        def truth_clearance_m() -> float:
            s = h.plant.state
            return truth_fence.clearance_at_m(*h.boat.gpsins.lat_lon(s.north_m, s.east_m))[0]

        breach = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "Fence breach" in m.text, 120))
        closest_m = truth_clearance_m()
        while not breach.done():
            await h.run_for(0.1)
            closest_m = min(closest_m, truth_clearance_m())
            assert h.clock.now_s() < 120.0, "no fence action"
        assert "RTL" in breach.result().text and breach.result().severity == mav.MAV_SEVERITY_CRITICAL
        assert vehicle.modes.current.number == ModeNumber.RTL
        at_action_m = truth_clearance_m()
        assert 0.0 < at_action_m < 6.0  # acted near the margin, before the edge
        status = await run_until_done(h, gcs.wait("FENCE_STATUS", lambda m: m.breach_status == 1, 5))
        assert status.breach_count == 1 and status.breach_type == mav.FENCE_BREACH_BOUNDARY
        assert status.breach_time > 0

        # RTL turns the boat back against the current: it never reaches the edge
        cleared = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "breach cleared" in m.text, 60))
        while not cleared.done():
            await h.run_for(0.1)
            closest_m = min(closest_m, truth_clearance_m())
            assert h.clock.now_s() < 180.0, "breach never cleared"
        await h.run_for(10.0)
        closest_m = min(closest_m, truth_clearance_m())
        print(f"fence action at {at_action_m:.2f} m from the edge; "
              f"closest approach {closest_m:.2f} m")
        assert closest_m > 0.0, f"the boat crossed the fence ({closest_m:.2f} m)"
        status = await run_until_done(h, gcs.wait("FENCE_STATUS", lambda m: m.breach_status == 0, 5))
        assert status.breach_count == 1
