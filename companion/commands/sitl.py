"""``usv sitl``: the simulated boat and the companion in one process."""

from __future__ import annotations

import argparse
from pathlib import Path

from companion.app import Application
from companion.clock import SimClock
from companion.commands.common import add_config_argument, add_sim_arguments, config_from_args, run_async
from companion.config import Config
from companion.runtime import ReadyBanner, build_companion_services, build_context

HELP = "run the simulated boat together with the companion (software in the loop)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_argument(parser)
    add_sim_arguments(parser)
    parser.add_argument("--duration", type=float, default=None,
                        help="stop after this many seconds of simulated time")
    parser.add_argument("--truth-log", type=Path, default=None, metavar="FILE.csv",
                        help="write the simulated boat's true position (20 Hz of simulated time) to this CSV "
                             "(for benchmarks; see sim_bridge/truthlog.py)")


async def run_sitl(config: Config, duration_s: float | None = None, truth_log: Path | None = None) -> None:
    from sim_bridge.runtime import build_sim_services

    clock = SimClock()
    ctx = build_context(config, clock)
    sim_services = build_sim_services(ctx, clock)
    if truth_log is not None:
        from sim_bridge.simboat import SimulatedBoat
        from sim_bridge.truthlog import TruthLog

        boat = ctx.extras["sim_boat"]
        assert isinstance(boat, SimulatedBoat)
        sim_services.append(TruthLog(boat, clock, truth_log))
    app = Application(sim_services + build_companion_services(ctx))
    app.add(ReadyBanner(ctx, "usv sitl: simulated boat + companion"))
    if duration_s is not None:
        from sim_bridge.runtime import StopAfter

        app.add(StopAfter(clock, duration_s, app.request_stop))
    await app.run()


def run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    return run_async(run_sitl(config, args.duration, args.truth_log))
