"""SitlHarness: the simulated boat and the companion in one process, for tests and tools.

Usage::

    async with SitlHarness(seed=1, wind="5,270") as h:
        h.drive(lambda nav: ActuatorCommand(nav.t_s, throttle=0.5, ignition_on=True))
        await h.run_for(20.0)                 # 20 s of simulated time, lockstep, as fast as possible
        print(h.plant.state.u_mps)
        h.faults.gps_outage = True            # inject a GNSS outage (also: silent, corrupt_fraction ...)
        h.rc.override = True                  # put the boat under RC control
        h.launcher.events, h.sampler.bottles_ml, h.launcher.buoys

It builds a :class:`~companion.clock.SimClock`, a companion :class:`~companion.app.Context`
(state in a temporary directory unless ``state_dir`` is given), the :class:`SimulatedBoat`
and two byte links (``transport="memory"``: in-memory pipes, synchronous and fastest;
``"pty"``: real pseudo-terminals read by pyserial, as on the boat).  The companion side is
the hardware seam (GPS-INS parser, a :class:`~companion.pipeline.Pipeline` whose modes stage
is the function given to :meth:`SitlHarness.drive`, servo output) or, with
``full_stack=True``, the whole companion of :func:`companion.runtime.build_companion`, whose
parts tests read from :attr:`SitlHarness.services`.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import shutil
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from companion.actuators.servo import ServoMap
from companion.app import Application, Context, Service
from companion.clock import SimClock
from companion.config import Config, default_config
from companion.hardware import HardwareIoService, HardwareLinks
from companion.messages import ActuatorCommand, NavState
from companion.payloads.registry import PayloadDef
from companion.pipeline import LoopStats, Pipeline, ServoOutput
from companion.runtime import Services, build_companion, build_context
from companion.transport import ByteLink, SerialLink, memory_pipe
from sim_bridge.disturbances import spec_from_strings
from sim_bridge.gpsins import SensorFaults
from sim_bridge.hull import BoatParams
from sim_bridge.lockstep import Lockstep
from sim_bridge.payload import Launcher, RcTransmitter, Sampler
from sim_bridge.plant import BoatPlant
from sim_bridge.ptyport import PtyPort
from sim_bridge.simboat import SimulatedBoat

START_UNIX_S = 1_700_000_000.0


class TeeLink:
    """Sim-side link that is the GNSS writer and the servo reader at once (two underlying links)."""

    def __init__(self, out: ByteLink, inp: ByteLink) -> None:
        self.name, self.stats = "sim", out.stats
        self.out, self.inp = out, inp

    def set_receiver(self, receiver: Any) -> None:
        self.inp.set_receiver(receiver)

    def write(self, data: bytes) -> None:
        self.out.write(data)

    async def open(self) -> None:
        await self.out.open()
        if self.inp is not self.out:
            await self.inp.open()

    async def close(self) -> None:
        await self.out.close()
        if self.inp is not self.out:
            await self.inp.close()


class Driver:
    """The hardware seam's stand-in for the modes stage: a function of the sample (or nothing)."""

    def __init__(self) -> None:
        self.command: Callable[[NavState], ActuatorCommand | None] | None = None

    def update(self, nav: NavState) -> ActuatorCommand | None:
        return None if self.command is None else self.command(nav)


class SitlHarness:
    def __init__(self, *, seed: int = 1, wind: str = "0,0", current: str = "0,0", waves: str = "0",
                 payload_kg: float = 0.0, gnss_rate_hz: int = 100, psi0_deg: float = 0.0,
                 home: tuple[float, float] = (41.77, 123.43), full_stack: bool = False,
                 transport: str = "memory", config: Config | None = None,
                 params: dict[str, float] | None = None, state_dir: Path | None = None,
                 speedup: float = 0.0, extra_payloads: Sequence[PayloadDef] = (),
                 noise_scale: float = 1.0) -> None:
        """``extra_payloads``: payloads added to the built-in ones (full stack); ``noise_scale``:
        the GPS-INS noise levels times this (1: the device's)."""
        if transport not in ("memory", "pty"):
            raise ValueError(f"transport must be 'memory' or 'pty', not {transport!r}")
        self._tmp: str | None = None
        if state_dir is None:
            self._tmp = tempfile.mkdtemp(prefix="usv-sitl-")
            state_dir = Path(self._tmp)
        base = config or default_config()
        self.config = base.with_overrides({"vehicle.state_dir": str(state_dir), "sim.seed": seed,
                                           "sim.wind": wind, "sim.current": current, "sim.waves": waves})
        self.clock = SimClock(start_unix_time_s=START_UNIX_S)
        self.extra_payloads = tuple(extra_payloads)
        self.ctx: Context = build_context(self.config, self.clock, self.extra_payloads)
        for name, value in (params or {}).items():
            self.ctx.params.set(name, value, persist=False)
        self.boat = SimulatedBoat(seed=seed, disturbances=spec_from_strings(wind, current, waves),
                                  params=BoatParams().with_payload(payload_kg), home_lat_deg=home[0],
                                  home_lon_deg=home[1], psi0_rad=math.radians(psi0_deg),
                                  gnss_rate_hz=gnss_rate_hz, start_unix_s=START_UNIX_S,
                                  noise_scale=noise_scale)
        self.transport = transport
        self.full_stack = full_stack
        self.speedup = speedup
        self.driver = Driver()
        self.services: Services | None = None
        """Every part of the companion (``full_stack=True``; ``None`` for the hardware seam)."""
        self.pipeline: Pipeline | None = None
        self.hardware: HardwareIoService | None = None
        self._lifecycle: list[Service] = []
        self._tasks: list[asyncio.Task[None]] = []
        self._exit_stack = contextlib.AsyncExitStack()
        self._sim_link: ByteLink | None = None
        self.lockstep: Lockstep | None = None

    # -- what tests use -------------------------------------------------------------------
    def drive(self, command: Callable[[NavState], ActuatorCommand | None] | None) -> None:
        """Hardware seam: the actuator command for every sample (``None``: keep the last)."""
        if self.full_stack:
            raise RuntimeError("drive() is for the hardware seam; the full stack runs its modes")
        self.driver.command = command

    def set_servo(self, channel: int, pulse_us: int | None) -> None:
        """Hardware seam: hold output ``channel`` (1-based) at ``pulse_us`` (``None`` releases it);
        with the full stack the boat's and the payloads' outputs are not overridable."""
        assert self.pipeline is not None, "use 'async with SitlHarness() as h'"
        overrides = self.pipeline.output.servo_map.overrides_us
        if pulse_us is None:
            overrides.pop(channel, None)
        else:
            overrides[channel] = pulse_us

    @property
    def stats(self) -> LoopStats:
        """Samples, frames and the cost of each pipeline stage."""
        assert self.pipeline is not None, "use 'async with SitlHarness() as h'"
        return self.pipeline.stats

    @property
    def plant(self) -> BoatPlant:
        return self.boat.plant

    @property
    def faults(self) -> SensorFaults:
        return self.boat.faults

    @property
    def launcher(self) -> Launcher:
        return self.boat.launcher

    @property
    def sampler(self) -> Sampler:
        return self.boat.sampler

    @property
    def rc(self) -> RcTransmitter:
        return self.boat.rc

    async def run_for(self, sim_seconds: float) -> None:
        """Advance ``sim_seconds`` of simulated time in lockstep (as fast as possible)."""
        assert self.lockstep is not None, "use 'async with SitlHarness() as h'"
        await self.lockstep.run_for(sim_seconds)
        for task in self._tasks:
            if task.done() and not task.cancelled() and task.exception() is not None:
                raise RuntimeError(f"service {task.get_name()} crashed") from task.exception()

    async def run_until(self, done: Callable[[], bool], max_s: float, step_s: float = 1.0) -> bool:
        """Run in ``step_s`` steps until ``done()`` or ``max_s`` of simulated time; ``done()`` then."""
        for _ in range(math.ceil(max_s / step_s)):
            await self.run_for(step_s)
            if done():
                return True
        return done()

    # -- life cycle -----------------------------------------------------------------------
    async def __aenter__(self) -> SitlHarness:
        if self.transport == "memory":
            sim_gnss, comp_gnss = memory_pipe("sim-gnss", "companion-gnss")
            sim_servo, comp_servo = memory_pipe("sim-servo", "companion-servo")
            links = HardwareLinks(gnss=comp_gnss, servo=comp_servo)
            gnss_out: ByteLink = sim_gnss
            servo_in: ByteLink = sim_servo
        else:
            gnss_pty, servo_pty = PtyPort("sim-gnss"), PtyPort("sim-servo")
            links = HardwareLinks(gnss=SerialLink(gnss_pty.path, 115200, self.clock),
                                  servo=SerialLink(servo_pty.path, 115200, self.clock))
            gnss_out, servo_in = gnss_pty, servo_pty
        self._sim_link = TeeLink(gnss_out, servo_in)
        await self._sim_link.open()
        self.lockstep = Lockstep(self.boat, self.clock, self._sim_link, speedup=self.speedup)
        if self.full_stack:
            self.services = build_companion(self.ctx, links, self.extra_payloads)
            self.pipeline, self.hardware = self.services.pipeline, self.services.hardware
            self._lifecycle = self.services.in_start_order()
        else:
            ctx = self.ctx
            output = ServoOutput(ServoMap(ctx.params), ctx.clock, ctx.bus, LoopStats())
            self.pipeline = Pipeline(bus=ctx.bus, estimator=None, modes=self.driver.update, controller=None,
                                     output=output)
            self.hardware = HardwareIoService(ctx, self.pipeline, links)
            self._lifecycle = [self.hardware]
        try:
            self._tasks = await self._exit_stack.enter_async_context(Application(self._lifecycle).running())
        except BaseException:
            await self.__aexit__(None, None, None)
            raise
        return self

    async def __aexit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                        tb: TracebackType | None) -> None:
        await self._exit_stack.aclose()  # the companion's services, in reverse start order
        if self._sim_link is not None:
            await self._sim_link.close()
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
