"""Arguments and set-up shared by the subcommands that run the vehicle."""

from __future__ import annotations

import argparse
import asyncio
import logging
from pathlib import Path
from typing import Any

from companion.config import Config, load_config
from companion.param_table import all_param_defs

log = logging.getLogger(__name__)


def add_config_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", "-c", type=Path, default=None,
                        help="TOML configuration file (default: embedded SITL defaults)")
    parser.add_argument("--state-dir", default=None,
                        help="directory for parameters, missions and logs (overrides vehicle.state_dir)")


def add_mqtt_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--mqtt", default=None, metavar="URL",
                        help="publish telemetry, records and events to this MQTT broker "
                             "(mqtt://HOST[:PORT] or mqtts://...; sets [mqtt] url)")


def add_sim_arguments(parser: argparse.ArgumentParser, *, with_speedup: bool = True) -> None:
    """The disturbance flags shared by ``usv sitl``, ``usv sim`` and ``usv sim maneuver``."""
    parser.add_argument("--wind", default=None, metavar="SPEED_MPS,FROM_DEG",
                        help="mean wind speed and the direction it blows FROM (meteorological)")
    parser.add_argument("--current", default=None, metavar="SPEED_MPS,TOWARD_DEG[,VAR]",
                        help="current speed and the direction it flows TOWARD (oceanographic); VAR in "
                             "[0, 1] makes it slowly varying (spread VAR*SPEED m/s and VAR rad, ~2 min)")
    parser.add_argument("--waves", default=None, metavar="HS_M[,TP_S]",
                        help="significant wave height and peak period")
    parser.add_argument("--seed", type=int, default=None, help="random seed (disturbances, sensor noise)")
    if with_speedup:
        parser.add_argument("--speedup", type=float, default=None,
                            help="cap on speed relative to real time (0: as fast as possible)")
        parser.add_argument("--realtime", action="store_true",
                            help="follow the wall clock instead of lockstep (for people and QGC)")


def config_from_args(args: argparse.Namespace) -> Config:
    """Load the config file and apply command-line overrides (all validated)."""
    config = load_config(getattr(args, "config", None), all_param_defs())
    overrides: dict[str, Any] = {}
    for flag, key in (("wind", "sim.wind"), ("current", "sim.current"), ("waves", "sim.waves"),
                      ("seed", "sim.seed"), ("speedup", "sim.speedup"), ("state_dir", "vehicle.state_dir"),
                      ("signing_key", "security.signing_key_file"), ("mqtt", "mqtt.url")):
        value = getattr(args, flag, None)
        if value is not None:
            overrides[key] = str(value) if isinstance(value, Path) else value
    if getattr(args, "realtime", False):
        overrides["sim.lockstep"] = False
        overrides.setdefault("sim.speedup", 1.0)
    if overrides:
        config = config.with_overrides(overrides)
    return config


def run_async(coro: Any) -> int:
    """Run the application's coroutine and check that it left no task behind."""

    async def main() -> None:
        await coro
        leftover = [t for t in asyncio.all_tasks() if t is not asyncio.current_task() and not t.done()]
        for task in leftover:
            log.warning("task %s still running after shutdown; cancelling", task.get_name())
            task.cancel()

    try:
        asyncio.run(main())
    except KeyboardInterrupt:
        return 130
    return 0
