"""Lockstep round trips per second, simulator <-> companion seam (parser, pipeline, servo frame).

Over the in-memory pipe (one process, synchronous delivery) and over real pseudo-terminals
read by pyserial.  Each round trip is one 0.01 s physics step, so ``realtime_factor`` =
round trips per second / 100 (ArduPilot Rover SITL reaches about 150x on a 2-core machine).
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

from companion.messages import ActuatorCommand
from sim_bridge.sitl import SitlHarness


async def _rate(transport: str, sim_s: float) -> dict[str, Any]:
    async with SitlHarness(transport=transport) as h:
        h.drive(lambda nav: ActuatorCommand(nav.t_s, nozzle_rad=0.2, throttle=0.6, ignition_on=True))
        await h.run_for(0.5)
        t0 = time.perf_counter()
        await h.run_for(sim_s)
        wall = time.perf_counter() - t0
        assert h.lockstep is not None
        rate = round(sim_s / 0.01) / wall
        return {"round_trips_per_s": round(rate), "realtime_factor": round(rate * 0.01, 1),
                "missed_acks": h.lockstep.missed_acks}


def run(quick: bool) -> dict[str, Any]:
    sim_s = 5.0 if quick else 60.0

    async def both() -> dict[str, Any]:
        return {"memory_pipe": await _rate("memory", sim_s), "pty": await _rate("pty", sim_s)}

    return asyncio.run(both())
