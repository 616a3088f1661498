"""``usv sim``: the simulated boat alone (GPS-INS and servo pseudo-terminals for a separate
companion), or ``usv sim maneuver KIND --out LOG.csv``: an open-loop manoeuvre log."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from companion.app import Application
from companion.clock import SimClock
from companion.commands.common import add_config_argument, add_sim_arguments, config_from_args, run_async
from companion.config import Config

HELP = "run the simulated boat alone, or an open-loop manoeuvre for identification"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_argument(parser)
    add_sim_arguments(parser)
    parser.add_argument("--gnss-port", default="pty", metavar="SPEC",
                        help="GPS-INS output: 'pty' (new pseudo-terminal, path printed), 'pty:PATH' (also "
                             "published as the stable symlink PATH, found again after a restart), "
                             "'udpout:HOST:PORT' (send datagrams there) or 'udp:HOST:PORT'")
    parser.add_argument("--servo-port", default="pty", metavar="SPEC",
                        help="servo frame input: 'pty', 'pty:PATH', 'udp:HOST:PORT' (listen there) or "
                             "'udpout:HOST:PORT'")
    parser.add_argument("--status-every", type=float, default=10.0, metavar="SECONDS",
                        help="print a status line (servo frames received, speed, pulses) every so many "
                             "simulated seconds (0: never; default 10)")
    sub = parser.add_subparsers(dest="sim_action", metavar="ACTION")
    m = sub.add_parser("maneuver", help="open-loop manoeuvre written as a CSV log (README: Log format)")
    m.add_argument("kind", choices=("sine", "zigzag", "turn", "random"))
    m.add_argument("--out", type=Path, required=True, help="CSV log to write")
    m.add_argument("--throttle", type=float, default=0.3, help="throttle 0..1 (default 0.3, chapter Fig. 8)")
    m.add_argument("--amplitude", type=float, default=math.pi / 3,
                   help="nozzle amplitude in rad (default pi/3); zig-zag: also the heading check angle")
    m.add_argument("--period", type=float, default=10.0, help="sine period / random hold scale, s")
    m.add_argument("--duration", type=float, default=60.0, help="manoeuvre duration, s")
    m.add_argument("--warmup", type=float, default=10.0, help="straight run before the manoeuvre, s")
    m.add_argument("--payload", type=float, default=0.0, help="payload mass, kg (0..70)")
    add_sim_arguments(m, with_speedup=False)


async def run_sim(config: Config, gnss_port: str = "pty", servo_port: str = "pty",
                  status_every_s: float = 10.0) -> None:
    from companion.runtime import build_context  # the companion's wiring: import late (CLI start-up)
    from sim_bridge.runtime import build_sim_services

    clock = SimClock()
    ctx = build_context(config, clock)
    services = build_sim_services(ctx, clock, transport="external", gnss_port=gnss_port,
                                  servo_port=servo_port, status_every_s=status_every_s)
    print("usv sim: simulated boat ready; press Ctrl-C to stop", flush=True)
    await Application(services).run()


def run_maneuver_command(args: argparse.Namespace) -> int:
    from sim_bridge.maneuvers import run_maneuver, write_log_csv

    config = config_from_args(args)
    log = run_maneuver(args.kind, throttle=args.throttle, amplitude_rad=args.amplitude, period_s=args.period,
                       duration_s=args.duration, warmup_s=args.warmup, seed=int(config["sim.seed"]),
                       wind=config["sim.wind"], current=config["sim.current"], waves=config["sim.waves"],
                       payload_kg=args.payload)
    try:
        write_log_csv(log, args.out)
    except OSError as exc:
        from companion.cli import UserError

        raise UserError(f"cannot write {args.out}: {exc.strerror or exc}") from None
    print(f"usv sim maneuver: {args.kind}, {len(log)} rows -> {args.out}")
    return 0


def run(args: argparse.Namespace) -> int:
    if getattr(args, "sim_action", None) == "maneuver":
        return run_maneuver_command(args)
    if not args.status_every >= 0.0:
        from companion.cli import UserError

        raise UserError(f"--status-every: invalid value {args.status_every}; accepted: seconds >= 0")
    return run_async(run_sim(config_from_args(args), args.gnss_port, args.servo_port, args.status_every))
