"""``usv bench``: run every benchmark and print one JSON object."""

from __future__ import annotations

import argparse
import importlib
import inspect
import json
import platform
import sys
import time
from typing import Any

from benchmarks import BENCHMARKS

HELP = "run the benchmarks and print every figure as one JSON object"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help="run only these benchmarks (same as --only), e.g. 'usv bench nav'")
    parser.add_argument("--quick", action="store_true", help="short runs (for smoke tests)")
    parser.add_argument("--only", action="append", default=None, choices=sorted(BENCHMARKS),
                        help="run only this benchmark (repeatable)")
    parser.add_argument("--out", default=None, help="also write the JSON to this file")
    parser.add_argument("--plots", default=None, metavar="DIR",
                        help="write PNG plots (benchmarks that make them, e.g. nav: its worst runs) to DIR")


def run_benchmarks(names: list[str], quick: bool, plots_dir: str | None = None) -> dict[str, Any]:
    result: dict[str, Any] = {
        "meta": {
            "python": platform.python_version(),
            "machine": platform.machine(),
            "quick": quick,
            "unix_time_s": round(time.time(), 3),
        },
        "benchmarks": {},
    }
    for name in names:
        module = importlib.import_module(BENCHMARKS[name])
        t0 = time.perf_counter()
        try:
            if plots_dir is not None and "plots_dir" in inspect.signature(module.run).parameters:
                figures = module.run(quick, plots_dir=plots_dir)
            else:
                figures = module.run(quick)
        except Exception as exc:  # one broken benchmark must not hide the others
            figures = {"error": f"{type(exc).__name__}: {exc}"}
        figures["wall_time_s"] = round(time.perf_counter() - t0, 3)
        result["benchmarks"][name] = figures
        print(f"bench {name}: done in {figures['wall_time_s']} s", file=sys.stderr, flush=True)
    return result


def run(args: argparse.Namespace) -> int:
    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        print(f"usv bench: unknown benchmark {unknown[0]!r}; choose from {', '.join(sorted(BENCHMARKS))}",
              file=sys.stderr)
        return 2
    names = [*args.names, *(args.only or [])] or list(BENCHMARKS)
    result = run_benchmarks(names, args.quick, args.plots)
    text = json.dumps(result, indent=2, sort_keys=False)
    print(text)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    return 1 if any("error" in f for f in result["benchmarks"].values()) else 0
