"""Clock abstraction used by every part of the companion and the simulator.

Every timeout, period and failsafe in the code base reads time from a :class:`Clock`
instead of :mod:`time` or ``loop.time()``.  On a real boat that is :class:`WallClock`;
in SITL it is :class:`SimClock`, which only moves when the simulator advances it, so
lockstep runs go faster than real time and timeouts (failsafes included) still expire
after the right amount of *simulated* time.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import time
from collections.abc import AsyncIterator, Awaitable
from typing import Protocol, TypeVar

T = TypeVar("T")


class Clock(Protocol):
    """Time source: seconds since the clock started, and sleeping in that time base."""

    def now_s(self) -> float:
        """Monotonic seconds since the clock started."""
        ...

    def unix_time_s(self) -> float:
        """Seconds since the Unix epoch (for SYSTEM_TIME, logs and file names)."""
        ...

    async def sleep(self, duration_s: float) -> None:
        """Sleep for ``duration_s`` seconds of this clock's time."""
        ...


class WallClock:
    """The real clock of a real boat (``time.monotonic`` and ``time.time``)."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now_s(self) -> float:
        return time.monotonic() - self._t0

    def unix_time_s(self) -> float:
        return time.time()

    async def sleep(self, duration_s: float) -> None:
        await asyncio.sleep(max(0.0, duration_s))


class SimClock:
    """Simulation time, advanced explicitly by the simulator (lockstep or paced).

    Sleepers are kept in a heap of deadlines and woken by :meth:`advance_to` in
    deadline order, so a 120 s failsafe timeout takes 120 s of simulated time however
    fast the simulation runs.
    """

    def __init__(self, start_unix_time_s: float | None = None) -> None:
        self._now_s = 0.0
        self._start_unix_s = time.time() if start_unix_time_s is None else start_unix_time_s
        self._sleepers: list[tuple[float, int, asyncio.Future[None]]] = []
        self._counter = itertools.count()

    def now_s(self) -> float:
        return self._now_s

    def unix_time_s(self) -> float:
        return self._start_unix_s + self._now_s

    async def sleep(self, duration_s: float) -> None:
        deadline_s = self._now_s + max(0.0, duration_s)
        if deadline_s <= self._now_s:
            await asyncio.sleep(0)
            return
        fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        heapq.heappush(self._sleepers, (deadline_s, next(self._counter), fut))
        await fut

    def advance_to(self, t_s: float) -> None:
        """Move simulated time forward to ``t_s`` and wake every sleeper due by then."""
        if t_s < self._now_s:
            raise ValueError(f"simulation time cannot go backwards ({t_s} < {self._now_s})")
        while self._sleepers and self._sleepers[0][0] <= t_s:
            deadline_s, _, fut = heapq.heappop(self._sleepers)
            self._now_s = deadline_s
            if not fut.done():
                fut.set_result(None)
        self._now_s = t_s

    def next_deadline_s(self) -> float | None:
        """Earliest pending sleeper deadline, or ``None`` when nobody sleeps."""
        while self._sleepers and self._sleepers[0][2].done():
            heapq.heappop(self._sleepers)
        return self._sleepers[0][0] if self._sleepers else None


NOMINAL_STEP_S = 0.01
"""The chapter's control period (100 Hz); the first step after a reset is taken to be this long."""
STEP_MIN_S, STEP_MAX_S = 0.001, 0.1
"""Bounds of a step: a repeated, late or missing sensor sample cannot kick an integrator."""


class StepTimer:
    """The one dt clamp: time between successive sensor samples (their own time stamps), in
    [``STEP_MIN_S``, ``STEP_MAX_S``], :data:`NOMINAL_STEP_S` for the first sample after a reset."""

    __slots__ = ("last_t_s",)

    def __init__(self) -> None:
        self.last_t_s: float | None = None

    def reset(self) -> None:
        self.last_t_s = None

    def step(self, t_s: float) -> float:
        """The step ending at sample time ``t_s`` (remembered for the next one)."""
        last_t_s, self.last_t_s = self.last_t_s, t_s
        if last_t_s is None:
            return NOMINAL_STEP_S
        return min(STEP_MAX_S, max(STEP_MIN_S, t_s - last_t_s))


async def wait_for(clock: Clock, aw: Awaitable[T], timeout_s: float) -> T:
    """Like :func:`asyncio.wait_for`, but the timeout runs in ``clock`` time.

    Raises :class:`TimeoutError` when ``timeout_s`` of clock time passes first.
    """
    task = asyncio.ensure_future(aw)
    timer = asyncio.ensure_future(clock.sleep(timeout_s))
    try:
        done, _ = await asyncio.wait({task, timer}, return_when=asyncio.FIRST_COMPLETED)
        if task in done:
            return task.result()
        task.cancel()
        raise TimeoutError(f"timed out after {timeout_s} s")
    finally:
        timer.cancel()
        if not task.done():
            task.cancel()


async def periodic(clock: Clock, period_s: float) -> AsyncIterator[float]:
    """Async generator yielding the clock time every ``period_s`` without drift."""
    next_s = clock.now_s()
    while True:
        yield clock.now_s()
        next_s += period_s
        await clock.sleep(next_s - clock.now_s())
