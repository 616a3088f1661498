"""MAVSDK-Python 4 against a ``usv sitl`` process (with a current): the geofence as a MAVSDK user meets it.

The Geofence plugin uploads a U-shaped inclusion polygon (arms to the north, the boat in its base);
then, with FENCE_ENABLE = 1:

* Action.goto_location beyond the fence: COMMAND_DENIED, STATUSTEXT "Reposition refused: outside
  the inclusion polygon ...";
* goto_location to a point inside whose straight way cuts across the notch: denied too;
* Mission.upload_mission whose last leg goes from one arm to the other through the notch: refused
  (MissionError), STATUSTEXT "Mission upload refused: leg 2-4: leaves the inclusion polygon" (item
  numbers on the wire: MAVSDK adds a DO_CHANGE_SPEED after each waypoint); the same mission
  without that leg is accepted.

``usv sitl`` runs as its own process in real time (MAVSDK's timeouts follow the wall clock).
"""

from __future__ import annotations

import asyncio
import re
from pathlib import Path

import pytest

from companion.guidance.geo import LocalFrame
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config
from tests.mavlink.test_mavsdk_sitl import connect, wait_until

pytestmark = [pytest.mark.integration]

U_SHAPE_NE = [(-50, -60), (-50, 60), (100, 60), (100, 20), (20, 20), (20, -20), (100, -20), (100, -60)]
"""The inclusion polygon (north, east m from the boat's start): the base north -50..20, the arms
east -60..-20 and 20..60 up to north 100; the notch between the arms is outside."""


async def test_mavsdk_geofence_goto_and_mission_through_the_fence_refused(tmp_path: Path,
                                                                          usv_env: dict[str, str]) -> None:
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.geofence import GeofenceAsync
    from mavsdk.asyncio.plugins.mission import MissionAsync
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.action import ActionError, ActionResult
    from mavsdk.plugins.geofence import FenceType, GeofenceData, Point, Polygon
    from mavsdk.plugins.mission import MissionError, MissionItem, MissionPlan

    port = free_port()
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [port])
    with sitl(cfg, usv_env, extra_args=["--current", "0.3,90"]):
        mav, system = await connect(port)
        tel, action = TelemetryAsync(system), ActionAsync(system)
        mission, param, geofence = MissionAsync(system), ParamAsync(system), GeofenceAsync(system)
        texts: list[str] = []

        async def collect() -> None:
            async for status in tel.subscribe_status_text():
                texts.append(status.text)

        collector = asyncio.ensure_future(collect())

        async def told(needle: str) -> str:
            for _ in range(100):
                if found := [t for t in texts if needle in t]:
                    return found[-1]
                await asyncio.sleep(0.1)
            raise AssertionError(f"no STATUSTEXT with {needle!r} in {texts}")

        start = await wait_until(tel.subscribe_position, lambda p: abs(p.latitude_deg) > 1.0, 30)
        frame = LocalFrame(start.latitude_deg, start.longitude_deg)

        def point(north_m: float, east_m: float) -> tuple[float, float]:
            return frame.to_lat_lon(north_m, east_m)

        await param.set_param_int("FENCE_ENABLE", 1)
        polygon = Polygon([Point(*point(n, e)) for n, e in U_SHAPE_NE], FenceType.INCLUSION)
        await geofence.upload_geofence(GeofenceData([polygon], []))

        with pytest.raises(ActionError) as denied:
            await action.goto_location(*point(0.0, 150.0), float("nan"), float("nan"))
        assert denied.value.result == ActionResult.COMMAND_DENIED
        assert "outside the inclusion polygon" in await told("Reposition refused: outside")

        with pytest.raises(ActionError):  # the left arm, but the straight way crosses the notch
            await action.goto_location(*point(60.0, -40.0), float("nan"), float("nan"))
        await told("Reposition refused: the way there leaves")


        def waypoint(north_m: float, east_m: float) -> MissionItem:
            lat, lon = point(north_m, east_m)
            return MissionItem(lat, lon, 0.0, 3.0, True, float("nan"), float("nan"), None, float("nan"),
                               float("nan"), 3.0, float("nan"), float("nan"), None)

        with pytest.raises(MissionError):  # base, left arm, right arm: leg 2-3 crosses the notch
            await mission.upload_mission(MissionPlan([waypoint(0, -40), waypoint(60, -40), waypoint(60, 40)]))
        refusal = await told("Mission upload refused: leg ")  # MAVSDK numbers its items its own way
        assert re.fullmatch(r"Mission upload refused: leg \d-\d: leaves the inclusion polygon", refusal)
        await mission.upload_mission(MissionPlan([waypoint(0, -40), waypoint(60, -40)]))
        await told("Mission received: ")
        collector.cancel()
        mav.destroy()
