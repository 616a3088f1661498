"""Water sampler (chapter 4.2): pump/valve sequence, bottle bookkeeping, refusals, log records."""

from __future__ import annotations

import asyncio

import pytest

from companion.guidance.geo import LocalFrame
from companion.messages import STATUS_TEXT_TOPIC, Severity, StatusText
from companion.payloads.samplelog import SampleRecord
from companion.payloads.sampler import BottleState, SampleJob, SampleRequest, WaterSampler

from .helpers import LAT0, LON0, World, make_ctx


@pytest.fixture
def world(tmp_path) -> World:
    return World(make_ctx(), tmp_path)


async def _fill(world: World, sampler: WaterSampler, req: SampleRequest, seconds: float = 30.0) -> SampleJob:
    job = sampler.start(req)
    assert isinstance(job, SampleJob), job
    await world.advance(seconds)
    assert job.done.done()
    return job


async def test_sample_runs_valve_then_pump_and_logs(world: World) -> None:
    world.bottles_ml = []  # no bottle level sensors: volume from USV_SMPL_FLOW x pump time
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    job = sampler.start(SampleRequest(bottle=0, fill_s=10.0))
    assert isinstance(job, SampleJob) and job.bottle == 1
    await world.advance(5.0)
    assert world.outputs.current.pump_on and world.outputs.current.valve_bottle == 1
    assert 40 <= job.progress_pct <= 60
    assert world.log.samples()[0].status == "filling"  # durable before the pump finished
    await world.advance(6.0)
    record = await job.wait()
    assert record is not None and record.status == "complete" and record.bottle == 1
    assert record.volume_ml == pytest.approx(250.0, abs=5)  # 25 mL/s x 10 s
    assert not world.outputs.current.pump_on and world.outputs.current.valve_bottle == 0
    assert sampler.bottle_state[0] == BottleState.FULL
    first_valve = next(i for i, c in enumerate(world.commands) if c.valve_bottle == 1)
    first_pump = next(i for i, c in enumerate(world.commands) if c.pump_on)
    assert first_valve < first_pump  # valve opens before the pump runs


async def _fill_sensed_bottle(world: World, job: SampleJob, bottle: int,
                             within_s: float) -> SampleRecord | None:
    """While the pump runs, the real bottle ``bottle`` (its level sensor) fills at 40 mL/s; the
    sample's record once it is done (at most ``within_s``)."""
    for _ in range(round(within_s / 0.05)):
        if world.outputs.current.pump_on:
            world.bottles_ml[bottle - 1] += 40.0 * 0.05
        await world.advance(0.05)
        if job.done.done():
            break
    return await job.wait()


async def test_volume_from_level_sensor_stops_at_target(world: World) -> None:
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    job = sampler.start(SampleRequest(bottle=3, volume_ml=200.0))
    assert isinstance(job, SampleJob)
    record = await _fill_sensed_bottle(world, job, 3, 10.0)
    assert record is not None and record.status == "complete" and record.bottle == 3
    assert 200.0 <= record.volume_ml <= 210.0
    assert record.duration_s == pytest.approx(5.0, abs=0.3)


async def test_a_bottle_left_with_water_in_it_gets_the_whole_sample_on_top_and_a_warning(
        world: World) -> None:
    """The crew marked the bottles empty (USV_CMD_SAMPLER_RESET) but bottle 2 still reads 200 mL
    (not emptied, or a sensor offset): the sample is the rise of the level, so the pump runs for the
    full 200 mL, and the operator is told.  Before, the old level counted as the sample: it ended at
    once without pumping, with no distance from the point (``usv sitl``: the second mission after
    ``--reset-bottles``, whose simulated bottles nobody empties)."""
    world.bottles_ml[1] = 200.0
    world.publish_sensors()
    texts: list[StatusText] = []
    world.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(texts.append)
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    job = sampler.start(SampleRequest(bottle=2, volume_ml=200.0))
    assert isinstance(job, SampleJob)
    record = await _fill_sensed_bottle(world, job, 2, 20.0)
    assert record is not None and record.status == "complete"
    assert 200.0 <= record.volume_ml <= 210.0 and 400.0 <= world.bottles_ml[1] <= 410.0
    assert record.duration_s == pytest.approx(5.0, abs=0.3)
    warning = (Severity.WARNING, "sampler: bottle 2 not empty (200 mL)")
    assert [(t.severity, t.text) for t in texts] == [warning]


async def test_next_bottle_order_and_fifth_sample_refused(world: World) -> None:
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    for expected in (1, 2, 3, 4):
        job = await _fill(world, sampler, SampleRequest(fill_s=2.0), 3.0)
        assert job.bottle == expected and job.status == "complete"
    assert sampler.start(SampleRequest()) == "sampler: no empty bottle left"
    assert sampler.start(SampleRequest(bottle=2)) == "sampler: bottle 2 full"
    assert len(world.log.samples("complete")) == 4
    assert sampler.reset(2) is None
    job = await _fill(world, sampler, SampleRequest(fill_s=1.0), 2.0)
    assert job.bottle == 2


async def test_busy_and_invalid_requests_refused(world: World) -> None:
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    assert sampler.start(SampleRequest(bottle=7)) == "sampler: bottle 7 invalid (0-4)"
    assert sampler.start(SampleRequest(fill_s=float("nan"))) == "sampler: invalid fill time nan"
    assert sampler.start(SampleRequest(volume_ml=9000)) == "sampler: volume 9000 mL > bottle 500 mL"
    job = sampler.start(SampleRequest(fill_s=5.0))
    assert isinstance(job, SampleJob)
    assert sampler.start(SampleRequest()) == "sampler: busy filling bottle 1"
    assert world.log.samples()[0].bottle == 1 and len(world.log.samples()) == 1


async def test_stop_pump_aborts_and_marks_bottle_failed(world: World) -> None:
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    job = sampler.start(SampleRequest(fill_s=20.0))
    assert isinstance(job, SampleJob)
    await world.advance(2.0)
    assert sampler.stop_pump() is True
    await world.advance(0.2)
    record = await job.wait()
    assert record is not None and record.status == "aborted"
    assert not world.outputs.current.pump_on
    assert sampler.bottle_state[0] == BottleState.FAILED
    assert isinstance(sampler.start(SampleRequest()), SampleJob)  # next bottle is 2
    assert sampler.active is not None and sampler.active.bottle == 2


async def test_timeout_marks_failed(world: World) -> None:
    world.publish_sensors()
    world.ctx.params.set("USV_SMPL_TMO_S", 5.0)
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    # commanded point far away: the pump never runs outside the acceptance circle
    job = await _fill(
        world,
        sampler,
        SampleRequest(fill_s=3.0, target_lat_deg=LAT0 + 0.001, target_lon_deg=LON0, accept_radius_m=2.5),
        6.0,
    )
    assert job.status == "failed" and "timeout" in job.reason
    assert not any(c.pump_on for c in world.commands)


async def test_pump_only_inside_acceptance_circle_and_distance_logged(world: World) -> None:
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    target_lat = LocalFrame(LAT0, LON0).to_lat_lon(1.5, 0.0)[0]  # 1.5 m north
    job = sampler.start(
        SampleRequest(
            fill_s=2.0, target_lat_deg=target_lat, target_lon_deg=LON0, accept_radius_m=2.5, mission_seq=7
        )
    )
    assert isinstance(job, SampleJob)
    await world.advance(1.0)
    assert world.outputs.current.pump_on
    world.lat = LocalFrame(LAT0, LON0).to_lat_lon(-3.0, 0.0)[0]  # drifted 4.5 m from the point: pump pauses
    await world.advance(1.0)
    assert not world.outputs.current.pump_on and not job.done.done()
    world.lat = LAT0
    await world.advance(2.0)
    record = await job.wait()
    assert record is not None and record.status == "complete" and record.mission_seq == 7
    assert record.distance_m == pytest.approx(1.5, abs=0.05)
    assert record.target_lat_deg == pytest.approx(target_lat)


async def test_pump_stops_before_the_boat_leaves_the_circle(world: World) -> None:
    """2.3 m from the point inside the 2.5 m circle: the pump runs while the boat closes or holds,
    and stops while it heads out at 1 m/s (it would be outside before the stop reached the pump)."""
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    target_lat = LocalFrame(LAT0, LON0).to_lat_lon(-2.3, 0.0)[0]  # the boat is 2.3 m north of it
    job = sampler.start(SampleRequest(fill_s=10.0, target_lat_deg=target_lat, target_lon_deg=LON0,
                                      accept_radius_m=2.5))
    assert isinstance(job, SampleJob)
    world.vel_ne_mps = (-1.0, 0.0)  # closing
    await world.advance(1.0)
    assert world.outputs.current.pump_on
    world.vel_ne_mps = (1.0, 0.0)  # heading out
    await world.advance(0.5)
    assert not world.outputs.current.pump_on
    world.vel_ne_mps = (0.0, 1.0)  # along the circle
    await world.advance(0.5)
    assert world.outputs.current.pump_on
    assert sampler.stop_pump()
    await world.advance(0.5)


async def test_restart_remembers_full_bottles(world: World, tmp_path) -> None:
    world.publish_sensors()
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    await _fill(world, sampler, SampleRequest(bottle=2, fill_s=1.0), 2.0)
    world.log.close()
    from companion.payloads.samplelog import SampleLog

    again = WaterSampler(world.ctx, world.outputs, SampleLog(tmp_path / "samples.sqlite"))
    assert again.bottle_state == [BottleState.EMPTY, BottleState.FULL, BottleState.EMPTY, BottleState.EMPTY]
    assert again.last_sample is not None and again.last_sample.bottle == 2


def test_no_event_loop_needed_for_queries(world: World) -> None:
    sampler = WaterSampler(world.ctx, world.outputs, world.log)
    assert sampler.choose_bottle(0) == 1
    assert asyncio.iscoroutinefunction(sampler._run)
