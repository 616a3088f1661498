"""``usv samples``: the durable water-sample log, exported as CSV or GeoJSON.

Reads ``<state_dir>/samples.sqlite`` read-only, so it is safe while the companion runs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from companion.commands.common import add_config_argument, config_from_args
from companion.payloads.samplelog import SAMPLE_LOG_NAME, SampleLog, export_csv, export_geojson

HELP = "export the water-sample log (time, position, bottle, volume, mission item, distance)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    exp = sub.add_parser("export", help="write the sample log as CSV or GeoJSON")
    exp.add_argument(
        "--format", choices=("csv", "geojson"), default="csv", help="output format (default csv)"
    )
    exp.add_argument("--output", "-o", type=Path, default=None, help="output file (default: standard output)")
    exp.add_argument(
        "--status",
        default="complete",
        help="which samples: complete (default), failed, aborted, interrupted, filling or all",
    )
    exp.add_argument(
        "--db", type=Path, default=None, help=f"sample log file (default: <state_dir>/{SAMPLE_LOG_NAME})"
    )
    add_config_argument(exp)


def run(args: argparse.Namespace) -> int:
    from companion.cli import UserError

    path = args.db or config_from_args(args).state_dir() / SAMPLE_LOG_NAME
    try:
        samplelog = SampleLog(path, readonly=True)
    except FileNotFoundError as exc:
        raise UserError(str(exc)) from None
    try:
        records = samplelog.samples(None if args.status == "all" else args.status)
    except Exception as exc:  # sqlite3.DatabaseError: not a sample log / unreadable
        raise UserError(f"cannot read sample log {path}: {exc}") from None
    finally:
        samplelog.close()
    text = export_csv(records) if args.format == "csv" else export_geojson(records)
    if args.output is None:
        sys.stdout.write(text)
    else:
        args.output.write_text(text, encoding="utf-8")
        print(f"wrote {len(records)} sample(s) to {args.output}", file=sys.stderr)
    return 0
