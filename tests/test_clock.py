import asyncio

import pytest

from companion.clock import (
    NOMINAL_STEP_S,
    STEP_MAX_S,
    STEP_MIN_S,
    SimClock,
    StepTimer,
    WallClock,
    periodic,
    wait_for,
)


async def test_sim_clock_wakes_sleepers_in_deadline_order_at_their_deadline() -> None:
    clock = SimClock(start_unix_time_s=1000.0)
    woke: list[tuple[str, float]] = []

    async def sleeper(name: str, dt: float) -> None:
        await clock.sleep(dt)
        woke.append((name, clock.now_s()))

    tasks = [asyncio.create_task(sleeper("late", 2.0)), asyncio.create_task(sleeper("early", 0.5))]
    for step in range(1, 301):  # 10 ms physics steps, as the pacer does
        await asyncio.sleep(0)
        clock.advance_to(step * 0.01)
        await asyncio.sleep(0)
        if step == 100:
            assert [name for name, _ in woke] == ["early"]
    await asyncio.gather(*tasks)
    assert [name for name, _ in woke] == ["early", "late"]
    assert woke[0][1] == pytest.approx(0.5, abs=0.011)
    assert woke[1][1] == pytest.approx(2.0, abs=0.011)
    assert clock.unix_time_s() == pytest.approx(1003.0)


async def test_sim_clock_refuses_to_go_backwards() -> None:
    clock = SimClock()
    clock.advance_to(5.0)
    with pytest.raises(ValueError, match="backwards"):
        clock.advance_to(4.0)


async def test_wait_for_times_out_in_simulated_time_not_wall_time() -> None:
    clock = SimClock()
    never = asyncio.get_running_loop().create_future()
    waiter = asyncio.create_task(wait_for(clock, never, timeout_s=120.0))
    await asyncio.sleep(0.01)
    assert not waiter.done()  # wall time passes, simulated time does not
    clock.advance_to(119.9)
    await asyncio.sleep(0)
    assert not waiter.done()
    clock.advance_to(120.0)
    with pytest.raises(TimeoutError):
        await waiter


async def test_periodic_keeps_its_rate_without_drift() -> None:
    clock = SimClock()
    stamps: list[float] = []

    async def consume() -> None:
        async for t in periodic(clock, 0.01):
            stamps.append(round(t, 9))
            if len(stamps) == 5:
                return

    task = asyncio.create_task(consume())
    for step in range(1, 10):
        await asyncio.sleep(0)
        clock.advance_to(step * 0.01)
        await asyncio.sleep(0)
    await task
    assert stamps == [0.0, 0.01, 0.02, 0.03, 0.04]


async def test_wall_clock_moves_forward() -> None:
    clock = WallClock()
    t0 = clock.now_s()
    await clock.sleep(0.01)
    assert clock.now_s() > t0


def test_step_timer_clamps_the_sensor_time_step() -> None:
    timer = StepTimer()
    assert timer.step(5.0) == NOMINAL_STEP_S  # first sample: the nominal control period
    assert timer.step(5.02) == pytest.approx(0.02)
    assert timer.step(5.02) == STEP_MIN_S  # a repeated sample
    assert timer.step(9.0) == STEP_MAX_S  # a gap: integrators must not get the whole of it
    timer.reset()
    assert timer.step(9.5) == NOMINAL_STEP_S
