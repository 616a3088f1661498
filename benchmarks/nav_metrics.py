"""The figures of ``usv bench nav`` from one flight: the simulator's truth log cut by the ground
station's timeline.

Positions are the simulator's TRUTH (``usv sitl --truth-log``, 20 Hz of simulated time), not the
vehicle's telemetry; the telemetry is only compared with it (``telemetry_vs_truth_rms_m``, which
also checks that the two time bases agree).  Everything is expressed in metres north/east of the
vehicle's home (HOME_POSITION, as the ground station received it), the frame the mission points
were defined in.  Times of mode changes are the vehicle time of the last timestamped message before
the command's ACK (GLOBAL_POSITION_INT at 10 Hz: at most 0.1 s early).

Definitions (the issue's, made precise where it is silent):

* LOITER: distance from the true position at the LOITER command to every true position over
  the next 120 s: max and RMS.
* arrival (GUIDED go-to, RTL): ``overshoot_m``, how far the boat ran past the point along the
  approach direction (start of the phase -> point), 0 if it never passed it; ``after_arrival_max_m``,
  the largest distance from the point after first coming within WP_RADIUS, until the next command.
* square: ``side_max_m``, the largest distance from the nearest side of the commanded path (the
  first leg starts where AUTO was entered, as the vehicle plans it; then the square's sides), from
  AUTO to mission complete; mid-leg cross-track: distance from the active leg's line while the boat
  is 10 m or more from both of its ends (the rig bench's definition), RMS and max over all legs.
  When AUTO first kept orbiting its hold point (``USV_WP_JOIN``; the vehicle's STATUSTEXT "AUTO:
  leaving the orbit onto the first leg" ends the wait), the first leg starts where the boat left
  the orbit, again as the vehicle plans it; ``side_max_m`` still counts the orbiting (from AUTO's
  start), ``side_max_after_join_m`` only the legs, ``join_s`` is how long AUTO orbited.
  ``first_15s_max_m``: the largest distance from the path in the first 15 s of AUTO.
* sampling circle: from the first time the boat comes within radius + 0.5 m of an item's point
  (the vehicle's own "on the circle" rule) until the item is reached, ``| distance - radius |``
  (the chapter's Fig. 13 tracking error), max and RMS; radius = max(USV_SMPL_CIRC_M, USV_TURN_RAD)
  as the vehicle applies it to an item with radius 0.  Each sample (truth log ``pump_on``/``valve``):
  ``distance_at_end_m``, the distance from its point when the bottle stopped filling (where the
  sample log records it: the sample's position), and ``distance_max_m``, the largest distance from
  its point while the pump ran into that bottle (the chapter's "inside the 2.5 m circle whenever a
  bottle fills").
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from companion.guidance.geo import LocalFrame
from companion.modes.orbit_join import LEAVING_ORBIT_TEXT

MID_LEG_MARGIN_M = 10.0
FIRST_LEG_WINDOW_S = 15.0
"""The start of the square: the largest distance from the path in this long after AUTO starts."""
ON_CIRCLE_MARGIN_M = 0.5
MODE_LOITER, MODE_AUTO, MODE_RTL = 5, 10, 11


class Truth:
    """The truth log in metres north/east of ``home``."""

    def __init__(self, path: Path, home: tuple[float, float]) -> None:
        d = np.genfromtxt(path, delimiter=",", names=True)
        if d.size < 2:
            raise ValueError(f"truth log {path} is empty")
        frame = LocalFrame(*home)
        ne = np.array([frame.to_ne(la, lo) for la, lo in zip(d["lat_deg"], d["lon_deg"], strict=True)])
        self.t = np.asarray(d["t_s"], dtype=float)
        self.n, self.e = ne[:, 0], ne[:, 1]
        self.pump = np.asarray(d["pump_on"], dtype=int)
        self.valve = np.asarray(d["valve"], dtype=int)

    def window(self, t0: float, t1: float) -> np.ndarray:
        return np.flatnonzero((self.t >= t0) & (self.t <= t1))

    def at(self, t_s: float) -> tuple[float, float]:
        return float(np.interp(t_s, self.t, self.n)), float(np.interp(t_s, self.t, self.e))

    def dist(self, idx: np.ndarray, point: tuple[float, float]) -> np.ndarray:
        return np.asarray(np.hypot(self.n[idx] - point[0], self.e[idx] - point[1]))


def rms(x: np.ndarray) -> float:
    """Root mean square of ``x`` (NaN when empty)."""
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else math.nan


def _r(x: float) -> float:
    return round(float(x), 3)


class Timeline:
    """Lookups in the ground station's event list ``[[t_s, kind, value], ...]``."""

    def __init__(self, events: list[list[Any]]) -> None:
        self.events = events

    def times(self, kind: str, value: Any = None) -> list[float]:
        return [float(t) for t, k, v in self.events if k == kind and (value is None or v == value)]

    def one(self, kind: str, value: Any = None, after_s: float = -1.0) -> float:
        for t in self.times(kind, value):
            if t >= after_s:
                return t
        raise LookupError(f"no {kind} {value} after {after_s} s in the timeline")

    def reached(self, t0: float, t1: float) -> dict[int, float]:
        """First MISSION_ITEM_REACHED time of every item between ``t0`` and ``t1``."""
        out: dict[int, float] = {}
        for t, k, v in self.events:
            if k == "reached" and t0 <= t <= t1 and int(v) not in out:
                out[int(v)] = float(t)
        return out


def arrival(truth: Truth, t0: float, t1: float, point: tuple[float, float],
            radius_m: float) -> dict[str, float]:
    idx = truth.window(t0, t1)
    start = truth.at(t0)
    approach = np.array([point[0] - start[0], point[1] - start[1]])
    unit = approach / max(1e-9, float(np.linalg.norm(approach)))
    along_past = (truth.n[idx] - point[0]) * unit[0] + (truth.e[idx] - point[1]) * unit[1]
    d = truth.dist(idx, point)
    inside = np.flatnonzero(d <= radius_m)
    after = d[inside[0]:] if inside.size else np.array([])
    return {"overshoot_m": _r(max(0.0, float(along_past.max()))),
            "after_arrival_max_m": _r(after.max()) if after.size else math.inf,
            "time_to_radius_s": _r(truth.t[idx][inside[0]] - t0) if inside.size else math.inf}


def loiter(truth: Truth, t0: float, duration_s: float) -> dict[str, Any]:
    idx = truth.window(t0, t0 + duration_s)
    entry = truth.at(t0)
    d = truth.dist(idx, entry)
    return {"max_m": _r(d.max()), "rms_m": _r(rms(d)), "entry_ne": [_r(entry[0]), _r(entry[1])]}


def _segment(p: np.ndarray, a: tuple[float, float], b: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Along-track position (m from ``a``) and unsigned cross-track distance of points ``p`` (N x 2)
    from the line a -> b; and the distance to the segment itself."""
    ab = np.array([b[0] - a[0], b[1] - a[1]])
    length = float(np.linalg.norm(ab))
    u = ab / length
    rel = p - np.array(a)
    along = rel @ u
    cross = np.abs(rel[:, 0] * u[1] - rel[:, 1] * u[0])
    clamped = np.clip(along, 0.0, length)
    seg = np.hypot(rel[:, 0] - clamped * u[0], rel[:, 1] - clamped * u[1])
    return np.stack([along, cross]), seg


def mid_leg_cross_m(pts: np.ndarray, a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
    """Cross-track distances from the leg a -> b of the points ``pts`` (N x 2) flown on it that lie
    more than :data:`MID_LEG_MARGIN_M` along from either end (the leg's middle)."""
    (along, cross), _ = _segment(pts, a, b)
    length = math.dist(a, b)
    return np.asarray(cross[(along >= MID_LEG_MARGIN_M) & (along <= length - MID_LEG_MARGIN_M)])


def path_distance(pts: np.ndarray, path: list[tuple[float, float]]) -> np.ndarray:
    """Distance of points ``pts`` (N x 2, north/east) from the nearest segment of the polyline ``path``."""
    return np.asarray(np.min([_segment(pts, path[k], path[k + 1])[1] for k in range(len(path) - 1)], axis=0))


def square(truth: Truth, t0: float, t1: float, corners: list[tuple[float, float]],
           reached: dict[int, float], leg_start_s: float | None = None) -> dict[str, Any]:
    """``leg_start_s``: when the first leg started, if AUTO first kept orbiting its hold point
    (the vehicle's STATUSTEXT); the first leg then starts where the boat was at that moment."""
    joined = t0 if leg_start_s is None else leg_start_s
    path = [truth.at(joined), *corners]

    def side_distance(t_from: float, t_to: float) -> tuple[np.ndarray, np.ndarray]:
        idx = truth.window(t_from, t_to)
        pts = np.stack([truth.n[idx], truth.e[idx]], axis=1)
        return path_distance(pts, path), pts

    side, pts = side_distance(t0, t1)
    mid: list[np.ndarray] = []
    leg_start = joined
    for k in range(1, len(corners) + 1):
        leg_end = reached.get(k, t1)
        sel = truth.window(leg_start, leg_end)
        p = np.stack([truth.n[sel], truth.e[sel]], axis=1)
        mid.append(mid_leg_cross_m(p, path[k - 1], path[k]))
        leg_start = leg_end
    mids = np.concatenate(mid) if mid else np.array([])
    worst = int(np.argmax(side))
    return {"side_max_m": _r(side.max()), "side_max_at_ne": [_r(pts[worst, 0]), _r(pts[worst, 1])],
            "first_15s_max_m": _r(side_distance(t0, t0 + FIRST_LEG_WINDOW_S)[0].max()),
            "join_s": _r(joined - t0), "side_max_after_join_m": _r(side_distance(joined, t1)[0].max()),
            "mid_leg_rms_m": _r(rms(mids)), "mid_leg_max_m": _r(mids.max()) if mids.size else math.nan,
            "legs_completed": len(reached), "duration_s": _r(t1 - t0)}


def sampling(truth: Truth, t0: float, t1: float, points: list[tuple[float, float]],
             reached: dict[int, float], radius_m: float, reported: list[list[float]]) -> dict[str, Any]:
    errors: list[np.ndarray] = []
    items: list[dict[str, Any]] = []
    bounds = [t0, *(reached.get(k, t1) for k in range(1, len(points) + 1))]
    for k, point in enumerate(points, start=1):
        idx = truth.window(bounds[k - 1], bounds[k])
        d = truth.dist(idx, point)
        on = np.flatnonzero(d <= radius_m + ON_CIRCLE_MARGIN_M)
        err = np.abs(d[on[0]:] - radius_m) if on.size else np.array([math.inf])
        errors.append(err)
        items.append({"item": k, "circle_error_max_m": _r(err.max()), "circle_error_rms_m": _r(rms(err)),
                      "duration_s": _r(bounds[k] - bounds[k - 1])})
    step_s = float(np.median(np.diff(truth.t)))
    samples: list[dict[str, Any]] = []
    run = truth.window(t0, t1)
    for bottle in range(1, 5):
        rows = run[(truth.pump[run] == 1) & (truth.valve[run] == bottle)]
        if not rows.size:
            continue
        # the item whose time the bottle started filling in
        k = max(1, min(len(points), int(np.searchsorted(bounds, truth.t[rows[0]], side="right"))))
        d = truth.dist(rows, points[k - 1])
        samples.append({"bottle": bottle, "item": k, "distance_max_m": _r(d.max()),
                        "distance_at_end_m": _r(d[-1]), "pump_s": _r(rows.size * step_s)})
    all_err = np.concatenate(errors)
    return {"radius_m": radius_m, "circle_error_max_m": _r(all_err.max()),
            "circle_error_rms_m": _r(rms(all_err[np.isfinite(all_err)])),
            "sample_distance_max_m": max((s["distance_at_end_m"] for s in samples), default=math.inf),
            "fill_distance_max_m": max((s["distance_max_m"] for s in samples), default=math.inf),
            "samples_taken": len(samples), "items": items, "samples": samples,
            "companion_reported_distance_m": [[int(b), _r(dist)] for b, dist in reported],
            "duration_s": _r(t1 - t0)}


def telemetry_vs_truth(truth: Truth, positions: list[list[float]], home: tuple[float, float]) -> float:
    """RMS distance between GLOBAL_POSITION_INT and the truth at the same vehicle time (m)."""
    if not positions:
        return math.nan
    frame = LocalFrame(*home)
    arr = np.array([(t, *frame.to_ne(la, lo)) for t, la, lo in positions])
    n = np.interp(arr[:, 0], truth.t, truth.n)
    e = np.interp(arr[:, 0], truth.t, truth.e)
    return _r(rms(np.hypot(arr[:, 1] - n, arr[:, 2] - e)))


def figures(flight: dict[str, Any]) -> dict[str, Any]:
    """Every figure of one flight (``Flight.to_json()``); raises LookupError if a phase is missing."""
    home = (float(flight["home"][0]), float(flight["home"][1]))
    truth = Truth(Path(flight["truth_csv"]), home)
    tl = Timeline(flight["events"])
    plan, params = flight["plan"], flight["params"]
    wp_radius = float(params["WP_RADIUS"])
    t_goto = tl.one("goto")
    t_loiter = tl.one("set_mode", MODE_LOITER)
    t_rtl = tl.one("set_mode", MODE_RTL)
    t_square, t_end = tl.one("set_mode", MODE_AUTO), tl.one("phase", "mission_done")
    reached = tl.reached(t_square, t_end)
    n_corners = len(plan["square_ne"])
    t_samples = reached.get(n_corners, t_end)  # the square's last corner, where sampling begins
    loiter_s = min(120.0, t_rtl - t_loiter)
    radius = max(float(params["USV_SMPL_CIRC_M"]), float(params["USV_TURN_RAD"]))
    reported = [e[2] for e in flight["events"] if e[1] == "sample_reported"]
    leg_start_s = next((float(t) for t, kind, text in flight["events"] if kind == "statustext"
                        and t >= t_square and str(text).startswith(LEAVING_ORBIT_TEXT)), None)
    return {
        "goto_arrival": arrival(truth, t_goto, t_loiter, tuple(plan["goto_ne"]), wp_radius),
        "loiter": loiter(truth, t_loiter, loiter_s),
        "rtl_arrival": arrival(truth, t_rtl, t_square, (0.0, 0.0), wp_radius),
        "square": square(truth, t_square, t_samples, [tuple(c) for c in plan["square_ne"]],
                         {k: t for k, t in reached.items() if k <= n_corners}, leg_start_s),
        "sampling": sampling(truth, t_samples, t_end, [tuple(p) for p in plan["sample_points_ne"]],
                             {k - n_corners: t for k, t in reached.items() if k > n_corners}, radius,
                             reported),
        "telemetry_vs_truth_rms_m": telemetry_vs_truth(truth, flight.get("positions", []), home),
    }
