"""MAVSDK-Python 4 (native library) flies the SITL boat: the issue's "done when" sequence.

connect, all health flags, arm, hold, go-to, 20-waypoint mission to the finish, RTL,
disarm, parameter round trip surviving a restart, and a boat-dialect command through
``mavlink_direct`` acknowledged.  Runs ``usv sitl`` as a subprocess at ``--speedup``
:data:`SPEEDUP`: MAVSDK's timeouts follow the wall clock, and since issue 15 the vehicle judges
the ground station's heartbeats by wall time too, so only the boat's motion is faster than real
time (every wait below is a wall-clock upper bound, generous at this speedup).
"""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import pytest

from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = [pytest.mark.integration, pytest.mark.slow]

HOME = (41.77, 123.43)
SPEEDUP = 5.0
"""Simulated seconds per wall second (the flight is not what is timed here)."""


def offset(lat: float, lon: float, north_m: float, east_m: float) -> tuple[float, float]:
    return lat + north_m / 111_320.0, lon + east_m / (111_320.0 * math.cos(math.radians(lat)))


async def wait_until(agen_factory, cond, timeout_s: float):
    async def run():
        async for value in agen_factory():
            if cond(value):
                return value
        raise AssertionError("stream ended")

    return await asyncio.wait_for(run(), timeout_s)


async def connect(port: int):
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

    mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    await mav.add_any_connection(f"udpin://127.0.0.1:{port}")
    system = await mav.first_autopilot(20)
    assert system is not None, "no autopilot discovered"
    return mav, system


async def test_mavsdk_full_sequence(tmp_path: Path, usv_env: dict[str, str]) -> None:
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mavlink_direct import MavlinkDirectAsync
    from mavsdk.asyncio.plugins.mission import MissionAsync
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.mavlink_direct import MavlinkMessage
    from mavsdk.plugins.mission import MissionItem, MissionPlan
    from mavsdk.plugins.telemetry import FlightMode

    import mavlink_dialect

    port = free_port()
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [port])
    with sitl(cfg, usv_env, speedup=SPEEDUP):
        mav, system = await connect(port)
        tel, action = TelemetryAsync(system), ActionAsync(system)
        mission, param = MissionAsync(system), ParamAsync(system)
        health = await wait_until(tel.subscribe_health, lambda h: h.is_global_position_ok
                                  and h.is_home_position_ok and h.is_armable, 30)
        assert health.is_gyrometer_calibration_ok and health.is_accelerometer_calibration_ok
        assert health.is_magnetometer_calibration_ok and health.is_local_position_ok

        await action.arm()
        await wait_until(tel.subscribe_armed, bool, 10)
        await action.hold()
        await wait_until(tel.subscribe_flight_mode, lambda m: m == FlightMode.HOLD, 10)

        await param.set_param_float("WP_RADIUS", 3.0)
        assert await param.get_param_float("WP_RADIUS") == pytest.approx(3.0)
        await param.set_param_int("MIS_DONE_BEHAVE", 0)

        pos = await wait_until(tel.subscribe_position, lambda p: True, 5)
        lat, lon = offset(pos.latitude_deg, pos.longitude_deg, 25.0, 0.0)
        await action.goto_location(lat, lon, pos.absolute_altitude_m, float("nan"))

        def near(p) -> bool:
            dn = (p.latitude_deg - lat) * 111_320.0
            de = (p.longitude_deg - lon) * 111_320.0 * math.cos(math.radians(lat))
            return math.hypot(dn, de) < 5.0

        await wait_until(tel.subscribe_position, near, 40)

        start = await wait_until(tel.subscribe_position, lambda p: True, 5)
        items = []
        for i in range(20):
            north, east = offset(start.latitude_deg, start.longitude_deg, 8.0 * (i // 2 + 1),
                                 0.0 if i % 2 == 0 else 6.0)
            items.append(MissionItem(north, east, 0.0, 5.0, True, float("nan"), float("nan"),
                                     None, float("nan"), float("nan"), 3.0, float("nan"), float("nan"),
                                     None))
        await mission.upload_mission(MissionPlan(items))
        await mission.start_mission()
        await wait_until(mission.subscribe_mission_progress, lambda p: p.current >= 1, 20)
        await asyncio.wait_for(_finished(mission), 150)

        await action.return_to_launch()
        await wait_until(tel.subscribe_flight_mode, lambda m: m == FlightMode.RETURN_TO_LAUNCH, 10)
        await action.disarm()
        await wait_until(tel.subscribe_armed, lambda a: not a, 10)

        direct = MavlinkDirectAsync(system)
        await direct.load_custom_xml(mavlink_dialect.mavsdk_xml())
        cmd = {"target_system": 1, "target_component": 1, "command": int(mavlink_dialect.UsvCmd.LAUNCHER_ARM),
               "confirmation": 0, **{f"param{i}": 0.0 for i in range(1, 8)}}
        ack = await asyncio.wait_for(direct.send_command(MavlinkMessage(
            "COMMAND_LONG", 0, 0, 1, 1, json.dumps(cmd))), 15)
        fields = json.loads(ack.fields_json)
        assert fields["command"] == int(mavlink_dialect.UsvCmd.LAUNCHER_ARM)
        assert fields["result"] in (0, 2)  # acknowledged: accepted, or denied with a reason (disarmed)
        mav.destroy()

    with sitl(cfg, usv_env, speedup=SPEEDUP):
        mav, system = await connect(port)
        assert await ParamAsync(system).get_param_float("WP_RADIUS") == pytest.approx(3.0)
        mav.destroy()


async def _finished(mission) -> None:
    while not await mission.is_mission_finished():
        await asyncio.sleep(0.5)
