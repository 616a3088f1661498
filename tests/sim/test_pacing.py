"""``--speedup`` pacing of the lockstep driver (:class:`sim_bridge.lockstep.Lockstep`), on a fake
wall clock: one part (the driver) with a fake boat and link; the wall clock only moves when the
driver sleeps, or when the test makes it stall."""

from __future__ import annotations

import asyncio
import types

import pytest

import sim_bridge.lockstep as lockstep_module
from companion.clock import SimClock
from sim_bridge.lockstep import Lockstep

STEP_S = 0.01
SPEEDUP = 20.0


class FakeBoat:
    """Answers nothing (no frame pending) and moves its clock one physics step per advance."""

    def __init__(self) -> None:
        self.t_s, self.pending, self.frames_received = 0.0, None, 0

    def sample(self) -> bytes:
        return b""

    def advance(self) -> None:
        self.t_s += STEP_S


class FakeLink:
    def set_receiver(self, receiver: object) -> None:
        pass

    def write(self, data: bytes) -> None:
        pass


class FakeWall:
    def __init__(self) -> None:
        self.now_s = 100.0

    def monotonic(self) -> float:
        return self.now_s

    def perf_counter(self) -> float:
        return self.now_s

    async def sleep(self, seconds: float) -> None:
        self.now_s += seconds
        await asyncio.sleep(0)


async def test_after_a_stall_the_simulation_keeps_its_speedup_instead_of_racing_to_catch_up(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The first steps of ``usv sitl`` take about 2 s of wall time (imports, compiled kernels).
    Making that time up ran the vehicle clock at over 100x, and a ground station sending its
    heartbeat once per wall second went unheard for tens of simulated seconds."""
    wall = FakeWall()
    fake_asyncio = types.SimpleNamespace(sleep=wall.sleep, wait_for=asyncio.wait_for, Event=asyncio.Event,
                                         get_running_loop=asyncio.get_running_loop)
    monkeypatch.setattr(lockstep_module, "time", wall)
    monkeypatch.setattr(lockstep_module, "asyncio", fake_asyncio)
    boat, clock = FakeBoat(), SimClock(0.0)
    driver = Lockstep(boat, clock, FakeLink(), speedup=SPEEDUP)  # type: ignore[arg-type]
    await driver.step()
    wall.now_s += 2.0  # the stall
    await driver.step()
    t0_vehicle, t0_wall = clock.now_s(), wall.now_s
    while clock.now_s() < t0_vehicle + 40.0:
        await driver.step()
        rate = (clock.now_s() - t0_vehicle) / max(wall.now_s - t0_wall, 1e-9)
        assert clock.now_s() - t0_vehicle < 1.0 or rate < 1.3 * SPEEDUP, (clock.now_s(), rate)
    assert abs((wall.now_s - t0_wall) * SPEEDUP - 40.0) < 0.5
