"""``usv campaign``: Monte-Carlo campaigns of missions and manoeuvres (``run``) and their report."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "Monte-Carlo SITL campaigns across currents, wind, waves and seeds on Dask: run, report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    run = sub.add_parser("run", help="run a campaign file's runs (resumes: finished runs are kept)")
    run.add_argument("file", type=Path, help="campaign file (TOML), e.g. campaigns/sampling_in_current.toml")
    run.add_argument("--runs", type=int, required=True, metavar="N", help="runs 0..N-1")
    run.add_argument("--out", type=Path, required=True, metavar="DIR",
                     help="results directory (results.csv, tracks/); rerunning into it resumes")
    run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                     help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: a local cluster)")
    run.add_argument("--workers", type=int, default=None, metavar="N",
                     help="local cluster: worker processes (default: one per core; ignored with --scheduler)")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    rep = sub.add_parser("report", help="Markdown summary with PNG plots of a campaign's results")
    rep.add_argument("dir", type=Path, metavar="DIR", help="results directory of 'usv campaign run'")
    rep.add_argument("--out", type=Path, required=True, metavar="REPORT",
                     help="Markdown file to write; the plots go beside it")


def run(args: argparse.Namespace) -> int:
    if args.action == "report":
        from sim_bridge.campaign.report import write_report

        summary = write_report(args.dir, args.out)
        print(f"usv campaign report: {summary['runs']} runs, {summary['successes']} succeeded; "
              f"wrote {args.out} and {len(summary['plots'])} plot(s)", file=sys.stderr)
        return 0
    from sim_bridge.campaign.runner import run_campaign

    o = run_campaign(args.file, args.runs, args.out, scheduler=args.scheduler, workers=args.workers,
                     progress=not args.no_progress)
    rate = o.sim_s / o.wall_s if o.wall_s > 0 else 0.0
    print(f"usv campaign run: {o.ran} run(s) done now ({o.successes} succeeded), {o.already_done} were "
          f"already done, {o.lost} lost; {o.sim_s} simulated s in {o.wall_s} wall s ({rate:.1f}x, "
          f"{'batch plant' if o.batch else f'{o.workers} worker(s)'})", file=sys.stderr)
    return 1 if o.lost else 0
