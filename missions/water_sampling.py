#!/usr/bin/env python3
"""Water sampling: four points, one bottle each, circling each point (chapter section 4.2).

The boat goes to each point, circles it at ``--radius`` (default: the vehicle's smallest
controlled circle, USV_TURN_RAD) with the GPS point-tracking controller, fills one bottle
while inside the ``--accept-radius`` circle (the chapter's 2.5 m; the vehicle's
USV_CMD_NAV_SAMPLE_HERE item pauses the pump outside it), then returns home.

    python missions/water_sampling.py                          # four points around home
    python missions/water_sampling.py --points 30,0 40,25 20,45 0,25 --volume 250
    python missions/water_sampling.py --points-at 41.7703,123.4300 ... --figure fig13.png

Prints for each point the largest tracking error -- the chapter's Fig. 13 figure: the distance
from the commanded circle while circling, from the first time the boat is inside the 2.5 m
circle until the sample item is done -- and the sample record the vehicle logged (bottle,
volume, largest distance from the point while pumping), and saves Fig. 13 as a PNG: the track
with the 2.5 m circles and the sampling positions, and the tracking error over time.

Success (exit 0): four bottles filled, each sample taken within ``--accept-radius`` of its
point, every tracking error at most ``--max-track-error`` (the chapter's 1.2 m), and the boat
back within WP_RADIUS of home and disarmed.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import sys
from pathlib import Path
from typing import Any

from mavsdk.plugins.mission_raw import MissionItem

from companion.guidance.geo import LocalFrame
from mavlink_dialect import UsvCmd
from missions.common import Boat, MissionError, add_common_arguments, finish, fly, parse_pair

NAME = "water_sampling"
FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT_INT = 2, 6
CMD_NAV_RETURN_TO_LAUNCH, CMD_DO_CHANGE_SPEED = 20, 178
BOTTLES = 4
BOTTLE_FULL = 2
DEFAULT_POINTS_NE = ((25.0, 0.0), (40.0, 25.0), (20.0, 45.0), (0.0, 25.0))


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--points", nargs=BOTTLES, type=lambda t: parse_pair(t, "--points"),
                       default=list(DEFAULT_POINTS_NE), metavar="NORTH_M,EAST_M",
                       help="the four sampling points relative to home (default 25,0 40,25 20,45 0,25)")
    where.add_argument("--points-at", nargs=BOTTLES, type=lambda t: parse_pair(t, "--points-at"),
                       default=None, metavar="LAT,LON", help="the four sampling points in degrees")
    parser.add_argument("--radius", type=float, default=0.0, metavar="M",
                        help="circle radius around each point (default 0: the vehicle's USV_TURN_RAD)")
    parser.add_argument("--accept-radius", type=float, default=2.5, metavar="M",
                        help="samples only inside this circle (default 2.5, the chapter's)")
    parser.add_argument("--volume", type=float, default=200.0, metavar="ML", help="per bottle (default 200)")
    parser.add_argument("--speed", type=float, default=3.0, metavar="MPS",
                        help="transit speed between points (default 3)")
    parser.add_argument("--max-track-error", type=float, default=1.2, metavar="M",
                        help="largest distance from the commanded circle while circling (default 1.2, "
                             "the chapter's Fig. 13)")
    parser.add_argument("--figure", type=Path, default=Path("water_sampling_fig13.png"), metavar="PNG",
                        help="where to save Fig. 13 (default water_sampling_fig13.png)")
    parser.add_argument("--reset-bottles", action="store_true",
                        help="tell the vehicle the bottles were emptied (USV_CMD_SAMPLER_RESET) first")
    add_common_arguments(parser, timeout_s=900.0)
    args = parser.parse_args(argv)
    if not 0.0 < args.accept_radius <= 50.0 or not 0.0 <= args.radius <= 50.0:
        parser.error("--radius and --accept-radius: metres in (0, 50]")
    if not 0.0 < args.volume <= 5000.0 or not 0.0 < args.speed <= 10.0:
        parser.error("--volume in (0, 5000] mL and --speed in (0, 10] m/s")
    return args


def plan(frame: LocalFrame, points_ne: list[tuple[float, float]], radius_m: float,
         args: argparse.Namespace) -> list[MissionItem]:
    """Transit speed, one USV_CMD_NAV_SAMPLE_HERE per point (north-east metres in ``frame``), return
    to launch; also flown in-process by campaigns (``usv campaign``)."""
    items = [MissionItem(0, FRAME_MISSION, CMD_DO_CHANGE_SPEED, 1, 1, 1.0, args.speed, -1.0, 0.0,
                         0, 0, 0.0, 0)]
    for bottle, (north_m, east_m) in enumerate(points_ne, start=1):
        lat, lon = frame.to_lat_lon(north_m, east_m)
        items.append(MissionItem(bottle, FRAME_GLOBAL_RELATIVE_ALT_INT, int(UsvCmd.NAV_SAMPLE_HERE), 0, 1,
                                 float(bottle), radius_m, 0.0, args.volume, round(lat * 1e7),
                                 round(lon * 1e7), 0.0, 0))
    items.append(MissionItem(BOTTLES + 1, FRAME_MISSION, CMD_NAV_RETURN_TO_LAUNCH, 0, 1, 0.0, 0.0, 0.0, 0.0,
                             0, 0, 0.0, 0))
    return items


async def check_bottles(boat: Boat, reset: bool) -> None:
    """Four empty bottles before leaving (optionally after USV_CMD_SAMPLER_RESET), else MissionError."""
    if reset:
        result = await boat.command(UsvCmd.SAMPLER_RESET, 0)
        if result != 0:
            raise MissionError(f"sampler reset refused (MAV_RESULT {result})")
        boat.rec.sampler = None
    await boat.until(lambda: boat.rec.sampler is not None, 30.0, "sampler status (USV_SAMPLER_STATUS)")
    assert boat.rec.sampler is not None
    states = boat.rec.sampler["bottle_state"]
    if any(state != 0 for state in states):
        raise MissionError(f"bottles not empty (states {states}): empty them and rerun with --reset-bottles")


def tracking(boat: Boat, points_ne: list[tuple[float, float]], radius_m: float,
             accept_m: float) -> list[dict[str, Any]]:
    """Per point: (time, distance from the commanded circle) while circling, and the largest."""
    frame = boat.frame()
    out = []
    for seq, point in enumerate(points_ne, start=1):
        start_s, end_s = boat.rec.current_since.get(seq, math.inf), boat.rec.reached.get(seq, math.inf)
        errors: list[tuple[float, float]] = []
        for pt in boat.rec.track:
            if not start_s <= pt.t_s <= end_s:
                continue
            d = math.dist(frame.to_ne(pt.lat_deg, pt.lon_deg), point)
            if errors or d <= accept_m:  # circling from the first time inside the sampling circle
                errors.append((pt.t_s, abs(d - radius_m)))
        out.append({"errors": errors, "max_m": max((e for _, e in errors), default=math.inf)})
    return out


def _rounded(value: Any) -> float | None:
    """A distance from a MAVLink field as JSON gives it (NaN arrives as null): rounded, or None."""
    return round(float(value), 2) if isinstance(value, (int, float)) and math.isfinite(value) else None


def sample_records(boat: Boat, points_ne: list[tuple[float, float]],
                   since_s: float) -> list[dict[str, Any] | None]:
    """The vehicle's record of the sample at each point (USV_SAMPLER_STATUS), by bottle, of the
    samples taken since vehicle time ``since_s`` (the first status names the last mission's)."""
    frame = boat.frame()
    by_bottle: dict[int, dict[str, Any]] = {}
    for s in boat.rec.samples:
        t_s = boat.vehicle_time_s(s["last_sample_time_unix_usec"])
        if t_s < since_s:
            continue
        bottle = s["last_sample_bottle"]
        north_m, east_m = frame.to_ne(s["last_sample_lat"] / 1e7, s["last_sample_lon"] / 1e7)
        by_bottle[bottle] = {
            "bottle": bottle, "t_s": round(t_s, 1),
            "volume_ml": round(s["bottle_volume"][bottle - 1], 1),
            "max_distance_m": _rounded(s["last_sample_distance"]),  # NaN (null): never pumped inside
            "north_m": round(north_m, 2), "east_m": round(east_m, 2),
        }
    last = boat.rec.sampler or {}
    for bottle, record in by_bottle.items():
        record["full"] = last.get("bottle_state", [0] * BOTTLES)[bottle - 1] == BOTTLE_FULL
    return [by_bottle.get(i) for i in range(1, len(points_ne) + 1)]


def save_figure(path: Path, boat: Boat, points_ne: list[tuple[float, float]], radius_m: float,
                accept_m: float, track_err: list[dict[str, Any]],
                records: list[dict[str, Any] | None]) -> None:
    """The chapter's Fig. 13: track, 2.5 m circles and sampling positions; tracking error over time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frame = boat.frame()
    track = [frame.to_ne(p.lat_deg, p.lon_deg) for p in boat.rec.track if p.t_s >= min(
        boat.rec.current_since.values(), default=0.0)]
    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(12, 5.5))
    ax.plot([e for _, e in track], [n for n, _ in track], color="green", lw=1.0, label="track")
    for i, (north_m, east_m) in enumerate(points_ne, start=1):
        for r, style in ((accept_m, "-"), (radius_m, ":")):
            ax.add_patch(plt.Circle((east_m, north_m), r, fill=False, color="red", ls=style, lw=1.2))
        ax.annotate(f"P{i}", (east_m, north_m), textcoords="offset points", xytext=(6, 6))
    samples = [r for r in records if r is not None]
    ax.scatter([r["east_m"] for r in samples], [r["north_m"] for r in samples], marker="x", color="blue",
               zorder=3, label="sampling position (pump start)")
    ax.plot([0.0], [0.0], "k^", label="home")
    ax.set(xlabel="east of home [m]", ylabel="north of home [m]", aspect="equal",
           title=f"Track, {accept_m:g} m circles (solid), commanded {radius_m:g} m circles (dotted)")
    ax.legend(loc="best", fontsize=8)
    for i, t in enumerate(track_err, start=1):
        if t["errors"]:
            t0 = t["errors"][0][0]
            ax_err.plot([s - t0 for s, _ in t["errors"]], [e for _, e in t["errors"]],
                        label=f"P{i}: max {t['max_m']:.2f} m")
    ax_err.set(xlabel="time circling [s]", ylabel="distance from the commanded circle [m]",
               title="Tracking error around the sampling points")
    ax_err.legend(loc="best", fontsize=8)
    ax_err.grid(True, alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


async def run(argv: list[str] | None = None) -> int:
    return await fly(NAME, parse_args(argv), sample)


async def sample(boat: Boat, args: argparse.Namespace) -> int:
    await check_bottles(boat, args.reset_bottles)
    wp_radius_m = await boat.param_float("WP_RADIUS")
    radius_m = args.radius or await boat.param_float("USV_TURN_RAD")
    await boat.telemetry.set_rate_position(10.0)  # a finer track for Fig. 13
    await boat.arm()
    frame = boat.frame()
    points_ne = [frame.to_ne(*p) for p in args.points_at] if args.points_at else list(args.points)
    print(f"{NAME}: {BOTTLES} points, circles of {radius_m:g} m, samples inside {args.accept_radius:g} m",
          flush=True)
    names = ["transit speed", *(f"sample at P{i}" for i in range(1, BOTTLES + 1)), "return home"]
    start_s = await boat.run_raw_mission(plan(boat.frame(), points_ne, radius_m, args), args.timeout,
                                         lambda seq: names[seq])
    track_err = tracking(boat, points_ne, radius_m, args.accept_radius)
    records = sample_records(boat, points_ne, start_s)
    home_m = await boat.go_home_and_disarm(wp_radius_m, args.timeout)
    save_figure(args.figure, boat, points_ne, radius_m, args.accept_radius, track_err, records)
    points = [{"point": i, "north_m": round(p[0], 1), "east_m": round(p[1], 1),
               "max_track_error_m": round(t["max_m"], 2), "sample": r}
              for i, (p, t, r) in enumerate(zip(points_ne, track_err, records, strict=True), start=1)]
    summary = {"radius_m": radius_m, "accept_radius_m": args.accept_radius, "points": points,
               "mission_time_s": round(boat.now_s() - start_s, 1), "figure": str(args.figure),
               "home_distance_at_disarm_m": round(home_m, 2), "wp_radius_m": wp_radius_m}
    return finish(NAME, summary, judge(points, args), args.json, print_summary)


def judge(points: list[dict[str, Any]], args: argparse.Namespace) -> list[str]:
    """The run's failures, per point: no sample (the vehicle refused or skipped it, and its
    messages say why; the boat did not circle there, so no tracking error is judged), a bottle not
    full, a sample with no distance or too far from the point, a tracking error over the limit."""
    failures = []
    for p in points:
        name, r = f"P{p['point']}", p["sample"]
        if r is None:
            failures.append(f"{name}: no sample (the vehicle refused or skipped it; see its messages)")
            continue
        if not r["full"]:
            failures.append(f"{name}: bottle {r['bottle']} not full")
        elif r["max_distance_m"] is None:
            failures.append(f"{name}: the vehicle recorded no distance from the point for its sample")
        elif r["max_distance_m"] > args.accept_radius:
            failures.append(f"{name}: sampled {r['max_distance_m']} m from the point "
                            f"(limit {args.accept_radius} m)")
        if p["max_track_error_m"] > args.max_track_error:
            failures.append(f"{name}: tracking error {p['max_track_error_m']} m "
                            f"(limit {args.max_track_error} m)")
    return failures


def print_summary(s: dict[str, Any]) -> None:
    print(f"{NAME} summary (figure {s['figure']}):")
    for p in s["points"]:
        r = p["sample"]
        sample = "no sample" if r is None else (
            f"bottle {r['bottle']} {r['volume_ml']} mL at t={r['t_s']} s, "
            f"at most {r['max_distance_m']} m from the point")
        print(f"  P{p['point']} ({p['north_m']} N, {p['east_m']} E): max tracking error "
              f"{p['max_track_error_m']} m; {sample}")
    print(f"  mission {s['mission_time_s']} s; disarmed {s['home_distance_at_disarm_m']} m from home",
          flush=True)


if __name__ == "__main__":
    sys.exit(asyncio.run(run()))
