"""Legs: the straight path between two places, checked against the fence's zones.

ArduPilot Rover does not plan paths: between two mission items, and from the boat to a GUIDED
target, it drives straight.  So a leg is refused when the straight segment ``a -> b`` (local
north-east metres, :mod:`.zones`) would take the boat where it must not go, zone by zone:

* **crossing**: the segment meets the zone's boundary while both ends are allowed (it leaves an
  inclusion zone and comes back, or cuts through an exclusion zone).  Crossings are the roots
  ``t`` in [0, 1] of ``a + t (b - a)`` on the boundary: for a polygon, the segment-segment
  intersections with its edges (``t = cross(p - a, e) / cross(d, e)``, the same ``t`` from two
  edges meeting at a vertex counted once); for a circle of centre ``c`` and radius ``R`` the roots
  of ``|a - c + t d|^2 = R^2``.
* **margin** (``keep_margin``): a leg that does not cross must still not come closer to the
  boundary than ``min(FENCE_MARGIN, clearance at a, clearance at b)``, the closest its ends already
  are (a boat within the margin may still leave the edge).  On the allowed side the smallest
  clearance along a segment is its distance to the boundary: for a polygon the minimum over edges
  of the segment-segment distance (the smallest of the four end-to-segment distances when they do
  not intersect); for an inclusion circle ``R - max(|a - c|, |b - c|)`` (a disc is convex), for an
  exclusion circle ``dist(c, segment) - R``.
* **coming back in**: a leg that starts where the zone forbids (a boat pushed out of the fence,
  a home outside it) may cross the boundary once, on its way in; more often is refused.
* a leg that ends where the zone forbids is refused (its end is outside the fence).

Every leg of a mission is checked against every edge at once (numpy arrays of legs x edges): a
1000-item mission against a 200-vertex fence takes milliseconds, not the seconds a loop over
legs would hold the 100 Hz loop for.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from companion.fence.zones import CircleZone, Fence, Point, PolygonZone, Zone, ZoneKind

MARGIN_TOLERANCE_M = 0.01
"""A leg may approach the boundary this much closer than its ends before it counts (rounding)."""
_SAME_T = 1e-9
"""Two crossings closer than this (in leg fractions) are one (a vertex shared by two edges)."""

Array = np.ndarray


@dataclass(frozen=True)
class LegClearances:
    """How legs meet one zone, one entry per leg: clearances (m, negative where forbidden) and crossings."""

    zone: Zone
    start_m: Array
    end_m: Array
    min_m: Array
    """Smallest clearance along each leg (exact without crossings; ``min(start, end, 0)`` with them)."""
    crossings: Array


def _dot(u: Array, v: Array) -> Array:
    return np.asarray(np.sum(u * v, axis=-1))


def _point_segments_m(p: Array, a: Array, b: Array) -> Array:
    """Distances (m) from points ``p`` to segments ``a -> b`` (arrays ``(..., 2)``, broadcast)."""
    d = b - a
    dd = _dot(d, d)
    t = np.clip(_dot(p - a, d) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
    r = p - a - t[..., None] * d
    return np.asarray(np.hypot(r[..., 0], r[..., 1]))


def _distinct_count(ts: Array, hit: Array) -> Array:
    """Per row, the number of distinct crossing fractions among ``ts[hit]`` (a vertex shared by two
    edges is one crossing)."""
    misses = 2.0 + np.arange(ts.shape[1])  # sort after every hit and never repeat
    srt = np.sort(np.where(hit, ts, misses[None, :]), axis=1)
    repeats = (np.diff(srt, axis=1) <= _SAME_T) & (srt[:, 1:] <= 1.0)
    return np.asarray(np.count_nonzero(hit, axis=1) - np.count_nonzero(repeats, axis=1))


def _polygon_legs(zone: PolygonZone, a: Array, b: Array) -> LegClearances:
    """Crossings ``t = cross(p - a, e) / cross(d, e)``, ``u = cross(p - a, d) / cross(d, e)`` for every
    leg (rows) and edge (columns); the ends' clearances by :meth:`PolygonZone.clearance_m`'s rule."""
    q = np.asarray(zone.vertices_ne, dtype=float)
    p = np.roll(q, 1, axis=0)  # edge i runs from vertex i-1 to vertex i
    d, e = b - a, q - p
    ap = p[None, :, :] - a[:, None, :]
    den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    safe = np.where(den != 0.0, den, 1.0)
    t = (ap[..., 0] * e[None, :, 1] - ap[..., 1] * e[None, :, 0]) / safe
    u = (ap[..., 0] * d[:, None, 1] - ap[..., 1] * d[:, None, 0]) / safe
    hit = (den != 0.0) & (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
    crossings = _distinct_count(t, hit)
    ends = np.concatenate([a, b])  # (2L, 2)
    to_edges = _point_segments_m(ends[:, None, :], p[None, :, :], q[None, :, :]).min(axis=1)
    spans = (p[None, :, 0] > ends[:, None, 0]) != (q[None, :, 0] > ends[:, None, 0])
    dn = np.where(e[:, 0] != 0.0, e[:, 0], 1.0)
    e_cross = p[None, :, 1] + (ends[:, None, 0] - p[None, :, 0]) * e[None, :, 1] / dn
    inside = (np.count_nonzero(spans & (ends[:, None, 1] < e_cross), axis=1) % 2) == 1
    clearance = np.where(inside == (zone.kind is ZoneKind.INCLUSION), to_edges, -to_edges)
    n_legs = len(a)
    start_m, end_m = clearance[:n_legs], clearance[n_legs:]
    to_leg = _point_segments_m(q[None, :, :], a[:, None, :], b[:, None, :]).min(axis=1)
    along_m = np.minimum(np.minimum(to_edges[:n_legs], to_edges[n_legs:]), to_leg)
    crossed = (crossings > 0) | (start_m < 0.0)
    min_m = np.where(crossed, np.minimum(np.minimum(start_m, end_m), 0.0), along_m)
    return LegClearances(zone, start_m, end_m, min_m, crossings)


def _circle_legs(zone: CircleZone, a: Array, b: Array) -> LegClearances:
    """Roots of ``|a - c + t d|^2 = R^2`` in [0, 1]; ``R - max(|a - c|, |b - c|)`` (inclusion) or
    ``dist(c, leg) - R`` (exclusion) along the leg."""
    c, r = np.asarray(zone.centre_ne, dtype=float), zone.radius_m
    u, d = a - c, b - a
    qa, qb, qc = _dot(d, d), 2.0 * _dot(u, d), _dot(u, u) - r * r
    disc = qb * qb - 4.0 * qa * qc
    ok = (qa > 0.0) & (disc >= 0.0)
    root = np.sqrt(np.where(ok, disc, 0.0))
    two_a = np.where(ok, 2.0 * qa, 1.0)
    ts = np.stack([(-qb - root) / two_a, (-qb + root) / two_a], axis=1)
    hit = ok[:, None] & (ts >= 0.0) & (ts <= 1.0)
    from_centre_a, from_centre_b = np.hypot(u[:, 0], u[:, 1]), np.hypot(b[:, 0] - c[0], b[:, 1] - c[1])
    sign = 1.0 if zone.kind is ZoneKind.INCLUSION else -1.0
    if zone.kind is ZoneKind.INCLUSION:
        min_m = r - np.maximum(from_centre_a, from_centre_b)
    else:
        min_m = _point_segments_m(c[None, :], a, b) - r
    return LegClearances(zone, sign * (r - from_centre_a), sign * (r - from_centre_b), min_m,
                         _distinct_count(ts, hit))


def leg_clearances(zone: Zone, a: Array, b: Array) -> LegClearances:
    """How the legs ``a[i] -> b[i]`` (arrays ``(L, 2)``, north-east m) meet ``zone`` (module doc)."""
    return _polygon_legs(zone, a, b) if isinstance(zone, PolygonZone) else _circle_legs(zone, a, b)


def _why(legs: LegClearances, i: int) -> str:
    what = legs.zone.describe()
    if legs.end_m[i] < 0.0:
        side = "inside" if legs.zone.kind is ZoneKind.EXCLUSION else "outside"
        return f"ends {side} the {what} ({legs.end_m[i]:.0f} m)"
    if legs.start_m[i] < 0.0:
        return f"crosses the {what} {legs.crossings[i]} times"
    if legs.crossings[i]:
        return f"{'leaves' if legs.zone.kind is ZoneKind.INCLUSION else 'crosses'} the {what}"
    return f"passes within FENCE_MARGIN of the {what} ({legs.min_m[i]:.0f} m)"


def legs_problem(fence: Fence, legs_ne: Sequence[tuple[Point, Point]], margin_m: float, *,
                 keep_margin: bool = True) -> tuple[int, str] | None:
    """The first leg the boat may not drive straight (module doc) and why, or ``None``.

    ``keep_margin`` False checks crossings only (a fence action's way home may run along the edge)."""
    if not legs_ne or fence.empty:
        return None
    ends = np.asarray(legs_ne, dtype=float).reshape(len(legs_ne), 2, 2)
    a, b = ends[:, 0, :], ends[:, 1, :]
    first: tuple[int, str] | None = None
    for zone in fence.zones:
        legs = leg_clearances(zone, a, b)
        start_out, end_out = legs.start_m < 0.0, legs.end_m < 0.0
        allowed_m = np.minimum(np.minimum(margin_m, legs.start_m), legs.end_m) - MARGIN_TOLERANCE_M
        too_close = (legs.min_m < allowed_m) if keep_margin else np.zeros(len(a), dtype=bool)
        bad = end_out | np.where(start_out, legs.crossings > 1, (legs.crossings > 0) | too_close)
        hits = np.flatnonzero(bad)
        if hits.size and (first is None or hits[0] < first[0]):
            first = (int(hits[0]), _why(legs, int(hits[0])))
    return first


def leg_problem(fence: Fence, a: Point, b: Point, margin_m: float, *, keep_margin: bool = True) -> str | None:
    """Why the boat may not drive straight from ``a`` to ``b`` (:func:`legs_problem`), or ``None``."""
    found = legs_problem(fence, [(a, b)], margin_m, keep_margin=keep_margin)
    return None if found is None else found[1]
