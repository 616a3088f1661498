"""Lockstep (and paced real-time) driver: sensor sample out, servo frame back, physics step.

In lockstep the simulator advances one physics step only after the companion answered the
previous sample with its servo frame, so runs are deterministic and as fast as the CPU
allows; ``speedup`` > 0 caps the rate at that multiple of real time (ArduPilot SITL's
``--speedup``).  With ``lockstep=False`` the boat never waits (real-time mode for people
and QGroundControl; pair with ``speedup=1``).  The wait for a frame is bounded by a
wall-clock ``ack_timeout_s`` so a dead companion slows the simulation but never hangs it.
"""

from __future__ import annotations

import asyncio
import time

from companion.clock import SimClock
from companion.transport import ByteLink
from sim_bridge.simboat import SimulatedBoat


class Lockstep:
    def __init__(self, boat: SimulatedBoat, clock: SimClock, link: ByteLink, *, lockstep: bool = True,
                 speedup: float = 0.0, ack_timeout_s: float = 2.0, wait_for_first_frame: bool = True) -> None:
        self.boat, self.clock, self.link = boat, clock, link
        self.lockstep, self.speedup, self.ack_timeout_s = lockstep, speedup, ack_timeout_s
        self.wait_for_first_frame = wait_for_first_frame
        self.missed_acks = 0
        self.steps = 0
        self._ack = asyncio.Event()
        link.set_receiver(self._on_bytes)
        self._wall0: float | None = None
        self._sim0 = 0.0

    def _on_bytes(self, data: bytes) -> None:
        self.boat.receive(data)
        if self.boat.pending is None:
            self._ack.set()

    def _reset_pacing(self) -> None:
        self._wall0, self._sim0 = time.monotonic(), self.clock.now_s()

    async def step(self) -> None:
        boat = self.boat
        self._ack.clear()
        data = boat.sample()
        if data:
            self.link.write(data)
        waiting = self.wait_for_first_frame or boat.frames_received > 0
        if self.lockstep and waiting and boat.pending is not None:
            try:
                await asyncio.wait_for(self._ack.wait(), self.ack_timeout_s)
            except TimeoutError:
                self.missed_acks += 1
                boat.pending = None
        boat.advance()
        self.clock.advance_to(boat.t_s)
        self.steps += 1
        await asyncio.sleep(0)  # let the companion's other tasks (links, timers) run
        if self.speedup > 0.0:
            if self._wall0 is None:
                self._reset_pacing()
            assert self._wall0 is not None
            ahead_s = self._wall0 + (self.clock.now_s() - self._sim0) / self.speedup - time.monotonic()
            if ahead_s > 0.002:
                await asyncio.sleep(ahead_s)

    async def run_for(self, sim_seconds: float) -> None:
        end = self.clock.now_s() + sim_seconds - 1e-9
        self._reset_pacing()
        while self.clock.now_s() < end:
            await self.step()

    async def run_forever(self) -> None:
        self._reset_pacing()
        while True:
            await self.step()
