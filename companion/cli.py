"""The ``usv`` command line.

Each subcommand lives in its own module (``companion/commands/*.py`` or a package's
``commands`` module) exposing ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``;
adding a subcommand is one module plus one line in :data:`COMMANDS`.  Modules are imported
lazily so ``usv --help`` stays fast.  Expected errors (bad configuration, unreadable
files, a state directory held by another instance) are printed as one line and exit with
status 2; no traceback reaches the operator.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from companion.config import ConfigError
from companion.statelock import StateDirBusy

COMMANDS: dict[str, str] = {
    "sitl": "companion.commands.sitl",
    "companion": "companion.commands.companion",
    "sim": "sim_bridge.commands",
    "bench": "benchmarks.cli",
    "params": "companion.commands.params",
    "samples": "companion.commands.samples",
    "identify": "companion.commands.identify",
    "campaign": "sim_bridge.campaign.commands",
}
"""Subcommand name -> module implementing it."""


class UserError(Exception):
    """An error the user can fix; printed as one line without a traceback."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="usv", description="Flood-rescue USV companion: MAVLink vehicle, SITL, identification."
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv: debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(module_name)
        sp = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(sp)
        sp.set_defaults(_module=module)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        return int(args._module.run(args) or 0)
    except (ConfigError, UserError, StateDirBusy) as exc:
        print(f"usv {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
