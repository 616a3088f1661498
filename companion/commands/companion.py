"""``usv companion``: the companion alone, for a real boat, configured from a TOML file."""

from __future__ import annotations

import argparse

from companion.app import Application
from companion.clock import WallClock
from companion.commands.common import add_config_argument, add_mqtt_argument, config_from_args, run_async
from companion.config import Config
from companion.statelock import StateDirLock

HELP = "run the companion alone against real hardware (GPS-INS and servo serial ports)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_config_argument(parser)
    add_mqtt_argument(parser)


async def run_companion(config: Config) -> None:
    from companion.runtime import ReadyBanner, build_companion, build_context  # the whole stack: import late

    with StateDirLock(config.state_dir()):  # one instance per state directory (exit 2 otherwise)
        clock = WallClock()
        ctx = build_context(config, clock)
        built = build_companion(ctx)
        services = built.in_start_order()
        services.append(ReadyBanner(ctx, f"usv companion ({config.source})", built.links))
        await Application(services).run()


def run(args: argparse.Namespace) -> int:
    return run_async(run_companion(config_from_args(args)))
