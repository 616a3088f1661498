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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.fence.zones import CircleZone, Fence, Point, PolygonZone, Zone, ZoneKind
from companion.guidance.geo import distance_to_segment_m

MARGIN_TOLERANCE_M = 0.01
"""A leg may approach the boundary this much closer than its ends before it counts (rounding)."""
_SAME_T = 1e-9
"""Two crossings closer than this (in leg fractions) are one (a vertex shared by two edges)."""


@dataclass(frozen=True, slots=True)
class LegClearance:
    """How one leg meets one zone: clearances (m, negative where forbidden) and boundary crossings."""

    zone: Zone
    start_m: float
    end_m: float
    min_m: float
    """Smallest clearance along the leg (exact without crossings; ``min(start, end, 0)`` with them)."""
    crossings: int


def _cross(u: Point, v: Point) -> float:
    return u[0] * v[1] - u[1] * v[0]


def _segment_distance_m(p: Point, a: Point, b: Point) -> float:
    if a == b:
        return math.hypot(p[0] - a[0], p[1] - a[1])
    return distance_to_segment_m(p, a, b)


def _crossing_ts(a: Point, b: Point, p: Point, q: Point) -> float | None:
    """Fraction along ``a -> b`` where it meets the edge ``p -> q`` (``None``: they do not meet;
    parallel edges count as not meeting, their distance is then what limits the leg)."""
    d = (b[0] - a[0], b[1] - a[1])
    e = (q[0] - p[0], q[1] - p[1])
    den = _cross(d, e)
    if den == 0.0:
        return None
    ap = (p[0] - a[0], p[1] - a[1])
    t = _cross(ap, e) / den
    s = _cross(ap, d) / den
    return t if 0.0 <= t <= 1.0 and 0.0 <= s <= 1.0 else None


def _distinct(ts: list[float]) -> int:
    count, last = 0, -math.inf
    for t in sorted(ts):
        if t - last > _SAME_T:
            count += 1
        last = t
    return count


def _polygon_leg(zone: PolygonZone, a: Point, b: Point) -> LegClearance:
    verts = zone.vertices_ne
    edges = [(verts[i - 1], verts[i]) for i in range(len(verts))]
    ts = [t for p, q in edges if (t := _crossing_ts(a, b, p, q)) is not None]
    start_m, end_m = zone.clearance_m(a), zone.clearance_m(b)
    crossings = _distinct(ts)
    if crossings or start_m < 0.0:
        return LegClearance(zone, start_m, end_m, min(start_m, end_m, 0.0), crossings)
    distance_m = min(min(_segment_distance_m(p, a, b), _segment_distance_m(a, p, q),
                         _segment_distance_m(b, p, q), _segment_distance_m(q, a, b)) for p, q in edges)
    return LegClearance(zone, start_m, end_m, distance_m, 0)


def _circle_leg(zone: CircleZone, a: Point, b: Point) -> LegClearance:
    c, r = zone.centre_ne, zone.radius_m
    u = (a[0] - c[0], a[1] - c[1])
    d = (b[0] - a[0], b[1] - a[1])
    qa, qb, qc = d[0] ** 2 + d[1] ** 2, 2.0 * (u[0] * d[0] + u[1] * d[1]), u[0] ** 2 + u[1] ** 2 - r * r
    disc = qb * qb - 4.0 * qa * qc
    ts: list[float] = []
    if qa > 0.0 and disc >= 0.0:
        root = math.sqrt(disc)
        ts = [t for t in ((-qb - root) / (2 * qa), (-qb + root) / (2 * qa)) if 0.0 <= t <= 1.0]
    if zone.kind is ZoneKind.INCLUSION:
        min_m = r - max(math.hypot(*u), math.hypot(b[0] - c[0], b[1] - c[1]))
    else:
        min_m = _segment_distance_m(c, a, b) - r
    return LegClearance(zone, zone.clearance_m(a), zone.clearance_m(b), min_m, _distinct(ts))


def leg_clearance(zone: Zone, a: Point, b: Point) -> LegClearance:
    """How the leg ``a -> b`` meets ``zone`` (module doc)."""
    return _polygon_leg(zone, a, b) if isinstance(zone, PolygonZone) else _circle_leg(zone, a, b)


def leg_problem(fence: Fence, a: Point, b: Point, margin_m: float, *, keep_margin: bool = True) -> str | None:
    """Why the boat may not drive straight from ``a`` to ``b`` (module doc), or ``None``.

    ``keep_margin`` False checks crossings only (a fence action's way home may run along the edge)."""
    for zone in fence.zones:
        leg = leg_clearance(zone, a, b)
        what = zone.describe()
        if leg.end_m < 0.0:
            return f"ends outside the {what} ({leg.end_m:.0f} m)"
        if leg.start_m < 0.0:
            if leg.crossings > 1:
                return f"crosses the {what} {leg.crossings} times"
            continue
        if leg.crossings:
            verb = "leaves the" if zone.kind is ZoneKind.INCLUSION else "crosses the"
            return f"{verb} {what}"
        allowed_m = min(margin_m, leg.start_m, leg.end_m) - MARGIN_TOLERANCE_M
        if keep_margin and leg.min_m < allowed_m:
            return f"passes within FENCE_MARGIN of the {what} ({leg.min_m:.0f} m)"
    return None
