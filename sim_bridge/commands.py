"""``usv sim``: the simulated boat alone (its hardware interfaces for a separate companion)."""

from __future__ import annotations

import argparse

from companion.app import Application
from companion.clock import SimClock
from companion.commands.common import add_config_argument, add_sim_arguments, config_from_args, run_async
from companion.config import Config
from companion.runtime import build_context

HELP = "run the simulated boat alone, or an open-loop manoeuvre for identification"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_argument(parser)
    add_sim_arguments(parser)


async def run_sim(config: Config) -> None:
    from sim_bridge.runtime import build_sim_services

    clock = SimClock()
    ctx = build_context(config, clock)
    print("usv sim: simulated boat ready; press Ctrl-C to stop", flush=True)
    await Application(build_sim_services(ctx, clock)).run()


def run(args: argparse.Namespace) -> int:
    return run_async(run_sim(config_from_args(args)))
