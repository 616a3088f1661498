"""The launcher's AUTO item waits for the bow within USV_LNCH_HDG_DEG of the bearing, stopped,
for the hold time, before it fires (unit test of the item; the SITL test flies it)."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

import pytest

from companion.guidance.geo import LocalFrame
from companion.mission.items import MissionItem
from companion.modes.auto_items import AutoRun, Phase
from companion.payloads.launcher.device import RopeLauncher
from companion.payloads.launcher.mission import LaunchAtItem
from companion.payloads.registry import PayloadEnv
from companion.payloads.samplelog import SampleLog
from companion.payloads.topics import PayloadOutputs
from mavlink_dialect import UsvCmd
from tests.mavlink.helpers import HOME_LAT_DEG, HOME_LON_DEG, make_ctx, make_vehicle, nav_sample

BEARING_DEG = 90.0


async def _seconds_to_fire(tmp_path: Path, heading_off_deg: float, tolerance_deg: float | None,
                           range_m: float = 0.0, drift_ne_m: tuple[float, float] = (0.0, 0.0)
                           ) -> float | None:
    ctx = make_ctx()
    if tolerance_deg is not None:
        ctx.params.set("USV_LNCH_HDG_DEG", tolerance_deg, persist=False)
    outputs = PayloadOutputs(ctx.bus, ctx.clock)
    samplelog = SampleLog(tmp_path / f"log-{heading_off_deg}-{tolerance_deg}-{range_m}.sqlite")
    env = PayloadEnv(ctx, samplelog, outputs)
    vehicle = make_vehicle(ctx)
    run = AutoRun(vehicle, {})
    frame = LocalFrame(HOME_LAT_DEG, HOME_LON_DEG)
    lat, lon = frame.to_lat_lon(20.0, 0.0)
    mission_item = MissionItem.at(1, UsvCmd.NAV_LAUNCH_AT, lat, lon, param1=BEARING_DEG, param2=2.0,
                                  param3=range_m)
    at_lat, at_lon = frame.to_lat_lon(20.0 + drift_ne_m[0], drift_ne_m[1])
    item = LaunchAtItem(run, mission_item, RopeLauncher(ctx, outputs, samplelog), env)
    heading = math.radians(BEARING_DEG + heading_off_deg)
    try:
        for k in range(100):  # 10 s at 10 Hz, stopped on the point
            nav = nav_sample(0.1 * k, lat_deg=at_lat, lon_deg=at_lon, heading_rad=heading)
            if k == 0:
                assert item.arrive(nav) is False and run.phase is Phase.ACTION
            item.hold(nav)
            if item.fire is not None:
                return nav.t_s
        return None
    finally:
        item.cancel()
        await asyncio.sleep(0)
        samplelog.close()


@pytest.mark.parametrize(("off_deg", "tolerance_deg", "fires"), [
    (5.0, None, True),     # default USV_LNCH_HDG_DEG (10 deg)
    (15.0, None, False),
    (15.0, 20.0, True),    # the parameter widens it
    (5.0, 3.0, False),     # ... or narrows it
])
async def test_fires_only_with_the_bow_within_the_parameter(tmp_path: Path, off_deg: float,
                                                            tolerance_deg: float | None, fires: bool) -> None:
    t_s = await _seconds_to_fire(tmp_path, off_deg, tolerance_deg)
    if fires:
        assert t_s is not None and 2.0 <= t_s <= 2.2  # after the item's 2 s hold
    else:
        assert t_s is None


@pytest.mark.parametrize(("off_deg", "fires"), [
    (18.4, True),   # the bow on the target 15 m east of the launch point, seen from 5 m north of it
    (0.0, False),   # on the item's bearing: 18 deg off the target, the throw would miss
])
async def test_with_a_range_the_bow_is_aimed_at_the_target_from_where_the_boat_holds(
        tmp_path: Path, off_deg: float, fires: bool) -> None:
    t_s = await _seconds_to_fire(tmp_path, off_deg, None, range_m=15.0, drift_ne_m=(5.0, 0.0))
    assert (t_s is not None) is fires
