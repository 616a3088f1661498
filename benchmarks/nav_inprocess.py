"""The nav bench's flight in-process, for tuning: a deterministic development rig, NOT the product's
figures.

``usv bench nav`` (:mod:`benchmarks.nav`) flies ``usv sitl`` over MAVLink from a separate process;
those are the figures the README reports, and they move by tenths of a metre from one flight of a
cell to the next (the ground station's commands land at wall-clock-dependent vehicle times).  This
rig flies the same script on the same grid with the companion's full stack stepped in this process
(:class:`~sim_bridge.sitl.SitlHarness`, lockstep, default parameters unless ``--param`` says
otherwise): the same cell gives the same figures to the centimetre, in about a minute for the
53 cells of a grid on two cores.  ``docs/tuning.md``'s "in-process" figures are this rig's.

The script, in vehicle time (as :mod:`benchmarks.nav_flight`, without the sampling mission):
arm; GUIDED go-to :data:`~benchmarks.nav_flight.GOTO_NE`; once within ``WP_RADIUS``,
:data:`~benchmarks.nav_flight.ARRIVAL_HOLD_S` there; LOITER for
:data:`~benchmarks.nav_flight.LOITER_S`; RTL, and once within ``WP_RADIUS`` of home
:data:`~benchmarks.nav_flight.ARRIVAL_HOLD_S` there; AUTO over the 50 m square.

Figures (truth positions, metres from the vehicle's home, which is where the boat was at arming,
not the simulator's origin: in a current it has drifted by then): ``goto_s`` / ``rtl_s`` (to within
``WP_RADIUS``), ``arrival_max_m`` / ``rtl_arrival_max_m`` (largest distance from the point over the
hold after arriving), ``loiter_max_m`` / ``loiter_rms_m`` (from where LOITER was entered),
``square_side_max_m`` and ``square_first_15s_max_m`` (distance from the nearest side of the path,
the first leg from where AUTO started or, if it first waited on its hold's orbit, where the vehicle
said it left it, as in :func:`benchmarks.nav_metrics.square`),
``square_mid_leg_rms_m`` and ``square_mid_leg_max_m`` (cross-track distance from each leg more than
:data:`~benchmarks.nav_metrics.MID_LEG_MARGIN_M` from its ends; a leg is the samples flown while the
mission's current item is its end corner, where the bench splits legs at MISSION_ITEM_REACHED).

Run: ``python -m benchmarks.nav_inprocess --seeds tuning --out F.json [--param NAME=VALUE ...]
[--compare BASE.json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import math
import statistics
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.nav_flight import ARRIVAL_HOLD_S, GOTO_NE, LOITER_S, PHASE_LIMIT_S, SQUARE_NE, Cell
from benchmarks.nav_grid import REPORTING_SEEDS, TUNING_SEEDS, full_grid
from benchmarks.nav_metrics import FIRST_LEG_WINDOW_S, mid_leg_cross_m, path_distance, rms
from companion.guidance.geo import LocalFrame
from companion.messages import STATUS_TEXT_TOPIC, GuidedTarget, ModeNumber
from companion.mission import items as mission_items
from companion.mission.items import MissionItem, MissionType
from companion.modes.orbit_join import LEAVING_ORBIT_TEXT
from companion.vehicle import MissionState
from sim_bridge.sitl import SitlHarness

STEP_S = 0.1
"""Vehicle seconds between two truth samples."""
SIM_ORIGIN = (41.77, 123.43)
"""Where the simulated boat starts (given to :class:`~sim_bridge.sitl.SitlHarness`)."""
FIGURES = ("goto_s", "arrival_max_m", "loiter_max_m", "loiter_rms_m", "rtl_s", "rtl_arrival_max_m",
           "square_side_max_m", "square_first_15s_max_m", "square_mid_leg_rms_m", "square_mid_leg_max_m")
TOLERANCE_M = {"square_mid_leg_rms_m": 0.05, "square_mid_leg_max_m": 0.1}
"""How far a cell's figure must move to count as better or worse (:func:`compare`); others 0.3 m."""


@dataclass(frozen=True)
class SequenceFigures:
    goto_s: float
    arrival_max_m: float
    loiter_max_m: float
    loiter_rms_m: float
    rtl_s: float
    rtl_arrival_max_m: float
    square_side_max_m: float
    square_first_15s_max_m: float
    square_mid_leg_rms_m: float
    square_mid_leg_max_m: float


class _Flight:
    """One cell's harness with the truth track in metres from the vehicle's home."""

    def __init__(self, h: SitlHarness) -> None:
        self.h = h
        assert h.services is not None, "the rig flies the full stack"
        self.vehicle = h.services.vehicle
        self.frame = LocalFrame(*SIM_ORIGIN)

    def set_home(self) -> None:
        home = self.vehicle.home
        assert home is not None, "armed without a home"
        self.frame = LocalFrame(home.lat_deg, home.lon_deg)

    def here(self) -> tuple[float, float]:
        """The truth position as :class:`benchmarks.nav_metrics.Truth` reads the truth log: the
        simulated GPS's degrees (no noise) in the companion's frame at home."""
        s = self.h.plant.state
        return self.frame.to_ne(*self.h.boat.gpsins.lat_lon(s.north_m, s.east_m))

    def now_s(self) -> float:
        return float(self.h.plant.state.t_s)

    async def track(self, duration_s: float) -> list[tuple[float, float]]:
        out = []
        for _ in range(round(duration_s / STEP_S)):
            await self.h.run_for(STEP_S)
            out.append(self.here())
        return out

    async def until_within(self, point: tuple[float, float], radius_m: float, limit_s: float) -> float:
        """Vehicle seconds until the boat is within ``radius_m`` of ``point`` (inf: not in ``limit_s``)."""
        t0 = self.now_s()
        while self.now_s() - t0 < limit_s:
            await self.h.run_for(STEP_S)
            if math.dist(self.here(), point) <= radius_m:
                return round(self.now_s() - t0, 2)
        return math.inf

    def set_mode(self, mode: ModeNumber) -> None:
        refused = self.vehicle.set_mode(int(mode))
        if refused is not None:
            raise RuntimeError(f"mode {mode.name} refused: {refused}")


def _max_from(track: list[tuple[float, float]], point: tuple[float, float]) -> float:
    return round(max(math.dist(p, point) for p in track), 2) if track else math.inf


async def fly(cell: Cell, params: dict[str, float] | None = None) -> SequenceFigures:
    """The script of the module docstring on ``cell``."""
    async with SitlHarness(seed=cell.seed, current=f"{cell.current_mps},{cell.current_toward_deg}",
                           wind=f"{cell.wind_mps},{cell.wind_from_deg}", waves=f"{cell.waves_hs_m}",
                           home=SIM_ORIGIN, full_stack=True, params=params) as h:
        f = _Flight(h)
        v = f.vehicle
        radius_m = v.params.get("WP_RADIUS")
        await h.run_for(0.6)
        refused = v.arm()
        if refused is not None:
            raise RuntimeError(f"arming refused: {refused}")
        f.set_home()
        f.set_mode(ModeNumber.GUIDED)
        v.guided_target = GuidedTarget(*f.frame.to_lat_lon(*GOTO_NE), t_s=h.ctx.clock.now_s())
        goto_s = await f.until_within(GOTO_NE, radius_m, PHASE_LIMIT_S["goto"])
        arrival = await f.track(ARRIVAL_HOLD_S)
        f.set_mode(ModeNumber.LOITER)
        entry = f.here()
        loiter = [entry, *await f.track(LOITER_S)]
        f.set_mode(ModeNumber.RTL)
        rtl_s = await f.until_within((0.0, 0.0), radius_m, PHASE_LIMIT_S["rtl"])
        rtl_hold = await f.track(ARRIVAL_HOLD_S)
        plan = [MissionItem.home(*f.frame.to_lat_lon(0.0, 0.0))] + [
            MissionItem.at(k, mission_items.CMD_NAV_WAYPOINT, *f.frame.to_lat_lon(*ne))
            for k, ne in enumerate(SQUARE_NE, start=1)]
        v.missions.replace(MissionType.MISSION, plan)
        f.set_mode(ModeNumber.AUTO)
        start = f.here()
        left_orbit: list[tuple[float, float]] = []  # where AUTO left its hold's orbit, if it waited on it
        stop_listening = h.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(
            lambda st: left_orbit.append(f.here()) if st.text.startswith(LEAVING_ORBIT_TEXT) else None)
        square: list[tuple[float, float]] = []
        leg_of: list[int] = []
        t0 = f.now_s()
        while v.mission_state != MissionState.COMPLETE and f.now_s() - t0 < PHASE_LIMIT_S["mission"]:
            square += await f.track(STEP_S)
            leg_of.append(v.current_seq)
        stop_listening()
        path = [left_orbit[0] if left_orbit else start, *SQUARE_NE]
        side = path_distance(np.array(square), path) if square else np.array([math.inf])
        mid = _mid_leg(square, leg_of, path)
        first = side[: round(FIRST_LEG_WINDOW_S / STEP_S)]
        dists = [math.dist(p, entry) for p in loiter]
        return SequenceFigures(
            goto_s=goto_s, arrival_max_m=_max_from(arrival, GOTO_NE), loiter_max_m=round(max(dists), 2),
            loiter_rms_m=round(rms(np.asarray(dists)), 2), rtl_s=rtl_s,
            rtl_arrival_max_m=_max_from(rtl_hold, (0.0, 0.0)), square_side_max_m=round(float(side.max()), 2),
            square_first_15s_max_m=round(float(first.max()), 2),
            square_mid_leg_rms_m=round(rms(mid), 3) if mid.size else math.inf,
            square_mid_leg_max_m=round(float(mid.max()), 2) if mid.size else math.inf)


def _mid_leg(track: list[tuple[float, float]], leg_of: list[int],
             path: list[tuple[float, float]]) -> np.ndarray:
    """Mid-leg cross-track distances of ``track`` (``leg_of``: the mission item each sample was
    flown toward, item k being the end of the leg ``path[k-1] -> path[k]``)."""
    pts, seq = np.array(track), np.array(leg_of)
    parts = [mid_leg_cross_m(pts[seq == k], path[k - 1], path[k])
             for k in range(1, len(path)) if np.any(seq == k)]
    return np.concatenate(parts) if parts else np.array([])


def _fly_cell(job: tuple[Cell, dict[str, float]]) -> dict[str, Any]:
    cell, params = job
    logging.disable(logging.CRITICAL)  # a worker's log is the vehicle's STATUSTEXT chatter
    try:
        return {"cell": asdict(cell), "name": cell.name, "figures": asdict(asyncio.run(fly(cell, params)))}
    except Exception as exc:  # one failed cell is reported, the grid goes on
        return {"cell": asdict(cell), "name": cell.name, "error": repr(exc)}


def run_grid(cells: Sequence[Cell], params: dict[str, float] | None = None,
             workers: int = 2) -> list[dict[str, Any]]:
    """Every cell (``workers`` processes); each row: the cell, its name, ``figures`` or ``error``."""
    jobs = [(c, dict(params or {})) for c in cells]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(_fly_cell, jobs))


def summary(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Worst and mean of every figure over the cells that flew (a phase that timed out is inf)."""
    out = {}
    for name in FIGURES:
        values = [float(r["figures"][name]) for r in rows if "figures" in r]
        finite = [x for x in values if math.isfinite(x)]
        out[name] = {"worst": max(values, default=math.nan), "mean": round(statistics.fmean(finite), 3)
                     if finite else math.nan, "timed_out": len(values) - len(finite)}
    return out


def compare(base: Sequence[dict[str, Any]], new: Sequence[dict[str, Any]],
            tolerance_m: float = 0.3) -> dict[str, dict[str, int]]:
    """Per figure, how many cells (by name) got better / worse by more than ``tolerance_m``
    (:data:`TOLERANCE_M` for the mid-leg figures); a figure the base lacks is not counted."""
    old = {r["name"]: r["figures"] for r in base if "figures" in r}
    out = {}
    for name in FIGURES:
        better = worse = 0
        for r in new:
            a, b = old.get(r["name"]), r.get("figures")
            tol_m = TOLERANCE_M.get(name, tolerance_m)
            if a is not None and b is not None and name in a:
                better += b[name] < a[name] - tol_m
                worse += b[name] > a[name] + tol_m
        out[name] = {"better": better, "worse": worse}
    return out


def _param(text: str) -> tuple[str, float]:
    name, _, value = text.partition("=")
    try:
        number = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--param wants NAME=NUMBER, got {text!r}") from None
    if not name or not math.isfinite(number):
        raise argparse.ArgumentTypeError(f"--param wants NAME=NUMBER, got {text!r}")
    return name, number


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.nav_inprocess",
                                 description="The nav bench flight in-process (a tuning rig).")
    ap.add_argument("--seeds", choices=("tuning", "reporting"), default="tuning")
    ap.add_argument("--out", type=Path, required=True, help="JSON file for every cell and the summary")
    ap.add_argument("--param", type=_param, action="append", default=[], metavar="NAME=VALUE",
                    help="a vehicle parameter for every cell (default: the vehicle's defaults)")
    ap.add_argument("--compare", type=Path, help="an earlier --out to count better / worse cells against")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    params = dict(args.param)
    seeds = TUNING_SEEDS if args.seeds == "tuning" else REPORTING_SEEDS
    rows = run_grid(full_grid(seeds), params, args.workers)
    report: dict[str, Any] = {"seeds": args.seeds, "params": params, "summary": summary(rows), "cells": rows}
    if args.compare is not None:
        report["compare"] = compare(json.loads(args.compare.read_text(encoding="utf-8"))["cells"], rows)
    args.out.write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    json.dump({k: report[k] for k in ("summary", "compare") if k in report}, sys.stdout, indent=1)
    print()
    return 1 if any("error" in r for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
