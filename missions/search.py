#!/usr/bin/env python3
"""Search a flooded area for people: a lawnmower or expanding-square pattern, with coverage.

The area is a polygon from a QGroundControl ``.plan`` (its first survey polygon, else its first
inclusion geofence polygon) or a GeoJSON file (the first Polygon / MultiPolygon), or by default
a 50 m x 60 m box starting 20 m north of home.  Lines are ``--sweep-width`` apart (the width
the lookout or sensor reliably detects a person in the water, IAMSAR's sweep width W; track
spacing S = W gives coverage factor 1).  The pattern is flown as a MAVSDK Mission-plugin
mission of fly-through waypoints; then the boat returns home.

    python missions/search.py                                  # the default box
    python missions/search.py --area flood.plan --sweep-width 15
    python missions/search.py --area area.geojson --pattern expanding-square

Coverage is measured, not planned: the share of the polygon within ``W/2`` of the track the
boat actually sailed while the pattern ran (1 m grid).  Success (exit 0): coverage at least
``--min-coverage`` (default 95 %) and the boat back within WP_RADIUS of home and disarmed.
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from missions.common import Boat, MissionError, add_common_arguments, fail, finish, fly

NAME = "search"
NE = tuple[float, float]
DEFAULT_BOX_NE = [(20.0, -30.0), (20.0, 30.0), (70.0, 30.0), (70.0, -30.0)]
GRID_M = 1.0


# -- the area ----------------------------------------------------------------------------------
def load_area(path: Path) -> list[tuple[float, float]]:
    """The search polygon (lat, lon vertices) from a QGC ``.plan`` or GeoJSON file."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise MissionError(f"{path}: cannot read the area ({exc})") from None
    if not isinstance(data, dict):
        raise MissionError(f"{path}: not a QGC plan or GeoJSON object")
    ring = _plan_polygon(data) if data.get("fileType") == "Plan" else _geojson_polygon(data)
    if ring is None:
        plan = data.get("fileType") == "Plan"
        kind = "a survey item or inclusion geofence polygon" if plan else "a Polygon"
        raise MissionError(f"{path}: no search polygon found (expected {kind})")
    try:
        vertices = [(float(lat), float(lon)) for lat, lon in ring]
    except (TypeError, ValueError):
        raise MissionError(f"{path}: polygon vertices must be number pairs") from None
    if len(vertices) > 1 and vertices[0] == vertices[-1]:
        vertices = vertices[:-1]  # closed ring
    if len(vertices) < 3 or not all(abs(a) <= 90 and abs(b) <= 180 for a, b in vertices):
        raise MissionError(f"{path}: the polygon needs at least 3 vertices on the globe")
    return vertices


def _plan_polygon(plan: dict[str, Any]) -> list[Any] | None:
    for item in plan.get("mission", {}).get("items", []):
        if item.get("type") == "ComplexItem" and item.get("polygon"):
            return [(p[0], p[1]) for p in item["polygon"]]
    for fence in plan.get("geoFence", {}).get("polygons", []):
        if fence.get("inclusion", True) and fence.get("polygon"):
            return [(p[0], p[1]) for p in fence["polygon"]]
    return None


def _geojson_polygon(obj: dict[str, Any]) -> list[Any] | None:
    kind = obj.get("type")
    if kind == "FeatureCollection":
        for feature in obj.get("features", []):
            ring = _geojson_polygon(feature)
            if ring is not None:
                return ring
        return None
    if kind == "Feature":
        return _geojson_polygon(obj.get("geometry") or {})
    coords = obj.get("coordinates")
    if kind == "Polygon" and coords:
        return [(p[1], p[0]) for p in coords[0]]  # GeoJSON is lon, lat
    if kind == "MultiPolygon" and coords:
        return [(p[1], p[0]) for p in coords[0][0]]
    return None


# -- the patterns (north-east metres) --------------------------------------------------------------
def _rotate(points: np.ndarray, angle_rad: float) -> np.ndarray:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return points @ np.array([[c, s], [-s, c]])


def longest_edge_angle(polygon: list[NE]) -> float:
    """Direction (rad, from north toward east) of the polygon's longest edge: fewest turns."""
    edges = [(polygon[i], polygon[(i + 1) % len(polygon)]) for i in range(len(polygon))]
    a, b = max(edges, key=lambda e: math.dist(*e))
    return math.atan2(b[1] - a[1], b[0] - a[0])


def lawnmower(polygon: list[NE], spacing_m: float, angle_rad: float | None = None,
              start: NE = (0.0, 0.0)) -> list[NE]:
    """Boustrophedon lines at most ``spacing_m`` apart across the polygon, first line half a spacing in.

    Lines run along ``angle_rad`` (default: the longest edge), alternating direction, starting
    at the corner nearest ``start`` (home).  Each line spans the polygon across its whole swath
    (half a spacing either side), so sloping edges leave no uncovered corners.
    """
    angle = longest_edge_angle(polygon) if angle_rad is None else angle_rad
    local = _rotate(np.asarray(polygon, dtype=float), angle)  # lines at constant column 1
    lo, hi = local[:, 1].min(), local[:, 1].max()
    n = max(1, math.ceil((hi - lo) / spacing_m - 1e-9))
    half = 0.5 * (hi - lo) / n
    lines: list[list[tuple[float, float]]] = []
    for k in range(n):
        y = lo + (2 * k + 1) * half
        xs = [x for x, v in local if y - half <= v <= y + half]  # vertices inside the swath
        for (x1, y1), (x2, y2) in zip(local, np.roll(local, -1, axis=0), strict=True):
            for edge_y in (y - half, y + half):  # where the edges cross the swath's sides
                if y1 != y2 and min(y1, y2) <= edge_y <= max(y1, y2):
                    xs.append(x1 + (edge_y - y1) * (x2 - x1) / (y2 - y1))
        if xs:
            lines.append([(min(xs), y), (max(xs), y)])
    candidates = []
    for order in (lines, lines[::-1]):
        for flip in (False, True):
            ends = [line[::-1] if (i % 2 == 1) != flip else line for i, line in enumerate(order)]
            points = [(float(p[0]), float(p[1])) for p in _rotate(np.asarray(ends).reshape(-1, 2), -angle)]
            candidates.append(points)
    return min(candidates, key=lambda pts: math.dist(pts[0], start)) if lines else []


def expanding_square(polygon: list[NE], spacing_m: float) -> list[NE]:
    """IAMSAR expanding square from the polygon's centre: legs S, S, 2S, 2S, ... until it covers it."""
    pts = np.asarray(polygon, dtype=float)
    centre = pts.mean(axis=0)
    reach = float(np.abs(pts - centre).max()) + spacing_m / 2
    waypoints = [(float(centre[0]), float(centre[1]))]
    heading, leg = 0, 1
    directions = ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))  # north, east, south, west
    while True:
        for _ in range(2):
            dn, de = directions[heading % 4]
            n, e = waypoints[-1]
            waypoints.append((n + dn * leg * spacing_m, e + de * leg * spacing_m))
            heading += 1
        if (leg - 1) * spacing_m / 2 >= reach:  # the last ring is complete on all four sides
            return waypoints
        leg += 1


def coverage(polygon: list[NE], track: list[NE], sweep_m: float, grid_m: float = GRID_M) -> float:
    """Share of the polygon (grid cells) within ``sweep_m / 2`` of the track polyline."""
    from matplotlib.path import Path as MplPath

    pts = np.asarray(polygon, dtype=float)
    (n0, e0), (n1, e1) = pts.min(axis=0), pts.max(axis=0)
    gn, ge = np.meshgrid(np.arange(n0 + grid_m / 2, n1, grid_m), np.arange(e0 + grid_m / 2, e1, grid_m))
    cells = np.column_stack([gn.ravel(), ge.ravel()])
    cells = cells[MplPath(pts).contains_points(cells)]
    if len(cells) == 0 or len(track) < 2:
        return 0.0
    seen = np.zeros(len(cells), dtype=bool)
    path = np.asarray(track, dtype=float)
    for a, b in itertools.pairwise(path):
        ab = b - a
        t = np.clip(((cells - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        seen |= np.hypot(*(cells - a - t[:, None] * ab).T) <= sweep_m / 2
    return float(seen.mean())


def path_length_m(points: list[NE]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(points))


# -- the script --------------------------------------------------------------------------------------
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--area", type=Path, default=None, metavar="FILE",
                        help="QGC .plan or GeoJSON polygon (default: 50 m x 60 m box 20 m north of home)")
    parser.add_argument("--pattern", choices=("lawnmower", "expanding-square"), default="lawnmower")
    parser.add_argument("--sweep-width", type=float, default=10.0, metavar="M",
                        help="width in which a person is reliably seen; also the line spacing (default 10)")
    parser.add_argument("--angle", type=float, default=None, metavar="DEG",
                        help="lawnmower line direction (default: along the polygon's longest edge)")
    parser.add_argument("--speed", type=float, default=4.0, metavar="MPS", help="search speed (default 4)")
    parser.add_argument("--min-coverage", type=float, default=0.95, metavar="FRACTION",
                        help="success threshold of the measured coverage (default 0.95)")
    add_common_arguments(parser, timeout_s=1800.0)
    args = parser.parse_args(argv)
    if not 1.0 <= args.sweep_width <= 500.0 or not 0.0 < args.speed <= 10.0:
        parser.error("--sweep-width in [1, 500] m and --speed in (0, 10] m/s")
    if not 0.0 <= args.min_coverage <= 1.0:
        parser.error("--min-coverage is a fraction in [0, 1]")
    return args


async def fly_pattern(boat: Boat, waypoints: list[tuple[float, float]], speed_mps: float,
                      timeout_s: float) -> tuple[float, float]:
    """Upload with the Mission plugin, fly, follow its progress; (start, end) vehicle times."""
    from mavsdk.asyncio.plugins.mission import MissionError as MavsdkMissionError
    from mavsdk.plugins.mission import MissionItem, MissionPlan

    plan = MissionPlan([MissionItem(lat, lon, 0.0, speed_mps if i == 0 else None, True, None, None, None,
                                    None, None, 3.0) for i, (lat, lon) in enumerate(waypoints)])
    try:
        await boat.mission.upload_mission(plan)
        await boat.mission.start_mission()
    except MavsdkMissionError as exc:
        raise MissionError(f"mission refused: {exc} (see the vehicle's messages above)") from None
    start_s = boat.now_s()
    state = {"shown": -1, "finished": False}

    async def follow() -> None:
        async for p in boat.mission.subscribe_mission_progress():
            if p.current != state["shown"]:
                state["shown"] = p.current
                print(f"  [{boat.now_s():7.1f} s] progress {p.current}/{p.total}", flush=True)

    async def finished() -> None:
        while not state["finished"]:
            state["finished"] = await boat.mission.is_mission_finished()
            await asyncio.sleep(0.2)

    tasks = [asyncio.ensure_future(follow()), asyncio.ensure_future(finished())]
    try:
        await boat.until(lambda: bool(state["finished"]), timeout_s, "search pattern")
    finally:
        for task in tasks:
            task.cancel()
    return start_s, boat.now_s()


async def run(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        area = load_area(args.area) if args.area else None
    except MissionError as exc:
        return fail(NAME, exc, args.json)
    return await fly(NAME, args, lambda boat, args: search(boat, area, args))


async def search(boat: Boat, area: list[tuple[float, float]] | None, args: argparse.Namespace) -> int:
    wp_radius_m = await boat.param_float("WP_RADIUS")
    await boat.arm()
    frame = boat.frame()
    polygon = [frame.to_ne(*v) for v in area] if area else DEFAULT_BOX_NE
    if args.pattern == "lawnmower":
        angle = None if args.angle is None else math.radians(args.angle)
        pattern = lawnmower(polygon, args.sweep_width, angle)
    else:
        pattern = expanding_square(polygon, args.sweep_width)
    area_m2 = 0.5 * abs(sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(polygon, polygon[1:] + polygon[:1],
                                                                        strict=True)))
    print(f"{NAME}: {args.pattern} over {area_m2:.0f} m2, {len(pattern)} waypoints, "
          f"{path_length_m(pattern):.0f} m, sweep width {args.sweep_width:g} m", flush=True)
    waypoints = [frame.to_lat_lon(*p) for p in pattern]
    start_s, end_s = await fly_pattern(boat, waypoints, args.speed, args.timeout)
    track = [frame.to_ne(p.lat_deg, p.lon_deg) for p in boat.rec.track if start_s <= p.t_s <= end_s]
    covered = coverage(polygon, track, args.sweep_width)
    home_m = await boat.go_home_and_disarm(wp_radius_m, args.timeout)
    summary = {"pattern": args.pattern, "area_m2": round(area_m2), "sweep_width_m": args.sweep_width,
               "waypoints": len(pattern), "planned_length_m": round(path_length_m(pattern)),
               "sailed_length_m": round(path_length_m(track)), "search_time_s": round(end_s - start_s, 1),
               "coverage": round(covered, 4), "home_distance_at_disarm_m": round(home_m, 2),
               "wp_radius_m": wp_radius_m}
    failures = []
    if covered < args.min_coverage:
        failures.append(f"covered {100 * covered:.1f} % of the area "
                        f"(required {100 * args.min_coverage:.0f} %)")
    return finish(NAME, summary, failures, args.json, print_summary)


def print_summary(s: dict[str, Any]) -> None:
    print(f"{NAME} summary: covered {100 * s['coverage']:.1f} % of {s['area_m2']} m2 in "
          f"{s['search_time_s']} s ({s['sailed_length_m']} m sailed); disarmed "
          f"{s['home_distance_at_disarm_m']} m from home", flush=True)


if __name__ == "__main__":
    sys.exit(asyncio.run(run()))
