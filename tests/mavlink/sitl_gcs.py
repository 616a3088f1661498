"""Lockstep SITL (full companion stack) with the asyncio test ground station on a UDP port.

The simulation runs as fast as the CPU allows; :func:`run_until_done` keeps stepping it while a
ground-station coroutine (a command and its ACK, a wait for a message) is pending, so the
companion's clock-driven parts (streams, heartbeats, failsafes) see simulated time.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Awaitable
from typing import Any, TypeVar

from companion.config import default_config
from sim_bridge.sitl import SitlHarness
from tests.mavlink.gcs import AsyncGcs, free_port

T = TypeVar("T")


@contextlib.asynccontextmanager
async def sitl_with_gcs(**harness: Any) -> AsyncIterator[tuple[SitlHarness, AsyncGcs]]:
    """A connected ground station and a full-stack lockstep SITL talking MAVLink over loopback UDP."""
    port = free_port()
    config = default_config().with_overrides({"links.udp_targets": [f"127.0.0.1:{port}"],
                                              "links.tcp_listen": "", "links.tlog": False})
    async with AsyncGcs(port) as gcs, SitlHarness(full_stack=True, config=config, **harness) as h:
        await run_until_done(h, gcs.connect(timeout_s=10.0), max_sim_s=5.0)
        yield h, gcs


async def run_until_done(h: SitlHarness, aw: Awaitable[T], *, max_sim_s: float = 10.0,
                         step_s: float = 0.05) -> T:
    """Advance the simulation in ``step_s`` slices until ``aw`` finishes (at most ``max_sim_s``)."""
    task = asyncio.ensure_future(aw)
    end_s = h.clock.now_s() + max_sim_s
    while not task.done() and h.clock.now_s() < end_s:
        await h.run_for(step_s)
    if not task.done():
        task.cancel()
        raise AssertionError(f"not done after {max_sim_s} s of simulated time")
    return task.result()
