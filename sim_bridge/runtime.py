"""Services that run the simulated boat inside ``usv sitl`` and ``usv sim``.

``usv sitl``: :class:`SimulatorService` with in-memory pipes to the companion in the same
process (:attr:`SimulatorService.companion_links` are handed to
:func:`companion.runtime.build_companion`).
``usv sim``: the same boat behind two hardware ports (GPS-INS out, servo frames in; pseudo-
terminals by default, or UDP) for a separate ``usv companion`` with ``sensors.gnss_port`` /
``servos.port`` set to the printed paths.  Lockstep by default (``sim.lockstep``), capped at
``sim.speedup`` x real time (0 = as fast as possible); ``--realtime`` follows the wall clock without waiting.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

from companion.app import BaseService, Context, Service
from companion.clock import SimClock
from companion.config import ConfigError
from companion.hardware import HardwareLinks
from companion.transport import ByteLink, memory_pipe, open_link
from sim_bridge.disturbances import spec_from_strings
from sim_bridge.lockstep import Lockstep
from sim_bridge.ptyport import PtyPort
from sim_bridge.simboat import PHYSICS_STEP_S, SimulatedBoat
from sim_bridge.sitl import TeeLink

__all__ = ["PHYSICS_STEP_S", "SimStatus", "SimulatorService", "StopAfter", "boat_from_config",
           "build_sim_services"]


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


def sim_side_link(spec: str, name: str, clock: SimClock) -> ByteLink:
    """The simulator's end of one hardware port from ``usv sim --gnss-port/--servo-port``.

    ``pty`` (a new pseudo-terminal), ``pty:PATH`` (the same, also published as the stable
    symbolic link PATH), ``udp:HOST:PORT`` (listen there), ``udpout:HOST:PORT`` (send
    there), or ``DEVICE[:BAUD]`` (a real serial port, e.g. a USB adapter for hardware in
    the loop).
    """
    if spec == "pty":
        return PtyPort(name)
    if spec.startswith("pty:"):
        if not spec[4:]:
            raise ConfigError(f"{name}: invalid value {spec!r}; accepted: 'pty', 'pty:PATH', "
                              "'udp:HOST:PORT', 'udpout:HOST:PORT' or 'DEVICE[:BAUD]'")
        try:
            return PtyPort(name, spec[4:])
        except OSError as exc:
            raise ConfigError(f"{name}: cannot create the link {spec[4:]!r}: {exc.strerror or exc}") from None
    return open_link(spec, clock, what=name)


def describe_link(link: ByteLink, spec: str) -> str:
    if isinstance(link, PtyPort):
        return link.path if link.path == link.device else f"{link.path} -> {link.device}"
    return spec


def companion_spec(link: ByteLink, spec: str) -> str:
    """What the companion's ``sensors.gnss_port`` / ``servos.port`` must say to reach ``link``."""
    if isinstance(link, PtyPort):
        return link.path
    if spec.startswith("udpout:"):
        return "udp:" + spec[7:]
    if spec.startswith("udp:"):
        return "udpout:" + spec[4:]
    return "<the serial device wired to " + spec + ">"


class SimulatorService(BaseService):
    """The simulated boat stepping in lockstep with the companion (or paced by the wall clock).

    ``transport="memory"``: in-memory pipes to a companion in the same process (``usv sitl``);
    ``"external"``: the GPS-INS and servo ports given by ``gnss_port`` / ``servo_port``
    (see :func:`sim_side_link`) for a separate ``usv companion`` (``usv sim``).
    """

    name = "simulator"

    def __init__(self, ctx: Context, clock: SimClock, transport: str = "memory", *, gnss_port: str = "pty",
                 servo_port: str = "pty") -> None:
        self.ctx, self.clock, self.transport = ctx, clock, transport
        self.boat = boat_from_config(ctx, clock)
        self.ports: tuple[ByteLink, ByteLink] | None = None
        self.companion_links = HardwareLinks()
        """The companion's ends of the in-memory pipes (``transport="memory"``)."""
        if transport == "memory":
            sim_gnss, comp_gnss = memory_pipe("sim-gnss", "companion-gnss")
            sim_servo, comp_servo = memory_pipe("sim-servo", "companion-servo")
            self.companion_links = HardwareLinks(gnss=comp_gnss, servo=comp_servo)
            self.link: ByteLink = TeeLink(sim_gnss, sim_servo)
        else:
            gnss = sim_side_link(gnss_port, "--gnss-port", clock)
            servo = sim_side_link(servo_port, "--servo-port", clock)
            self.ports = (gnss, servo)
            self.specs = (gnss_port, servo_port)
            self.link = TeeLink(gnss, servo)
        lockstep = bool(ctx.config["sim.lockstep"])
        self.lockstep = Lockstep(self.boat, clock, self.link, lockstep=lockstep,
                                 speedup=float(ctx.config["sim.speedup"]),
                                 wait_for_first_frame=transport == "memory",
                                 ack_timeout_s=2.0 if transport == "memory" else 0.2)

    async def start(self) -> None:
        await self.link.open()
        if self.ports is not None:
            gnss, servo = (describe_link(p, s) for p, s in zip(self.ports, self.specs, strict=True))
            g_cfg, s_cfg = (companion_spec(p, s) for p, s in zip(self.ports, self.specs, strict=True))
            print(f"  GPS-INS serial (XW-GI sentences): {gnss}\n"
                  f"  servo input ($PUSVS frames):      {servo}\n"
                  f"  companion: usv companion with sensors.gnss_port = \"{g_cfg}\", "
                  f"servos.port = \"{s_cfg}\"", flush=True)

    async def run(self) -> None:
        await self.lockstep.run_forever()

    async def stop(self) -> None:
        await self.link.close()


class SimStatus(BaseService):
    """Prints one status line every ``every_s`` of simulated time (``usv sim --status-every``):
    servo frames received (is a companion driving the boat?), missed lockstep answers,
    speed over ground and the latest pulses."""

    name = "sim-status"

    def __init__(self, sim: SimulatorService, every_s: float) -> None:
        self.sim, self.every_s = sim, every_s

    def line(self) -> str:
        boat, ls = self.sim.boat, self.sim.lockstep
        s = boat.plant.state
        pulses = ",".join(str(p) for p in boat.pulses)
        return (f"usv sim: t={boat.t_s:.1f} s servo_frames={boat.frames_received} "
                f"bad_frames={boat.bad_frames} missed_acks={ls.missed_acks} speed={s.speed_mps:.2f} m/s "
                f"north={s.north_m:.2f} m east={s.east_m:.2f} m pulses={pulses}")

    async def run(self) -> None:
        while True:
            await self.sim.clock.sleep(self.every_s)
            print(self.line(), flush=True)


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


def build_sim_services(ctx: Context, clock: SimClock, transport: str = "memory", *, gnss_port: str = "pty",
                       servo_port: str = "pty", status_every_s: float = 0.0) -> list[Service]:
    """The simulator's services in start-up order (they start before the companion's)."""
    sim = SimulatorService(ctx, clock, transport, gnss_port=gnss_port, servo_port=servo_port)
    services: list[Service] = [sim]
    if status_every_s > 0.0:
        services.append(SimStatus(sim, status_every_s))
    return services
