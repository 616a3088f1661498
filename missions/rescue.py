#!/usr/bin/env python3
"""Rescue: throw a lifebuoy on a rope to a person in the water (chapter section 4.1).

The boat approaches at speed, slows down, stops beside the casualty at ``--standoff``
metres with its bow toward them (the launcher is fixed to the hull and throws forward),
arms and fires the rope launcher (the dialect's mission item USV_CMD_NAV_LAUNCH_AT: the
vehicle fires only with every interlock satisfied, bow on the bearing and stopped), holds
station while the person is pulled alongside, and tows them home at ``--tow-speed``.

    python missions/rescue.py                       # casualty 100 m north, 30 m east of home
    python missions/rescue.py --casualty 150,-40    # metres north,east of home
    python missions/rescue.py --casualty-at 41.7712,123.4301 --url udpin://0.0.0.0:14550

Success (exit 0): one launch, fired within ``--launch-tol`` metres of the planned launch point
with the bow within ``--bearing-tol`` degrees of the casualty, and the boat back within
WP_RADIUS of home and disarmed.  The summary gives the time to the casualty (mission start to
launch), the distance and bearing error at launch and the time on station (vehicle seconds).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import math
import sys
from typing import Any

from mavsdk.plugins.mission_raw import MissionItem

from companion.guidance.geo import LocalFrame
from mavlink_dialect import UsvCmd
from missions.common import Boat, MissionError, WaterCurrent, add_common_arguments, finish, fly, parse_pair

NAME = "rescue"
FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT_INT = 2, 6
CMD_NAV_WAYPOINT, CMD_NAV_LOITER_TIME, CMD_NAV_RETURN_TO_LAUNCH, CMD_DO_CHANGE_SPEED = 16, 19, 20, 178
CURRENT_WAIT_S = 10.0
"""How long (vehicle seconds) the upstream approach waits for a confident current estimate (slack
water never gives one: then the launch is planned on the direct line)."""
MIN_CONFIDENCE = 0.5
"""Confidence of the current estimate from which the launch is planned from downstream."""
STOPPED_MPS = 1.8
"""The vehicle's "stopped" for a jet boat on a bearing (AUTO's launch item)."""
ROPE_RANGE_M = 150.0
"""The launcher's farthest throw (chapter section 4.1)."""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--casualty", type=lambda t: parse_pair(t, "--casualty"), default=(100.0, 30.0),
                       metavar="NORTH_M,EAST_M", help="casualty position relative to home (default 100,30)")
    where.add_argument("--casualty-at", type=lambda t: parse_pair(t, "--casualty-at"), default=None,
                       metavar="LAT,LON", help="casualty position in degrees")
    parser.add_argument("--standoff", type=float, default=15.0, metavar="M",
                        help="launch from this far from the casualty (default 15, at most 150)")
    parser.add_argument("--approach-speed", type=float, default=5.0, metavar="MPS", help="default 5")
    parser.add_argument("--slow-speed", type=float, default=2.0, metavar="MPS",
                        help="speed over the last --slow-down metres (default 2)")
    parser.add_argument("--slow-down", type=float, default=40.0, metavar="M", help="default 40")
    parser.add_argument("--hold", type=float, default=30.0, metavar="S",
                        help="time on station after the launch, person pulled alongside (default 30)")
    parser.add_argument("--aim-timeout", type=float, default=180.0, metavar="S",
                        help="give up when the launcher has not fired this long after the boat set off for "
                             "the launch point (default 180)")
    parser.add_argument("--tow-speed", type=float, default=1.5, metavar="MPS", help="default 1.5")
    parser.add_argument("--launch-tol", type=float, default=8.0, metavar="M",
                        help="largest distance of the launch from the planned point (default 8)")
    parser.add_argument("--approach", choices=("upstream", "direct"), default="upstream",
                        help="upstream (default): in moving water, stop downstream of the casualty with "
                             "the bow into the current; direct: stop on the line from the boat")
    parser.add_argument("--min-current", type=float, default=0.1, metavar="MPS",
                        help="weakest estimated current for the upstream approach (default 0.1)")
    parser.add_argument("--bearing-tol", type=float, default=10.0, metavar="DEG",
                        help="largest angle between the bow and the casualty at launch (default 10)")
    add_common_arguments(parser, timeout_s=900.0)
    args = parser.parse_args(argv)
    if not 0.0 < args.standoff <= ROPE_RANGE_M:
        parser.error(f"--standoff {args.standoff} m: must be in (0, {ROPE_RANGE_M:.0f}]")
    for name in ("approach_speed", "slow_speed", "tow_speed"):
        if not 0.0 < getattr(args, name) <= 10.0:
            parser.error(f"--{name.replace('_', '-')}: must be in (0, 10] m/s")
    return args


def _item(seq: int, command: int, lat_lon: tuple[float, float] | None = None, *params: float) -> MissionItem:
    p = [*params, *([0.0] * (4 - len(params)))]
    x, y = (round(lat_lon[0] * 1e7), round(lat_lon[1] * 1e7)) if lat_lon else (0, 0)
    frame = FRAME_GLOBAL_RELATIVE_ALT_INT if lat_lon else FRAME_MISSION
    return MissionItem(seq, frame, command, 1 if seq == 0 else 0, 1, p[0], p[1], p[2], p[3], x, y, 0.0, 0)


def plan(boat: Boat, casualty_ne: tuple[float, float], args: argparse.Namespace) -> dict[str, Any]:
    """The mission items and the geometry they were planned from (north-east metres from home)."""
    return plan_from(boat.frame(), boat.position_ne(), casualty_ne, args, boat.rec.water_current)


def confident(est: WaterCurrent | None) -> bool:
    """An estimate that stands out of its uncertainty enough to plan the launch on."""
    return est is not None and est.confidence >= MIN_CONFIDENCE


def upstream_unit(drift: WaterCurrent | None, args: argparse.Namespace) -> tuple[float, float] | None:
    """The unit vector (north, east) against the water's flow when the launch should be made from
    downstream: ``--approach upstream`` and a :func:`confident` estimate of at least
    ``--min-current`` m/s (confidence >= 0.5, the vehicle's own threshold for holding station bow
    into the current); else ``None``."""
    if args.approach != "upstream" or drift is None or not confident(drift):
        return None
    speed = drift.speed_mps
    if not (math.isfinite(speed) and speed >= args.min_current):
        return None
    return (-drift.north_mps / speed, -drift.east_mps / speed)


def plan_from(frame: LocalFrame, here: tuple[float, float], casualty_ne: tuple[float, float],
              args: argparse.Namespace, drift: WaterCurrent | None = None) -> dict[str, Any]:
    """:func:`plan` for a boat at ``here`` (north-east metres in ``frame``) in water drifting at
    ``drift`` (the vehicle's USV_CURRENT_ESTIMATE); also used by
    campaigns (``usv campaign``), which fly the same plan in-process.

    In moving water (see :func:`upstream_unit`) the launch point is ``--standoff`` metres
    downstream of the casualty and the last ``--slow-down`` metres are run against the current:
    a jet boat that cannot reverse stops and holds station only bow into the current, so that is
    where its bow can stay on the casualty for the launcher's aim (USV_LNCH_HOLD_S), and the
    current brakes the approach instead of carrying the boat onto the person.  A route to the
    slow-down point that would pass closer than the standoff to the casualty goes round them
    through a waypoint abeam, twice the standoff away.  In slack water the launch point is on
    the straight line from the boat."""
    dn, de = casualty_ne[0] - here[0], casualty_ne[1] - here[1]
    dist = math.hypot(dn, de)
    if dist <= args.standoff:
        raise MissionError(f"casualty is {dist:.0f} m away, closer than the standoff ({args.standoff:.0f} m)")
    upstream = upstream_unit(drift, args)
    un, ue = upstream if upstream is not None else (dn / dist, de / dist)
    launch_ne = (casualty_ne[0] - args.standoff * un, casualty_ne[1] - args.standoff * ue)
    bearing_deg = math.degrees(math.atan2(ue, un)) % 360.0
    slow_m = args.slow_down if upstream is not None else min(args.slow_down, dist - args.standoff)
    slow_ne = (launch_ne[0] - slow_m * un, launch_ne[1] - slow_m * ue)
    detour_ne = _detour(here, slow_ne, casualty_ne, (un, ue), args.standoff)
    items: list[tuple[str, int, tuple[float, float] | None, tuple[float, ...]]] = [
        ("approach speed", CMD_DO_CHANGE_SPEED, None, (1.0, args.approach_speed, -1.0))]
    if detour_ne is not None:
        items.append(("round the casualty", CMD_NAV_WAYPOINT, frame.to_lat_lon(*detour_ne), ()))
    launch_ll = frame.to_lat_lon(*launch_ne)
    items += [
        ("approach", CMD_NAV_WAYPOINT, frame.to_lat_lon(*slow_ne), ()),
        ("slow down", CMD_DO_CHANGE_SPEED, None, (1.0, args.slow_speed, -1.0)),
        ("stop, aim and fire", UsvCmd.NAV_LAUNCH_AT, launch_ll, (bearing_deg, 0.0, args.standoff)),
        ("hold: person pulled alongside", CMD_NAV_LOITER_TIME, launch_ll, (args.hold,)),
        ("towing speed", CMD_DO_CHANGE_SPEED, None, (1.0, args.tow_speed, -1.0)),
        ("tow home", CMD_NAV_RETURN_TO_LAUNCH, None, ()),
    ]
    names = [name for name, *_ in items]
    return {"items": [_item(seq, cmd, ll, *params) for seq, (_, cmd, ll, params) in enumerate(items)],
            "names": names, "launch_ne": launch_ne, "slow_ne": slow_ne, "detour_ne": detour_ne,
            "bearing_deg": bearing_deg, "approach": "upstream" if upstream is not None else "direct",
            "seq": {"slow": names.index("approach"), "launch": names.index("stop, aim and fire"),
                    "hold": names.index("hold: person pulled alongside")}}


def _detour(here: tuple[float, float], to: tuple[float, float], casualty: tuple[float, float],
            toward: tuple[float, float], standoff_m: float) -> tuple[float, float] | None:
    """A waypoint abeam of the casualty (``2 * standoff_m`` across ``toward``, on the boat's side)
    when the straight leg ``here`` -> ``to`` passes closer than ``standoff_m`` to them."""
    sn, se = to[0] - here[0], to[1] - here[1]
    length2 = sn * sn + se * se
    cn, ce = casualty[0] - here[0], casualty[1] - here[1]
    s = 0.0 if length2 == 0.0 else min(1.0, max(0.0, (cn * sn + ce * se) / length2))
    if math.hypot(cn - s * sn, ce - s * se) >= standoff_m:
        return None
    across = (-toward[1], toward[0])
    side = 1.0 if (-cn) * across[0] + (-ce) * across[1] >= 0.0 else -1.0
    away_m = 2.0 * standoff_m * side
    return (casualty[0] + away_m * across[0], casualty[1] + away_m * across[1])


async def check_launcher(boat: Boat) -> dict[str, Any]:
    """The launcher's status before leaving: loaded and pressurised, or :class:`MissionError`."""
    await boat.until(lambda: boat.rec.launcher is not None, 30.0, "launcher status (USV_LAUNCHER_STATUS)")
    status = boat.rec.launcher
    assert status is not None
    if status["shots_left"] < 1:
        raise MissionError("rope launcher is empty: reload it (and set USV_LNCH_SHOTS) before a rescue")
    pressure, needed = status["cylinder_pressure_mpa"], status["min_pressure_mpa"]
    if not (pressure is not None and math.isfinite(pressure) and pressure >= needed):
        raise MissionError(f"launcher pressure {pressure} MPa below the {needed} MPa needed to fire")
    return status


def launch_errors(at_ne: tuple[float, float], heading_deg: float, casualty_ne: tuple[float, float],
                  launch_ne: tuple[float, float]) -> dict[str, float]:
    """Where a launch happened against the plan: distance from the planned launch point, range to
    the casualty and the bow's angle off the casualty (the figures of the success criteria)."""
    to_casualty = (casualty_ne[0] - at_ne[0], casualty_ne[1] - at_ne[1])
    bearing_deg = math.degrees(math.atan2(to_casualty[1], to_casualty[0])) % 360.0
    return {"launch_north_m": round(at_ne[0], 2), "launch_east_m": round(at_ne[1], 2),
            "distance_error_m": round(math.dist(at_ne, launch_ne), 2),
            "range_to_casualty_m": round(math.hypot(*to_casualty), 2),
            "heading_deg": round(heading_deg % 360.0, 1),
            "bearing_error_deg": round(abs((heading_deg - bearing_deg + 180.0) % 360.0 - 180.0), 1)}


def launch_failures(report: dict[str, Any], args: argparse.Namespace) -> list[str]:
    """The rescue's success criteria on a launch report (empty: met)."""
    failures = []
    if not report["launched"]:
        failures.append("the launcher did not fire (see the vehicle's messages)")
    else:
        if report["distance_error_m"] > args.launch_tol:
            failures.append(f"launched {report['distance_error_m']} m from the planned point "
                            f"(tolerance {args.launch_tol} m)")
        if report["bearing_error_deg"] > args.bearing_tol:
            failures.append(f"bow {report['bearing_error_deg']} deg off the casualty at launch "
                            f"(tolerance {args.bearing_tol} deg)")
        if report["range_to_casualty_m"] > ROPE_RANGE_M:
            failures.append(f"casualty {report['range_to_casualty_m']} m away: beyond the rope's range")
    return failures


def launch_report(boat: Boat, before: dict[str, Any], casualty_ne: tuple[float, float],
                  p: dict[str, Any], start_s: float, station_s: float | None) -> dict[str, Any]:
    """Where, when and how the launch happened, from USV_LAUNCHER_STATUS (vehicle figures)."""
    now = boat.rec.launcher or before
    if now["last_launch_time_unix_usec"] in (0, before["last_launch_time_unix_usec"]):
        return {"launched": False}
    frame = boat.frame()
    at_ne = frame.to_ne(now["last_launch_lat"] / 1e7, now["last_launch_lon"] / 1e7)
    heading_deg = now["last_launch_heading"] / 100.0
    launch_s = boat.vehicle_time_s(now["last_launch_time_unix_usec"])
    return {
        "launched": True,
        "shots_used": before["shots_left"] - now["shots_left"],
        **launch_errors(at_ne, heading_deg, casualty_ne, p["launch_ne"]),
        "time_to_casualty_s": round(launch_s - start_s, 1),
        "time_to_station_s": None if station_s is None else round(station_s - start_s, 1),
    }


def aiming_report(boat: Boat, p: dict[str, Any], casualty_ne: tuple[float, float],
                  args: argparse.Namespace) -> dict[str, Any]:
    """How close the boat came to firing conditions after it set off for the launch point: share
    of the time within ``--launch-tol`` of the point, the best bow error while stopped there (at
    most the vehicle's 1.8 m/s "stopped" for a jet), and the longest stretch stopped there with the
    bow within ``--bearing-tol`` (the vehicle fires after USV_LNCH_HOLD_S, 3 s) -- figures for a
    launch that never came."""
    frame = boat.frame()
    since_s = boat.rec.current_since.get(p["seq"]["launch"], math.inf)
    near, stopped_errors, aimed_since, longest_aimed_s = 0, [], None, 0.0
    points = [pt for pt in boat.rec.track if pt.t_s >= since_s]
    for pt in points:
        ne = frame.to_ne(pt.lat_deg, pt.lon_deg)
        error_deg = abs((pt.heading_deg - p["bearing_deg"] + 180.0) % 360.0 - 180.0)
        is_near = math.dist(ne, p["launch_ne"]) <= args.launch_tol
        stopped = is_near and pt.speed_mps <= STOPPED_MPS
        near += is_near
        if stopped:
            stopped_errors.append(error_deg)
        if stopped and error_deg <= args.bearing_tol:
            aimed_since = pt.t_s if aimed_since is None else aimed_since
            longest_aimed_s = max(longest_aimed_s, pt.t_s - aimed_since)
        else:
            aimed_since = None
    return {"seconds": round(points[-1].t_s - since_s, 1) if points else 0.0,
            "share_near_launch_point": round(near / len(points), 3) if points else 0.0,
            "share_stopped_near": round(len(stopped_errors) / len(points), 3) if points else 0.0,
            "best_bow_error_stopped_deg": round(min(stopped_errors), 1) if stopped_errors else None,
            "longest_aimed_and_stopped_s": round(longest_aimed_s, 2)}


def arrival_s(boat: Boat, point_ne: tuple[float, float], after_s: float, radius_m: float) -> float | None:
    """Vehicle time the track first came within ``radius_m`` of ``point_ne`` after ``after_s``."""
    frame = boat.frame()
    for pt in boat.rec.track:
        if pt.t_s >= after_s and math.dist(frame.to_ne(pt.lat_deg, pt.lon_deg), point_ne) <= radius_m:
            return pt.t_s
    return None


async def run(argv: list[str] | None = None) -> int:
    return await fly(NAME, parse_args(argv), rescue)


async def rescue(boat: Boat, args: argparse.Namespace) -> int:
    before = await check_launcher(boat)
    wp_radius_m = await boat.param_float("WP_RADIUS")
    await boat.arm()
    frame = boat.frame()
    casualty_ne = frame.to_ne(*args.casualty_at) if args.casualty_at else args.casualty
    if args.approach == "upstream":  # a few seconds after boot the vehicle knows the drift
        with contextlib.suppress(MissionError):
            await boat.until(lambda: confident(boat.rec.water_current), CURRENT_WAIT_S,
                             "a confident current estimate")
    p = plan(boat, casualty_ne, args)
    est = boat.rec.water_current
    drift = ("no current estimate" if est is None else
             f"current estimate {est.speed_mps:.2f} m/s toward {est.toward_deg:.0f} deg")
    print(f"{NAME}: casualty {casualty_ne[0]:.0f} m N {casualty_ne[1]:.0f} m E of home; {drift}; launch from "
          f"{args.standoff:.0f} m on bearing {p['bearing_deg']:.0f} deg ({p['approach']} approach"
          f"{', round the casualty' if p['detour_ne'] else ''})", flush=True)

    try:
        start_s = await boat.run_raw_mission(p["items"], args.timeout, lambda seq: p["names"][seq],
                                             {p["seq"]["launch"]: args.aim_timeout})
    except MissionError as exc:
        exc.details = {"launched": False, "aiming": aiming_report(boat, p, casualty_ne, args)}
        raise
    slowed_s = boat.rec.reached.get(p["seq"]["slow"], start_s)
    station_s = arrival_s(boat, p["launch_ne"], slowed_s, args.launch_tol)
    left_station_s = boat.rec.reached.get(p["seq"]["hold"], boat.now_s())
    report = launch_report(boat, before, casualty_ne, p, start_s, station_s)
    home_m = await boat.go_home_and_disarm(wp_radius_m, args.timeout)
    summary = {
        "casualty_north_m": round(casualty_ne[0], 1), "casualty_east_m": round(casualty_ne[1], 1),
        "standoff_m": args.standoff, "approach": p["approach"],
        "current_estimate_mps": None if est is None else round(est.speed_mps, 2),
        "current_toward_deg": None if est is None else round(est.toward_deg, 1),
        "launch_bearing_planned_deg": round(p["bearing_deg"], 1), **report,
        "time_on_station_s": None if station_s is None else round(left_station_s - station_s, 1),
        "mission_time_s": round(boat.now_s() - start_s, 1),
        "home_distance_at_disarm_m": round(home_m, 2), "wp_radius_m": wp_radius_m,
    }
    failures = launch_failures(report, args)
    return finish(NAME, summary, failures, args.json, print_summary)


def print_summary(s: dict[str, Any]) -> None:
    print(f"{NAME} summary (vehicle seconds):")
    if s["launched"]:
        print(f"  time to casualty (start to launch) {s['time_to_casualty_s']} s, on station "
              f"{s['time_on_station_s']} s, whole mission {s['mission_time_s']} s")
        print(f"  launch {s['distance_error_m']} m from the planned point, {s['range_to_casualty_m']} m from "
              f"the casualty, bow {s['bearing_error_deg']} deg off the casualty (heading {s['heading_deg']})")
    print(f"  disarmed {s['home_distance_at_disarm_m']} m from home", flush=True)


if __name__ == "__main__":
    sys.exit(asyncio.run(run()))
