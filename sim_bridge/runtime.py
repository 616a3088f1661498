"""Services that run the simulated boat inside ``usv sitl`` and ``usv sim``.

``usv sitl``: :class:`SimulatorService` with in-memory pipes to the companion in the same
process (the companion's links are put in ``ctx.extras`` before its services are built).
``usv sim``: the same boat behind two pseudo-terminals (GPS-INS out, servo frames in) for a
separate ``usv companion`` with ``sensors.gnss_port`` / ``servos.port`` set to the printed
paths.  Lockstep by default (``sim.lockstep``), capped at ``sim.speedup`` x real time
(0 = as fast as possible); ``--realtime`` follows the wall clock without waiting.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

from companion.app import BaseService, Context, Service
from companion.clock import SimClock
from companion.config import ConfigError
from companion.loop import GNSS_LINK_KEY, SERVO_LINK_KEY
from companion.transport import ByteLink, memory_pipe
from sim_bridge.disturbances import spec_from_strings
from sim_bridge.lockstep import Lockstep
from sim_bridge.ptyport import PtyPort
from sim_bridge.simboat import PHYSICS_STEP_S, SimulatedBoat
from sim_bridge.sitl import TeeLink

__all__ = ["PHYSICS_STEP_S", "SimulatorService", "StopAfter", "boat_from_config", "build_sim_services"]


def parse_home(text: str) -> tuple[float, float, float]:
    accepted = "'LAT_DEG,LON_DEG,HEADING_DEG'"
    try:
        lat, lon, hdg = (float(x) for x in str(text).split(","))
    except ValueError:
        raise ConfigError(f"sim.home: invalid value {text!r}; accepted: {accepted}") from None
    if not (-89.0 <= lat <= 89.0 and -180.0 <= lon <= 180.0 and math.isfinite(hdg)):
        raise ConfigError(f"sim.home: invalid value {text!r}; accepted: {accepted}")
    return lat, lon, hdg


def boat_from_config(ctx: Context, clock: SimClock) -> SimulatedBoat:
    cfg = ctx.config
    spec = spec_from_strings(cfg["sim.wind"], cfg["sim.current"], cfg["sim.waves"])
    lat, lon, hdg = parse_home(cfg["sim.home"])
    return SimulatedBoat(seed=int(cfg["sim.seed"]), disturbances=spec, home_lat_deg=lat, home_lon_deg=lon,
                         psi0_rad=math.radians(hdg), start_unix_s=clock.unix_time_s())


class SimulatorService(BaseService):
    """The simulated boat stepping in lockstep with the companion (or paced by the wall clock)."""

    name = "simulator"

    def __init__(self, ctx: Context, clock: SimClock, transport: str = "memory") -> None:
        self.ctx, self.clock, self.transport = ctx, clock, transport
        self.boat = boat_from_config(ctx, clock)
        ctx.extras["sim_boat"] = self.boat
        self.ptys: tuple[PtyPort, PtyPort] | None = None
        if transport == "memory":
            sim_gnss, comp_gnss = memory_pipe("sim-gnss", "companion-gnss")
            sim_servo, comp_servo = memory_pipe("sim-servo", "companion-servo")
            ctx.extras[GNSS_LINK_KEY], ctx.extras[SERVO_LINK_KEY] = comp_gnss, comp_servo
            self.link: ByteLink = TeeLink(sim_gnss, sim_servo)
        else:
            self.ptys = (PtyPort("sim-gnss"), PtyPort("sim-servo"))
            self.link = TeeLink(*self.ptys)
        lockstep = bool(ctx.config["sim.lockstep"])
        self.lockstep = Lockstep(self.boat, clock, self.link, lockstep=lockstep,
                                 speedup=float(ctx.config["sim.speedup"]),
                                 wait_for_first_frame=transport == "memory",
                                 ack_timeout_s=2.0 if transport == "memory" else 0.2)

    async def start(self) -> None:
        await self.link.open()
        if self.ptys is not None:
            print(f"  GPS-INS serial (XW-GI sentences): {self.ptys[0].path}\n"
                  f"  servo input ($PUSVS frames):      {self.ptys[1].path}\n"
                  f"  companion: usv companion with sensors.gnss_port = \"{self.ptys[0].path}\", "
                  f"servos.port = \"{self.ptys[1].path}\"", flush=True)

    async def run(self) -> None:
        await self.lockstep.run_forever()

    async def stop(self) -> None:
        await self.link.close()


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


def build_sim_services(ctx: Context, clock: SimClock, transport: str = "memory") -> list[Service]:
    """The simulator's services in start-up order (they start before the companion's)."""
    return [SimulatorService(ctx, clock, transport)]
