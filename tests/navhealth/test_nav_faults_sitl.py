"""Sensor faults end to end: the simulator's fault injection (sim_bridge.gpsins.SensorFaults) under
the full companion in lockstep SITL, watched by a MAVLink ground station on UDP.

GPS loss is flown on the INS dead reckoning for USV_FS_DR_S, then HOLD; a frozen solution stops
the engine at once; NaN velocities (every sample dropped by the parser) and a silent IMU give
HOLD's idle at the servos; each fault and each recovery is told by STATUSTEXT and shows in
SYS_STATUS health; the companion never stops answering.
"""

from __future__ import annotations

import asyncio

import pytest

from companion.link.dialect import mav
from companion.messages import ModeNumber
from sim_bridge.simboat import CH_IGNITION, CH_THROTTLE
from tests.mavlink.sitl_gcs import run_until_done, sitl_with_gcs

pytestmark = pytest.mark.integration

GPS = mav.MAV_SYS_STATUS_SENSOR_GPS
INS = mav.MAV_SYS_STATUS_AHRS


async def text(gcs, fragment: str, timeout_s: float = 5.0) -> object:  # type: ignore[no-untyped-def]
    return await gcs.wait("STATUSTEXT", lambda m: fragment in m.text, timeout_s)


async def go_guided_north(h, gcs) -> None:  # type: ignore[no-untyped-def]
    assert (await run_until_done(h, gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1))).result == 0
    nav = h.services.vehicle.nav()
    ack = await run_until_done(h, gcs.command(mav.MAV_CMD_DO_REPOSITION, -1,
                                              mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0,
                                              round((nav.lat_deg + 0.005) * 1e7), round(nav.lon_deg * 1e7), 0,
                                              as_int=True, frame=mav.MAV_FRAME_GLOBAL_INT))
    assert ack.result == mav.MAV_RESULT_ACCEPTED
    await h.run_for(10.0)
    assert h.plant.state.speed_mps > 2.0


async def test_gps_loss_dead_reckoning_then_hold_then_recovery() -> None:
    params = {"USV_FS_DR_S": 8.0, "USV_FS_NAV_ACT": 1, "WP_SPEED": 4.0}
    async with sitl_with_gcs(params=params) as (h, gcs):
        vehicle = h.services.vehicle
        await go_guided_north(h, gcs)
        lost = asyncio.ensure_future(text(gcs, "GPS lost: dead reckoning 8 s"))
        h.faults.gps_outage = True
        t_lost = h.clock.now_s()
        await run_until_done(h, lost)
        status = await run_until_done(h, gcs.wait("SYS_STATUS", lambda m: not m.onboard_control_sensors_health
                                                  & GPS, 5))
        assert status.onboard_control_sensors_health & INS  # the INS still works
        await h.run_for(3.0)
        assert vehicle.modes.current.number == ModeNumber.GUIDED  # still navigating on dead reckoning
        assert h.plant.state.speed_mps > 2.0

        hold = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "GPS lost 8 s: HOLD" in m.text, 15))
        await run_until_done(h, hold, max_sim_s=15.0)
        assert 8.0 <= h.clock.now_s() - t_lost <= 8.5
        assert hold.result().severity == mav.MAV_SEVERITY_CRITICAL
        assert vehicle.modes.current.number == ModeNumber.HOLD and vehicle.armed
        await h.run_for(1.0)
        assert h.boat.pulses[CH_THROTTLE] == 1100  # HOLD: throttle idle at the simulator's servo input

        back = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "GPS recovered after" in m.text, 5))
        h.faults.gps_outage = False
        await run_until_done(h, back)
        await run_until_done(h, gcs.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_health & GPS, 5))
        assert vehicle.modes.current.number == ModeNumber.HOLD  # not restored


async def test_frozen_nan_and_silent_imu_act_at_once_and_recover() -> None:
    params = {"USV_FS_NAV_ACT": 2, "WP_SPEED": 4.0}
    async with sitl_with_gcs(params=params) as (h, gcs):
        vehicle = h.services.vehicle
        await go_guided_north(h, gcs)

        # frozen solution: engine stop at once
        stop = asyncio.ensure_future(text(gcs, "GPS-INS frozen: engine stop"))
        h.faults.frozen = True
        t0 = h.clock.now_s()
        await run_until_done(h, stop)
        assert h.clock.now_s() - t0 < 1.0 and not vehicle.armed
        await run_until_done(h, gcs.wait("SYS_STATUS", lambda m: not m.onboard_control_sensors_health & INS,
                                         5))
        await h.run_for(1.0)
        assert h.boat.pulses[CH_IGNITION] == 1100 and not h.plant.state.engine_running
        back = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "GPS-INS recovered" in m.text, 5))
        h.faults.frozen = False
        await run_until_done(h, back)

        # NaN velocities: every sample dropped by the parser -> no data -> HOLD's idle
        h.ctx.params.set("USV_FS_NAV_ACT", 1, persist=False)
        await go_guided_north(h, gcs)
        errors_before = h.hardware.parser.errors
        hold = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "no GPS-INS data: HOLD" in m.text, 5))
        h.faults.nan_velocity = True
        await run_until_done(h, hold)
        await h.run_for(1.0)
        assert h.boat.pulses[CH_THROTTLE] == 1100 and vehicle.armed
        assert h.hardware.parser.errors > errors_before + 50
        heartbeat = await run_until_done(h, gcs.wait("HEARTBEAT", None, 5))  # still answering
        assert heartbeat.custom_mode == ModeNumber.HOLD
        back = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "GPS-INS recovered" in m.text, 5))
        h.faults.nan_velocity = False
        await run_until_done(h, back)

        # no IMU sentences: stale IMU
        await go_guided_north(h, gcs)
        stale = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "IMU stale: HOLD" in m.text, 5))
        h.faults.imu_silent = True
        await run_until_done(h, stale)
        assert vehicle.modes.current.number == ModeNumber.HOLD
        refused = await run_until_done(h, gcs.command(
            mav.MAV_CMD_DO_REPOSITION, -1, mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0, 417800000,
            1234300000, 0, as_int=True, frame=mav.MAV_FRAME_GLOBAL_INT))
        assert refused.result == mav.MAV_RESULT_DENIED  # no position estimate for GUIDED
        h.faults.imu_silent = False
        await run_until_done(h, gcs.wait("STATUSTEXT", lambda m: "GPS-INS recovered" in m.text, 5))
