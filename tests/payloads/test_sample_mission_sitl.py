"""Issue 7: a mission with four "sample here" items (USV_CMD_NAV_SAMPLE_HERE, 31001) run by AUTO
in lockstep SITL fills the four simulated bottles, each sample taken within 2.5 m of its
point according to the durable sample log; a fifth sample (item and command) is refused.
"""

from __future__ import annotations

import asyncio

import pytest

from companion.guidance.geo import LocalFrame
from companion.link.dialect import mav
from companion.mavlink.commands import CommandRequest
from companion.messages import STATUS_TEXT_TOPIC
from companion.mission.items import MissionItem, MissionType
from companion.mission.validate import validate_plan
from companion.vehicle import MissionState
from mavlink_dialect import UsvCmd
from sim_bridge.sitl import SitlHarness

pytestmark = pytest.mark.integration

HOME = (41.77, 123.43)
POINTS_NE = [(25.0, 0.0), (25.0, 25.0), (0.0, 25.0), (-15.0, 10.0), (10.0, 10.0)]
VOLUME_ML = 100.0


async def test_four_sample_items_fill_four_bottles_within_2_5_m_and_a_fifth_is_refused() -> None:
    async with SitlHarness(seed=2, current="0.2,45", full_stack=True) as h:
        await h.run_for(2.0)
        vehicle = h.services.vehicle
        frame = LocalFrame(*HOME)
        plan = [MissionItem.home(*HOME)]
        plan += [MissionItem.at(i + 1, UsvCmd.NAV_SAMPLE_HERE, *frame.to_lat_lon(n, e), param4=VOLUME_ML)
                 for i, (n, e) in enumerate(POINTS_NE)]
        assert validate_plan(plan, home_first=True) is None
        vehicle.missions.replace(MissionType.MISSION, plan)
        texts: list[str] = []
        h.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: texts.append(s.text))
        reached: list[int] = []
        vehicle.reached_listeners.append(reached.append)
        assert vehicle.arm() is None
        assert vehicle.set_mode(10) is None
        await h.run_until(lambda: vehicle.mission_state == MissionState.COMPLETE, 400.0)
        assert vehicle.mission_state == MissionState.COMPLETE, (reached, texts[-10:])

        payloads = h.services.payloads
        samples = payloads.samplelog.samples("complete")
        assert [s.bottle for s in samples] == [1, 2, 3, 4]
        assert [s.mission_seq for s in samples] == [1, 2, 3, 4]
        for record, (n, e) in zip(samples, POINTS_NE, strict=False):
            target = frame.to_lat_lon(n, e)
            assert record.target_lat_deg == pytest.approx(target[0], abs=1e-7)
            assert record.target_lon_deg == pytest.approx(target[1], abs=1e-7)
            assert record.distance_m is not None and record.distance_m <= 2.5
            assert record.volume_ml == pytest.approx(VOLUME_ML, abs=10.0)
        assert h.sampler.bottles_ml == pytest.approx([VOLUME_ML] * 4, abs=10.0)  # the simulated bottles

        # The fifth item was refused (no bottle) and the mission went on; nothing was pumped.
        assert "sampler: no empty bottle left" in texts
        assert len(payloads.samplelog.samples(None)) == 4
        # ... and so is a fifth sample command.
        spec = h.services.commands.get(UsvCmd.SAMPLE)
        assert spec is not None
        result = await spec.handler(CommandRequest(UsvCmd.SAMPLE, (0.0,) * 7))
        assert result.result == mav.MAV_RESULT_DENIED and result.reason == "sampler: no empty bottle left"
        await asyncio.sleep(0)
        await h.run_for(1.0)
        assert not h.sampler.pump_on and len(payloads.samplelog.samples(None)) == 4
