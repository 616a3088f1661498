"""The application skeleton: services started in order in one TaskGroup, stopped in reverse.

A :class:`Service` is anything with ``start()`` (bind sockets, open ports: fast, ordered),
``run()`` (the long-running loop) and ``stop()`` (release resources).  :class:`Application`
starts services one after another, runs all ``run()`` coroutines in one
:class:`asyncio.TaskGroup`, and on SIGINT/SIGTERM (or :meth:`Application.request_stop`)
cancels them in reverse start order, calls ``stop()`` in reverse order, and checks that no
task is left behind.  :meth:`Application.running` is the same life cycle for a caller that
drives the clock itself (``sim_bridge.sitl.SitlHarness``): services started in order with their
``run()`` as tasks inside the ``async with``, cancelled and stopped in reverse on leaving it.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Protocol

from companion.bus import Bus
from companion.clock import Clock
from companion.config import Config
from companion.params import ParamStore

log = logging.getLogger(__name__)


class Service(Protocol):
    """A part of the application with an ordered life cycle."""

    name: str

    async def start(self) -> None: ...

    async def run(self) -> None: ...

    async def stop(self) -> None: ...


class BaseService:
    """Convenience base: no-op start/stop, ``run`` waits forever."""

    name = "service"

    async def start(self) -> None:
        return None

    async def run(self) -> None:
        await asyncio.Event().wait()

    async def stop(self) -> None:
        return None


@dataclass(frozen=True)
class Context:
    """What every part gets: configuration, clock, bus and parameters.

    Everything else a part needs (the vehicle, the control system, the links ...) is passed to
    its constructor explicitly; :mod:`companion.runtime` builds them in start-up order into one
    typed :class:`~companion.runtime.Services` record.
    """

    config: Config
    clock: Clock
    bus: Bus
    params: ParamStore


class Application:
    """Ordered start-up and clean shutdown of a list of services."""

    def __init__(self, services: list[Service] | None = None) -> None:
        self.services: list[Service] = list(services or [])
        self._stop = asyncio.Event()
        self.started: list[str] = []
        self.stopped: list[str] = []

    def add(self, service: Service) -> None:
        self.services.append(service)

    def request_stop(self) -> None:
        """Ask for a clean shutdown (what SIGINT/SIGTERM do)."""
        self._stop.set()

    async def run(self, *, install_signal_handlers: bool = True) -> None:
        loop = asyncio.get_running_loop()
        installed: list[signal.Signals] = []
        if install_signal_handlers:
            for sig in (signal.SIGINT, signal.SIGTERM):
                with contextlib.suppress(NotImplementedError, RuntimeError):
                    loop.add_signal_handler(sig, self.request_stop)
                    installed.append(sig)
        started: list[Service] = []
        tasks: list[asyncio.Task[None]] = []
        try:
            async with asyncio.TaskGroup() as tg:
                for service in self.services:
                    await self._start(service, started)
                    tasks.append(tg.create_task(service.run(), name=service.name))
                stop_waiter = tg.create_task(self._stop.wait(), name="stop-request")
                await stop_waiter
                for task in reversed(tasks):
                    task.cancel()
                    with contextlib.suppress(asyncio.CancelledError):
                        await task
        finally:
            await self._stop_all(started)
            for sig in installed:
                loop.remove_signal_handler(sig)

    @contextlib.asynccontextmanager
    async def running(self) -> AsyncIterator[list[asyncio.Task[None]]]:
        """Start the services in order with their ``run()`` as tasks (yielded, in start order);
        on leaving, cancel the tasks and stop the services in reverse order.  A service whose
        ``run()`` fails is logged; the others go on (the caller, which drives the clock, looks
        at the tasks and decides when to leave)."""
        started: list[Service] = []
        tasks: list[asyncio.Task[None]] = []
        try:
            for service in self.services:
                await self._start(service, started)
                tasks.append(asyncio.create_task(service.run(), name=service.name))
            yield tasks
        finally:
            for task in reversed(tasks):
                task.cancel()
                try:
                    await task
                except asyncio.CancelledError:
                    pass
                except Exception:
                    log.exception("service %s failed", task.get_name())
            await self._stop_all(started)

    async def _start(self, service: Service, started: list[Service]) -> None:
        await service.start()
        started.append(service)
        self.started.append(service.name)
        log.debug("started %s", service.name)

    async def _stop_all(self, started: list[Service]) -> None:
        for service in reversed(started):
            try:
                await service.stop()
            except Exception:  # a failing stop must not prevent the others
                log.exception("error while stopping %s", service.name)
            self.stopped.append(service.name)
