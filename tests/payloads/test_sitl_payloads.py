"""End to end in lockstep SITL: the simulated boat registers launches and bottle fills only
when the companion's interlocks allow them (real sentence parser, servo frames, plant)."""

from __future__ import annotations

import asyncio
import math

import pytest

from companion.payloads.launcher import RopeLauncher
from companion.payloads.sampler import SampleJob, SampleRequest
from sim_bridge.sitl import SitlHarness

pytestmark = pytest.mark.integration


def _arm_vehicle(h: SitlHarness) -> None:
    assert h.services is not None
    assert h.services.vehicle.arm(force=True) is None


async def _fire(h: SitlHarness, launcher: RopeLauncher) -> str | None:
    task = asyncio.ensure_future(launcher.fire())
    await h.run_for(1.5)
    return task.result()


async def test_arm_and_fire_registers_launch_at_heading() -> None:
    async with SitlHarness(full_stack=True, psi0_deg=60.0) as h:
        await h.run_for(1.0)
        payloads = h.services.payloads
        launcher = payloads.device("launcher")
        _arm_vehicle(h)
        before = launcher.pressure_mpa()
        assert before is not None and before > 25.0  # read from the simulated $PUSVP sentence
        assert launcher.arm() is None
        assert await _fire(h, launcher) is None
        assert len(h.launcher.events) == 1
        ev = h.launcher.events[0]
        assert math.degrees(ev.bearing_rad) % 360 == pytest.approx(60.0, abs=3.0)
        assert len(h.launcher.buoys) == 1
        after = launcher.pressure_mpa()
        assert after is not None and after < before - 5.0  # the companion sees the pressure drop
        await h.run_for(6.0)
        assert h.launcher.buoys[0].inflated
        assert payloads.samplelog.launches()[0].heading_deg == pytest.approx(60.0, abs=3.0)


async def test_each_interlock_refuses_and_sim_registers_no_launch() -> None:
    async with SitlHarness(full_stack=True, params={"USV_LNCH_ARM_S": 5.0}) as h:
        await h.run_for(1.0)
        launcher = h.services.payloads.device("launcher")
        assert await _fire(h, launcher) == "launcher: vehicle not armed"
        _arm_vehicle(h)
        assert await _fire(h, launcher) == "launcher: not armed (send ARM first)"
        assert launcher.arm() is None
        await h.run_for(6.0)
        assert await _fire(h, launcher) == "launcher: arm window expired"
        h.rc.override = True
        await h.run_for(0.5)
        assert launcher.arm() == "launcher: RC has control (selector)"
        assert await _fire(h, launcher) == "launcher: RC has control (selector)"
        h.rc.override = False
        h.launcher.pressure_mpa = 8.0
        await h.run_for(0.5)
        assert (await _fire(h, launcher) or "").startswith("launcher: pressure low 8.0")
        assert h.launcher.events == [] and h.launcher.misfires == 0


async def test_sample_fills_the_simulated_bottle() -> None:
    async with SitlHarness(full_stack=True) as h:
        await h.run_for(1.0)
        payloads = h.services.payloads
        job = payloads.device("sampler").start(SampleRequest(bottle=0, volume_ml=200.0))
        assert isinstance(job, SampleJob) and job.bottle == 1
        await h.run_for(12.0)
        assert job.done.done() and job.status == "complete"
        assert 195.0 <= h.sampler.bottles_ml[0] <= 215.0
        assert h.sampler.bottles_ml[1:] == [0.0, 0.0, 0.0] and not h.sampler.pump_on
        rec = payloads.samplelog.samples("complete")[0]
        assert rec.bottle == 1 and 195.0 <= rec.volume_ml <= 215.0
