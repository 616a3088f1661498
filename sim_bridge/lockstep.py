"""Lockstep (and paced real-time) driver: sensor sample out, servo frame back, physics step.

In lockstep the simulator advances one physics step only after the companion answered the
previous sample with its servo frame, so runs are deterministic and as fast as the CPU
allows; ``speedup`` > 0 caps the rate at that multiple of real time (ArduPilot SITL's
``--speedup``).  With ``lockstep=False`` the boat never waits (real-time mode for people
and QGroundControl; pair with ``speedup=1``).  The wait for a frame is bounded by a
wall-clock ``ack_timeout_s`` so a dead companion slows the simulation but never hangs it.
Behind its pace by more than :data:`MAX_LAG_S` of wall time (the first steps import and load
compiled kernels for about 2 s), the pacing starts again from where the simulation is, instead
of running flat out to make up the lost time: ``speedup`` stays a cap for the ground stations
watching it (catching up ran 40 simulated seconds in half a wall second).

After each step the driver hands the event loop to the companion's other tasks (links,
timers, telemetry) when any is ready to run, which in lockstep is whenever the step woke a
sleeper of the simulation clock or published to an awaited topic, and otherwise at least
every ``IO_POLL_S`` of wall time so sockets and wall-clock timers are served.  Skipping the
yield when nothing is ready runs nothing sooner or later in simulated time: an idle pass
of the event loop costs more than a physics step.

Profiling counters (wall seconds, ``time.perf_counter``; :meth:`Lockstep.timing_us` gives
means per step): the simulator's ``sample_time_s`` (sensor sentences), ``receive_time_s``
(decoding the servo frame) and ``physics_time_s`` (plant, payloads), and ``write_time_s``,
the time in writing the sample less the simulator's receive within it, which over the
in-memory pipe is the companion's synchronous handling (parser, control loop stages,
servo frame); the rest of a run is the event loop and the companion's other tasks.
"""

from __future__ import annotations

import asyncio
import time

from companion.clock import SimClock
from companion.transport import ByteLink
from sim_bridge.simboat import SimulatedBoat

IO_POLL_S = 0.00025
"""Longest wall time between two passes of the event loop while stepping in lockstep."""
MAX_LAG_S = 0.25
"""Wall seconds behind the paced schedule that are made up by running faster; more is dropped."""


class Lockstep:
    def __init__(self, boat: SimulatedBoat, clock: SimClock, link: ByteLink, *, lockstep: bool = True,
                 speedup: float = 0.0, ack_timeout_s: float = 2.0, wait_for_first_frame: bool = True) -> None:
        self.boat, self.clock, self.link = boat, clock, link
        self.lockstep, self.speedup, self.ack_timeout_s = lockstep, speedup, ack_timeout_s
        self.wait_for_first_frame = wait_for_first_frame
        self.missed_acks = 0
        self.steps = 0
        self.sample_time_s = self.receive_time_s = self.physics_time_s = self.write_time_s = 0.0
        self._timed_steps = 0
        self._ack = asyncio.Event()
        link.set_receiver(self._on_bytes)
        self._wall0: float | None = None
        self._sim0 = 0.0
        self._last_yield_s = 0.0

    def reset_timing(self) -> None:
        self.sample_time_s = self.receive_time_s = self.physics_time_s = self.write_time_s = 0.0
        self._timed_steps = self.steps

    def timing_us(self) -> dict[str, float]:
        """Mean wall microseconds per step: ``simulator`` (``sensor_sample`` + ``servo_receive``
        + ``physics``) and ``sample_delivery`` (the companion's synchronous handling of a sample)."""
        per_step_us = 1e6 / max(1, self.steps - self._timed_steps)
        parts = {"sensor_sample": self.sample_time_s, "servo_receive": self.receive_time_s,
                 "physics": self.physics_time_s}
        out = {name: t * per_step_us for name, t in parts.items()}
        out["simulator"] = sum(parts.values()) * per_step_us
        out["sample_delivery"] = self.write_time_s * per_step_us
        return out

    def _on_bytes(self, data: bytes) -> None:
        t0 = time.perf_counter()
        self.boat.receive(data)
        self.receive_time_s += time.perf_counter() - t0
        if self.boat.pending is None:
            self._ack.set()

    def _reset_pacing(self) -> None:
        self._wall0, self._sim0 = time.monotonic(), self.clock.now_s()

    async def step(self) -> None:
        boat = self.boat
        self._ack.clear()
        t0 = time.perf_counter()
        data = boat.sample()
        t1 = time.perf_counter()
        received_s = self.receive_time_s
        if data:
            self.link.write(data)  # in-memory: the companion answers (and we receive) inside this call
        t2 = time.perf_counter()
        received_s = self.receive_time_s - received_s
        waiting = self.wait_for_first_frame or boat.frames_received > 0
        if self.lockstep and waiting and boat.pending is not None:
            try:
                await asyncio.wait_for(self._ack.wait(), self.ack_timeout_s)
            except TimeoutError:
                self.missed_acks += 1
                boat.pending = None
        t3 = time.perf_counter()
        boat.advance()
        self.physics_time_s += time.perf_counter() - t3
        self.sample_time_s += t1 - t0
        self.write_time_s += (t2 - t1) - received_s
        self.clock.advance_to(boat.t_s)
        self.steps += 1
        now = time.perf_counter()
        ready = getattr(asyncio.get_running_loop(), "_ready", None)  # CPython's queue of runnable callbacks
        if ready is None or ready or now - self._last_yield_s > IO_POLL_S:
            self._last_yield_s = now
            await asyncio.sleep(0)  # let the companion's other tasks (links, timers) run
        if self.speedup > 0.0:
            if self._wall0 is None:
                self._reset_pacing()
            assert self._wall0 is not None
            ahead_s = self._wall0 + (self.clock.now_s() - self._sim0) / self.speedup - time.monotonic()
            if ahead_s > 0.002:
                await asyncio.sleep(ahead_s)
            elif ahead_s < -MAX_LAG_S:
                self._reset_pacing()

    async def run_for(self, sim_seconds: float) -> None:
        end = self.clock.now_s() + sim_seconds - 1e-9
        self._reset_pacing()
        while self.clock.now_s() < end:
            await self.step()

    async def run_forever(self) -> None:
        self._reset_pacing()
        while True:
            await self.step()
