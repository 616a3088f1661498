"""The ``generic`` profile: MAVLink standard modes and byte-wise parameter encoding."""

from __future__ import annotations

import asyncio
import struct
from pathlib import Path

from companion.link.dialect import mav
from tests.mavlink.gcs import AsyncGcs, free_port
from tests.mavlink.helpers import feeding_nav, running_vehicle


async def test_generic_profile_identity_standard_modes_and_bytewise_ints(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port], profile="generic") as services:
        hb = await gcs.connect()
        assert (hb.type, hb.autopilot) == (mav.MAV_TYPE_SURFACE_BOAT, mav.MAV_AUTOPILOT_GENERIC)

        async with feeding_nav(services):
            await asyncio.sleep(0.2)
            ack = await gcs.command(mav.MAV_CMD_DO_SET_STANDARD_MODE, mav.MAV_STANDARD_MODE_POSITION_HOLD)
            assert ack.result == mav.MAV_RESULT_ACCEPTED
            cur = await gcs.wait("CURRENT_MODE",
                                 lambda m: m.standard_mode == mav.MAV_STANDARD_MODE_POSITION_HOLD, 3.0)
            assert cur.custom_mode == 5  # LOITER behind the standard mode
            ack = await gcs.command(mav.MAV_CMD_DO_SET_STANDARD_MODE, mav.MAV_STANDARD_MODE_TAKEOFF)
            assert ack.result == mav.MAV_RESULT_DENIED  # a boat does not take off

        gcs.send(mav.MAVLink_param_request_read_message(1, 1, b"FRAME_CLASS", -1))
        pv = await gcs.wait("PARAM_VALUE", lambda m: m.param_id == "FRAME_CLASS")
        assert pv.param_type in (mav.MAV_PARAM_TYPE_INT32, mav.MAV_PARAM_TYPE_INT8)
        raw = struct.pack("<f", pv.param_value)
        assert int.from_bytes(raw, "little", signed=True) == 2  # the int's bytes, not 2.0
