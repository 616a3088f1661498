"""Fence legs and the stored plans, end to end in lockstep SITL with a MAVLink ground station on UDP.

* A mission whose leg cuts through an exclusion zone is refused at upload (MAV_MISSION_INVALID,
  the leg named); a DO_REPOSITION whose straight way crosses it is DENIED.
* A fence uploaded after a mission that now conflicts is accepted; the mission is flagged
  (STATUSTEXT, again when FENCE_ENABLE is set to 1) and AUTO refused until a mission that goes
  round is uploaded.  A stored rally point in the new fence's rock is told; one uploaded there
  afterwards is refused (INVALID_PARAM5_X).
* Home moved outside the fence: RTL refused, and a current pushing the boat to the edge gets
  HOLD instead of RTL as the fence action, with a STATUSTEXT saying why.
"""

from __future__ import annotations

import asyncio

import pytest

from companion.guidance.geo import LocalFrame
from companion.link.dialect import mav
from companion.messages import STATUS_TEXT_TOPIC, ModeNumber
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType
from tests.fence.test_fence_sitl import HOME, inclusion_square, int_position
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs
from tests.mavlink.test_params_missions import upload

pytestmark = pytest.mark.integration

WAIT_S = 20.0
"""Wall-clock patience of the ground station's waits (the machine may be loaded)."""


def fence_plan(frame: LocalFrame) -> list[MissionItem]:
    """A 400 m square inclusion and a rock (exclusion square 40-60 m north, +-10 m east)."""
    plan = inclusion_square(frame, -200, 200, -200, 200)
    rock = [(40, -10), (40, 10), (60, 10), (60, -10)]
    for n, e in rock:
        lat, lon = frame.to_lat_lon(n, e)
        item = MissionItem.at(len(plan), mi.CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, lat, lon, param1=4)
        plan.append(MissionItem(**{**item.to_dict(), "mission_type": MissionType.FENCE}))
    return plan


def mission(frame: LocalFrame, *points_ne: tuple[float, float]) -> list[MissionItem]:
    return [MissionItem.home(*HOME)] + [MissionItem.waypoint(i + 1, *frame.to_lat_lon(n, e))
                                        for i, (n, e) in enumerate(points_ne)]


def rally(frame: LocalFrame, north_m: float, east_m: float) -> list[MissionItem]:
    item = MissionItem.at(0, mi.CMD_NAV_RALLY_POINT, *frame.to_lat_lon(north_m, east_m))
    return [MissionItem(**{**item.to_dict(), "mission_type": MissionType.RALLY})]


def text(gcs, needle: str):  # type: ignore[no-untyped-def]
    return asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: needle in m.text, WAIT_S))


async def test_legs_through_an_exclusion_zone_and_a_mission_flagged_by_a_new_fence() -> None:
    frame = LocalFrame(*HOME)
    through = mission(frame, (20, 0), (80, 0))  # leg 1-2 cuts through the rock
    around = mission(frame, (20, 30), (80, 30), (80, 0))
    async with sitl_with_gcs(params={"FENCE_ENABLE": 1}) as (h, gcs):
        await h.run_for(1.0)
        vehicle = h.services.vehicle
        texts: list[str] = []
        h.services.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: texts.append(s.text))
        # a mission stored before the fence, then the fence: accepted, the mission flagged
        ack = await run_until_done(h, upload(gcs, through, 0))
        assert ack.type == mav.MAV_MISSION_ACCEPTED
        assert (await run_until_done(h, upload(gcs, rally(frame, 50, 0), 2))).type == mav.MAV_MISSION_ACCEPTED
        flagged = text(gcs, "Fence: mission conflicts")
        rally_told = text(gcs, "Fence: rally point 0: inside the")
        ack = await run_until_done(h, upload(gcs, fence_plan(frame), 1))
        assert ack.type == mav.MAV_MISSION_ACCEPTED
        flag = (await run_until_done(h, flagged)).text
        assert flag.startswith("Fence: mission conflicts: leg 1-2: crosses the")  # first chunk
        await run_until_done(h, rally_told)
        assert "Fence: rally point 0: inside the exclusion polygon (-10 m)" in texts
        assert (await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1,
                                                    timeout_s=WAIT_S))).result == 0
        why = text(gcs, "AUTO: fence conflict: leg 1-2")
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_MISSION_START, timeout_s=WAIT_S))
        assert ack.result == mav.MAV_RESULT_DENIED
        await run_until_done(h, why)
        assert vehicle.modes.current.number == ModeNumber.HOLD
        # the fence disabled and enabled again (PARAM_SET): the conflict is told again
        for enable in (0, 1):
            gcs.send(mav.MAVLink_param_set_message(1, 1, b"FENCE_ENABLE", enable, mav.MAV_PARAM_TYPE_INT32))
            await run_until_done(h, gcs.wait("PARAM_VALUE", lambda m: m.param_id == "FENCE_ENABLE", WAIT_S))
            if enable == 0:
                flagged = text(gcs, "Fence: mission conflicts")
        await run_until_done(h, flagged)

        # a rally point in the rock uploaded now: refused
        ack = await run_until_done(h, upload(gcs, rally(frame, 45, 0), 2))
        assert ack.type == mav.MAV_MISSION_INVALID_PARAM5_X
        assert texts[-1] == "Mission upload refused: rally point 0: inside the exclusion polygon (-5 m)"

        # the same mission uploaded now: refused, the leg named, the stored one kept
        why = text(gcs, "upload refused: leg 1-2")
        ack = await run_until_done(h, upload(gcs, through, 0))
        assert ack.type == mav.MAV_MISSION_INVALID
        await run_until_done(h, why)

        # DO_REPOSITION beyond the rock (the point itself is fine): DENIED, the way there crosses it
        why = text(gcs, "Reposition refused: the way there")
        lat, lon = int_position(frame, 90.0, 0.0)
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_REPOSITION, -1,
                                                  mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0, lat, lon, 0,
                                                  as_int=True, frame=mav.MAV_FRAME_GLOBAL_INT,
                                                  timeout_s=WAIT_S))
        assert ack.result == mav.MAV_RESULT_DENIED
        await run_until_done(h, why)
        assert texts[-1] == "Reposition refused: the way there crosses the exclusion polygon"  # 2 chunks
        assert vehicle.modes.current.number == ModeNumber.HOLD

        # a mission that goes round the rock: accepted, AUTO starts
        ack = await run_until_done(h, upload(gcs, around, 0))
        assert ack.type == mav.MAV_MISSION_ACCEPTED
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_MISSION_START, timeout_s=WAIT_S))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        assert vehicle.modes.current.number == ModeNumber.AUTO


async def test_home_outside_the_fence_rtl_refused_and_the_fence_action_holds() -> None:
    """The east edge 12 m from the start, a 0.6 m/s current toward it, home moved 30 m beyond it."""
    frame = LocalFrame(*HOME)
    params = {"FENCE_ENABLE": 1, "FENCE_ACTION": 1, "FENCE_MARGIN": 2.0}
    async with sitl_with_gcs(params=params, current="0.6,90") as (h, gcs):
        ack = await run_until_done(h, upload(gcs, inclusion_square(frame, -200, 200, -200, 12), 1))
        assert ack.type == mav.MAV_MISSION_ACCEPTED
        assert (await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1,
                                                    timeout_s=WAIT_S))).result == 0
        vehicle = h.services.vehicle
        told = text(gcs, "Fence: home outside the inclusion polygon")
        lat, lon = frame.to_lat_lon(0.0, 42.0)
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, 0,
                                                  timeout_s=WAIT_S))
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await run_until_done(h, told)

        why = text(gcs, "RTL: home outside the inclusio")  # first chunk
        ack = await run_until_done(h, gcs.command(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, timeout_s=WAIT_S))
        assert ack.result == mav.MAV_RESULT_DENIED
        await run_until_done(h, why)
        assert vehicle.modes.current.number == ModeNumber.HOLD

        breach = text(gcs, "Fence breach")
        no_rtl = text(gcs, "Fence: no RTL")
        await run_until_done(h, breach, max_sim_s=60.0)
        assert breach.result().text.endswith(": HOLD")
        assert "home outside" in (await run_until_done(h, no_rtl)).text
        assert vehicle.modes.current.number == ModeNumber.HOLD and vehicle.armed
