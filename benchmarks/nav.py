"""``usv bench --only nav``: the product flown over MAVLink, across a grid of currents and weather.

Every cell is a separate ``usv sitl`` process with default parameters, in lockstep at
:data:`~benchmarks.nav_flight.SITL_SPEEDUP` x real time, flown by a pymavlink ground station in the
benchmark's worker process (:mod:`benchmarks.nav_flight`, :mod:`benchmarks.nav_gcs`): GUIDED go-to,
LOITER 120 s, RTL, a 50 m AUTO square and a four-point sampling mission.  Figures come from the
simulator's truth log (:mod:`benchmarks.nav_metrics`).  Reported: the worst value of every figure
over the grid with the cell it came from, the issue's targets with pass/fail, ArduRover's figures
from the issue as labelled reference, every cell's figures (``cells``), the issue's own two runs
(``issue_cases``, not in the worst case), and, in full runs, the same two cells flown twice
(``repeatability``: the spread that ground-station timing leaves in the figures).
Cells run :data:`WORKERS` at a time.  ``quick``: the reduced grid only (the hardest cells).
This is the product; ``control`` is the rig (controllers on the plant, no MAVLink, no modes).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from benchmarks.nav_flight import ARRIVAL_HOLD_S, LOITER_S, SITL_SPEEDUP, Cell, run_cell
from benchmarks.nav_gcs import GCS_HEARTBEAT_PERIOD_WALL_S, GPI_RATE_HZ
from benchmarks.nav_grid import (
    ARDUROVER_REFERENCE,
    ISSUE_CASES,
    REPORTING_SEEDS,
    TUNING_SEEDS,
    WEATHER_SLOTS,
    full_grid,
    reduced_grid,
    targets,
)
from benchmarks.nav_metrics import figures

WORKERS = 2
"""Cells flown at once (one ``usv sitl`` process and one ground station each; the machine has 2 cores)."""

FIGURES = ("loiter_max_m", "loiter_rms_m", "goto_overshoot_m", "goto_after_arrival_max_m", "rtl_overshoot_m",
           "rtl_after_arrival_max_m", "square_side_max_m", "square_mid_leg_rms_m", "square_mid_leg_max_m",
           "circle_error_max_m", "circle_error_rms_m", "sample_distance_max_m", "fill_distance_max_m")
"""Flat figure names (all metres, lower is better)."""


def idle_creep_mps() -> float:
    """Speed the simulated jet makes at idle throttle in calm water (it cannot stop: no reverse)."""
    from sim_bridge.plant import BoatPlant

    plant = BoatPlant()
    for _ in range(9000):
        plant.step(0.01, 0.0, 0.0, True)
    return round(plant.state.speed_mps, 2)


def flat(fig: dict[str, Any]) -> dict[str, float]:
    """One cell's figures as ``FIGURES`` (plus samples_taken)."""
    sq, smp = fig["square"], fig["sampling"]
    return {"loiter_max_m": fig["loiter"]["max_m"], "loiter_rms_m": fig["loiter"]["rms_m"],
            "goto_overshoot_m": fig["goto_arrival"]["overshoot_m"],
            "goto_after_arrival_max_m": fig["goto_arrival"]["after_arrival_max_m"],
            "rtl_overshoot_m": fig["rtl_arrival"]["overshoot_m"],
            "rtl_after_arrival_max_m": fig["rtl_arrival"]["after_arrival_max_m"],
            "square_side_max_m": sq["side_max_m"], "square_mid_leg_rms_m": sq["mid_leg_rms_m"],
            "square_mid_leg_max_m": sq["mid_leg_max_m"], "circle_error_max_m": smp["circle_error_max_m"],
            "circle_error_rms_m": smp["circle_error_rms_m"],
            "sample_distance_max_m": smp["sample_distance_max_m"],
            "fill_distance_max_m": smp["fill_distance_max_m"],
            "samples_taken": smp["samples_taken"]}


def fly_and_measure(cell: Cell, workdir: Path, keep_truth: bool) -> dict[str, Any]:
    """Worker: fly one cell and compute its figures (the truth log is kept only for plots)."""
    flight = run_cell(cell, workdir)
    out: dict[str, Any] = {"name": cell.name, "cell": asdict(cell), "error": flight.error,
                           "wall_s": flight.wall_s, "sim_s": flight.sim_s, "sitl_cpu_s": flight.sitl_cpu_s,
                           "gcs_cpu_s": flight.gcs_cpu_s, "params": flight.params}
    if flight.error is None:
        try:
            out["figures"] = figures(flight.to_json())
            out["flat"] = flat(out["figures"])
        except (LookupError, ValueError) as exc:
            out["error"] = f"figures: {exc}"
    if keep_truth:
        out["flight"] = {k: v for k, v in flight.to_json().items() if k != "positions"}
        (workdir / "result.json").write_text(json.dumps(out), encoding="utf-8")
    else:
        shutil.rmtree(workdir, ignore_errors=True)
    return out


def fly_all(cells: list[Cell], root: Path, keep_truth: bool, tag: str = "") -> list[dict[str, Any]]:
    """Fly ``cells`` ``WORKERS`` at a time (spawned worker processes); results in the cells' order."""
    results: list[dict[str, Any] | None] = [None] * len(cells)
    with ProcessPoolExecutor(max_workers=WORKERS, mp_context=get_context("spawn")) as pool:
        futures = {pool.submit(fly_and_measure, c, root / f"{tag}cell{i:03d}", keep_truth): i
                   for i, c in enumerate(cells)}
        for done, fut in enumerate(as_completed(futures), start=1):
            i = futures[fut]
            try:
                results[i] = fut.result()
            except Exception as exc:  # a broken worker must not lose the other cells
                results[i] = {"name": cells[i].name, "cell": asdict(cells[i]),
                              "error": f"{type(exc).__name__}: {exc}"}
            r = results[i]
            assert r is not None
            print(f"bench nav: {done}/{len(cells)} {r['name']}: "
                  f"{r.get('error') or 'ok'} ({r.get('wall_s', '?')} s)", file=sys.stderr, flush=True)
    return [r for r in results if r is not None]


def worst(results: list[dict[str, Any]], creep_mps: float) -> dict[str, dict[str, Any]]:
    """Worst value of every figure over the cells that flew, with the cell's name; LOITER also split
    by whether the current was stronger than the jet's idle creep."""
    out: dict[str, dict[str, Any]] = {}

    def consider(name: str, value: float, r: dict[str, Any]) -> None:
        if name not in out or not value <= out[name]["value"]:  # NaN/inf count as worst
            out[name] = {"value": value, "cell": r["name"]}

    for r in results:
        if "flat" not in r:
            continue
        for name in FIGURES:
            consider(name, r["flat"][name], r)
        side = "above" if r["cell"]["current_mps"] > creep_mps else "below"
        consider(f"loiter_max_m_current_{side}_creep", r["flat"]["loiter_max_m"], r)
        taken = r["flat"]["samples_taken"]
        if "samples_taken_min" not in out or taken < out["samples_taken_min"]["value"]:
            out["samples_taken_min"] = {"value": taken, "cell": r["name"]}
    return out


def judge(worst_figs: dict[str, dict[str, Any]], params: dict[str, float],
          errors: list[str]) -> dict[str, Any]:
    """The issue's targets against the worst case, figure by figure."""
    circle = max(params.get("USV_SMPL_CIRC_M", math.nan), params.get("USV_TURN_RAD", math.nan))
    table: dict[str, Any] = {}
    for t in targets(params.get("USV_TURN_RAD", math.nan), circle):
        w = worst_figs.get(t.figure)
        value = w["value"] if w else math.nan
        table[t.figure] = {"worst": value, "target_max": round(t.limit_m, 3),
                           "pass": bool(value <= t.limit_m), "cell": w["cell"] if w else None,
                           "target": t.text}
    taken = worst_figs.get("samples_taken_min", {}).get("value", 0)
    table["samples_taken_min"] = {"worst": taken, "target_min": 4, "pass": taken >= 4,
                                  "target": "all four bottles filled in every cell"}
    return {"figures": table, "all_met": all(v["pass"] for v in table.values()) and not errors,
            "cells_with_errors": len(errors)}


def spread(cells: list[dict[str, Any]], again: list[dict[str, Any]]) -> dict[str, Any]:
    """Largest difference of every figure between two flights of the same cell (matched by name)."""
    first = {r["name"]: r for r in cells}
    pairs = [(first[r["name"]], r) for r in again if r["name"] in first]
    out: dict[str, Any] = {"cells": [b["name"] for _, b in pairs]}
    for name in FIGURES:
        diffs = [abs(a["flat"][name] - b["flat"][name]) for a, b in pairs if "flat" in a and "flat" in b]
        out[name] = round(max(diffs), 3) if diffs else None
    out["pairs"] = [[a.get("flat"), b.get("flat")] for a, b in pairs]
    return out


def cost(results: list[dict[str, Any]]) -> dict[str, float]:
    """What the flights cost: simulated seconds and CPU seconds (timing figures, noisy when shared)."""
    sim = sum(r.get("sim_s", 0.0) for r in results)
    sitl = sum(r.get("sitl_cpu_s", 0.0) for r in results)
    gcs = sum(r.get("gcs_cpu_s", 0.0) for r in results)
    return {"flights": len(results), "sim_s_total": round(sim, 1), "sitl_cpu_s_total": round(sitl, 1),
            "gcs_cpu_s_total": round(gcs, 1), "sim_s_per_sitl_cpu_s": round(sim / sitl, 1) if sitl else 0.0}


def cells_to_fly(quick: bool, seeds: tuple[int, ...]) -> tuple[list[Cell], list[Cell], list[Cell]]:
    """The grid, the cells flown a second time (repeatability) and the issue's own cases."""
    grid = reduced_grid(seeds) if quick else full_grid(seeds)
    repeat = [] if quick else reduced_grid(seeds)[:2]
    issue = [] if quick or seeds != REPORTING_SEEDS else list(ISSUE_CASES)
    return grid, repeat, issue


def run(quick: bool, plots_dir: Path | str | None = None, seeds: tuple[int, ...] = REPORTING_SEEDS,
        keep_dir: Path | str | None = None) -> dict[str, Any]:
    """The grid (``quick``: the reduced one), figures, targets; ``plots_dir``: PNGs of the worst runs;
    ``keep_dir``: keep every flight there (truth log, ground-station timeline) for :func:`reanalyse`."""
    t0 = time.perf_counter()
    grid, repeat, issue = cells_to_fly(quick, seeds)
    root = Path(keep_dir) if keep_dir is not None else Path(tempfile.mkdtemp(prefix="usv-bench-nav-"))
    try:
        keep = plots_dir is not None or keep_dir is not None
        results = fly_all(grid + repeat + issue, root, keep_truth=keep)
        if keep_dir is not None:
            (root / "results.json").write_text(json.dumps(results), encoding="utf-8")
        out = report(results, len(grid), len(repeat), quick, seeds, plots_dir)
        out["wall_s"] = round(time.perf_counter() - t0, 1)
        return out
    finally:
        if keep_dir is None:
            shutil.rmtree(root, ignore_errors=True)


def reanalyse(keep_dir: Path, quick: bool, seeds: tuple[int, ...],
              plots_dir: Path | str | None) -> dict[str, Any]:
    """The report of flights kept by ``run(keep_dir=...)``, figures recomputed from their truth logs."""
    results = json.loads((Path(keep_dir) / "results.json").read_text(encoding="utf-8"))
    for r in results:
        if "flight" in r and not r["flight"].get("error"):
            r["figures"] = figures(r["flight"])
            r["flat"] = flat(r["figures"])
    grid, repeat, _ = cells_to_fly(quick, seeds)
    return report(results, len(grid), len(repeat), quick, seeds, plots_dir)


def report(results: list[dict[str, Any]], n_grid: int, n_repeat: int, quick: bool, seeds: tuple[int, ...],
           plots_dir: Path | str | None) -> dict[str, Any]:
    """Worst case, targets, reference, cells, repeatability, issue cases and cost of the flights."""
    creep = idle_creep_mps()
    cells, again, issue_res = results[:n_grid], results[n_grid:n_grid + n_repeat], results[n_grid + n_repeat:]
    errors = [f"{r['name']}: {r['error']}" for r in cells if r.get("error")]
    params: dict[str, float] = next((r["params"] for r in cells if r.get("params")), {})
    worst_figs = worst(cells, creep)
    out: dict[str, Any] = {
        "what": "the product: usv sitl (default parameters) flown over MAVLink UDP by a pymavlink ground "
                "station in another process; not the rig (that is 'control')",
        "method": {
            "positions": "simulator truth (usv sitl --truth-log, 20 Hz of simulated time); telemetry "
                         "only cross-checked (telemetry_vs_truth_rms_m per cell)",
            "sitl_speedup": SITL_SPEEDUP, "gcs_heartbeat_period_wall_s": GCS_HEARTBEAT_PERIOD_WALL_S,
            "global_position_int_hz": GPI_RATE_HZ, "arrival_hold_s": ARRIVAL_HOLD_S, "loiter_s": LOITER_S,
            "workers": WORKERS, "idle_creep_mps": creep,
            "weather_slots": [asdict(w) for w in WEATHER_SLOTS],
            "script": "arm; GUIDED go-to 30 m N 30 m E, 30 s there; LOITER 120 s; RTL, 30 s there; "
                      "AUTO: 50 m square then four USV_CMD_NAV_SAMPLE_HERE items (default radius, bottle "
                      "and fill time)"},
        "seeds": {"reporting": list(seeds), "tuning": list(TUNING_SEEDS),
                  "note": "figures come from the reporting seeds only; tune on the tuning seeds "
                          "(python -m benchmarks.nav --seeds tuning)"},
        "quick": quick, "cells_flown": len(cells), "errors": errors,
        "worst": worst_figs, "targets": judge(worst_figs, params, errors),
        "ardurover_reference": ARDUROVER_REFERENCE,
        "cells": [{k: v for k, v in r.items() if k not in ("flat", "params", "flight")} for r in cells],
    }
    if again:
        out["repeatability"] = spread(cells, again)
    if issue_res:
        out["issue_cases"] = [{k: v for k, v in r.items() if k not in ("params", "flight")}
                              for r in issue_res]
    if plots_dir is not None:
        from benchmarks.nav_plots import plot_worst

        out["plots"] = plot_worst(cells, worst_figs, Path(plots_dir))
    out["cost"] = cost(results)
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m benchmarks.nav [--quick] [--seeds reporting|tuning] [--plots DIR] [--out FILE]
    [--keep DIR | --reanalyse DIR]``."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.nav", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the reduced grid only")
    parser.add_argument("--seeds", choices=("reporting", "tuning"), default="reporting")
    parser.add_argument("--plots", default=None, help="write PNG plots of the worst runs here")
    parser.add_argument("--out", default=None, help="also write the JSON here")
    parser.add_argument("--keep", default=None, metavar="DIR",
                        help="keep every flight here (truth logs, timelines, results.json)")
    parser.add_argument("--reanalyse", default=None, metavar="DIR",
                        help="fly nothing: recompute the report from the flights kept in DIR (--keep)")
    args = parser.parse_args(argv)
    seeds = REPORTING_SEEDS if args.seeds == "reporting" else TUNING_SEEDS
    if args.reanalyse:
        result = reanalyse(Path(args.reanalyse), args.quick, seeds, args.plots)
    else:
        result = run(args.quick, args.plots, seeds, args.keep)
    text = json.dumps(result, indent=2)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    return 0 if not result["errors"] else 1


if __name__ == "__main__":
    sys.exit(main())
