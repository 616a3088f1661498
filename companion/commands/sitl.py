"""``usv sitl``: the simulated boat and the companion in one process."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from companion.app import Application
from companion.clock import SimClock
from companion.commands.common import (
    add_config_argument,
    add_mqtt_argument,
    add_sim_arguments,
    config_from_args,
    run_async,
)
from companion.config import Config, ConfigError
from companion.mqtt.broker import DEFAULT_EMBEDDED_PORT, EmbeddedBroker
from companion.statelock import StateDirLock

HELP = "run the simulated boat together with the companion (software in the loop)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_argument(parser)
    add_sim_arguments(parser)
    parser.add_argument("--signing-key", type=Path, default=None, metavar="FILE",
                        help="MAVLink 2 signing key file (64 hex characters, chmod 600); sets "
                             "[security] signing_key_file")
    add_mqtt_argument(parser)
    parser.add_argument("--mqtt-embedded", type=int, nargs="?", const=DEFAULT_EMBEDDED_PORT, default=None,
                        metavar="PORT",
                        help="start an MQTT broker (amqtt) on 127.0.0.1:PORT (default "
                             f"{DEFAULT_EMBEDDED_PORT}) and publish to it, unless --mqtt names another one")
    parser.add_argument("--status-every", type=float, default=10.0, metavar="SECONDS",
                        help="print a status line (simulated boat, the companion's mode and its "
                             "water-current estimate) every so many simulated seconds (0: never; default 10)")
    parser.add_argument("--duration", type=float, default=None,
                        help="stop after this many seconds of simulated time")
    parser.add_argument("--fault", action="append", default=[], metavar="KIND@START[-END]",
                        help="inject a GPS-INS fault in the simulator from START to END simulated seconds "
                             "(gps_outage, silent, gyro_stuck, frozen, nan_velocity, imu_silent); repeatable")
    parser.add_argument("--truth-log", type=Path, default=None, metavar="FILE.csv",
                        help="write the simulated boat's true position (20 Hz of simulated time) to this CSV "
                             "(for benchmarks; see sim_bridge/truthlog.py)")


async def run_sitl(config: Config, duration_s: float | None = None, truth_log: Path | None = None,
                   faults: Sequence[str] = (), broker: EmbeddedBroker | None = None,
                   status_every_s: float = 0.0) -> None:
    with StateDirLock(config.state_dir()):  # one instance per state directory (exit 2 otherwise)
        if broker is not None:
            await broker.start()  # before the companion: a port in use is a one-line error (exit 2)
        try:
            await _run_sitl(config, duration_s, truth_log, faults, status_every_s)
        finally:
            if broker is not None:
                await broker.stop()


async def _run_sitl(config: Config, duration_s: float | None, truth_log: Path | None,
                    faults: Sequence[str], status_every_s: float) -> None:
    from companion.runtime import ReadyBanner, build_companion, build_context  # the whole stack: import late
    from sim_bridge.runtime import SimulatorService

    clock = SimClock()
    ctx = build_context(config, clock)
    sim = SimulatorService(ctx, clock)  # the simulated boat, in-memory pipes to the companion
    services = build_companion(ctx, sim.companion_links)
    app = Application([sim, *services.in_start_order()])
    if truth_log is not None:
        from sim_bridge.truthlog import TruthLog

        app.add(TruthLog(sim.boat, clock, truth_log))
    app.add(ReadyBanner(ctx, "usv sitl: simulated boat + companion", services.links))
    if faults:
        from sim_bridge.faults import FaultSchedule, parse_fault

        app.add(FaultSchedule(sim.boat.faults, clock, [parse_fault(text) for text in faults]))
    if status_every_s > 0.0:
        from companion.commands.sitl_status import SitlStatus

        app.add(SitlStatus(sim, ctx.bus, services.vehicle, status_every_s))
    if duration_s is not None:
        from sim_bridge.runtime import StopAfter

        app.add(StopAfter(clock, duration_s, app.request_stop))
    await app.run()


def run(args: argparse.Namespace) -> int:
    if not args.status_every >= 0.0:
        from companion.cli import UserError

        raise UserError(f"--status-every must be 0 or more seconds, got {args.status_every:g}")
    config = config_from_args(args)
    if args.fault:  # refuse a bad schedule before anything starts
        from sim_bridge.faults import parse_fault

        for text in args.fault:
            parse_fault(text)
    broker = None
    if args.mqtt_embedded is not None:
        if not 1 <= args.mqtt_embedded <= 65535:
            raise ConfigError(f"--mqtt-embedded: invalid port {args.mqtt_embedded}; accepted: 1..65535")
        broker = EmbeddedBroker(args.mqtt_embedded)
        if not config["mqtt.url"]:
            config = config.with_overrides({"mqtt.url": broker.url})
    return run_async(run_sitl(config, args.duration, args.truth_log, args.fault, broker,
                              args.status_every))
