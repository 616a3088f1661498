"""Services that run the simulated boat inside ``usv sitl`` and ``usv sim``."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

from companion.app import BaseService, Context, Service
from companion.clock import SimClock

PHYSICS_STEP_S = 0.01
"""Physics and control period: the chapter's 0.01 s."""


class Pacer(BaseService):
    """Advances the simulation clock in fixed steps, capped at ``speedup`` x real time.

    ``speedup`` 0 means as fast as possible.  Between steps the event loop runs every task
    that became ready, which is what lets lockstep services answer before the next step.
    """

    name = "sim-pacer"

    def __init__(self, clock: SimClock, speedup: float, step_s: float = PHYSICS_STEP_S) -> None:
        self.clock = clock
        self.speedup = speedup
        self.step_s = step_s

    async def run(self) -> None:
        wall_t0 = time.monotonic()
        sim_t0 = self.clock.now_s()
        while True:
            self.clock.advance_to(self.clock.now_s() + self.step_s)
            if self.speedup > 0:
                due_wall = wall_t0 + (self.clock.now_s() - sim_t0) / self.speedup
                delay = due_wall - time.monotonic()
                await asyncio.sleep(max(0.0, delay))
            else:
                await asyncio.sleep(0)


class StopAfter(BaseService):
    """Requests shutdown after a given amount of clock time (``usv sitl --duration``)."""

    name = "stop-after"

    def __init__(self, clock: SimClock, duration_s: float, stop: Callable[[], None]) -> None:
        self.clock = clock
        self.duration_s = duration_s
        self.stop_cb = stop

    async def run(self) -> None:
        await self.clock.sleep(self.duration_s)
        self.stop_cb()
        await asyncio.Event().wait()


def build_sim_services(ctx: Context, clock: SimClock) -> list[Service]:
    """The simulator's services in start-up order (they start before the companion's)."""
    speedup = float(ctx.config["sim.speedup"])
    return [Pacer(clock, speedup)]
