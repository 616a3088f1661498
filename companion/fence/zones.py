"""The zones of a FENCE plan as geometry in a local north-east frame.

A FENCE plan (MAV_MISSION_TYPE_FENCE) holds inclusion and exclusion polygons (consecutive
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_* items, param1 = the polygon's vertex count) and circles
(MAV_CMD_NAV_FENCE_CIRCLE_*, param1 = radius in metres).  As in ArduPilot (without
FENCE_OPTIONS bit 1 "inclusion union") the boat must be inside EVERY inclusion zone and outside
every exclusion zone.

Everything is measured by one number, the *clearance* of a point: its distance (m) to the
nearest boundary it must not cross, positive where the point is allowed and negative where it
is not.  For a circle of centre c and radius R: ``R - |p - c|`` (inclusion) and its negative
(exclusion).  For a polygon: the distance to the nearest edge, with the sign of the even-odd
(ray casting) inside test.  The clearance of the fence is the minimum over its zones.  Positions
are projected on the tangent plane at the first vertex (:class:`~companion.guidance.geo.LocalFrame`;
below 1 cm per km of error for a boat's working area).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from companion.guidance.geo import LocalFrame, distance_to_segment_m
from companion.mission import items as mi
from companion.mission.items import MissionItem

Point = tuple[float, float]
"""(north_m, east_m) in the fence's local frame."""


class ZoneKind(enum.Enum):
    INCLUSION = "inclusion"
    EXCLUSION = "exclusion"


@dataclass(frozen=True, slots=True)
class CircleZone:
    kind: ZoneKind
    centre_ne: Point
    radius_m: float

    def clearance_m(self, p: Point) -> float:
        inside_m = self.radius_m - math.hypot(p[0] - self.centre_ne[0], p[1] - self.centre_ne[1])
        return inside_m if self.kind is ZoneKind.INCLUSION else -inside_m

    def describe(self) -> str:
        return f"{self.kind.value} circle"


@dataclass(frozen=True, slots=True)
class PolygonZone:
    kind: ZoneKind
    vertices_ne: tuple[Point, ...]

    def contains(self, p: Point) -> bool:
        """Even-odd rule: a ray from ``p`` towards +east crosses the boundary an odd number of times."""
        inside = False
        verts = self.vertices_ne
        n, e = p
        for i in range(len(verts)):
            (n1, e1), (n2, e2) = verts[i - 1], verts[i]
            if (n1 > n) != (n2 > n):
                e_cross = e1 + (n - n1) * (e2 - e1) / (n2 - n1)
                if e < e_cross:
                    inside = not inside
        return inside

    def edge_distance_m(self, p: Point) -> float:
        verts = self.vertices_ne
        return min(distance_to_segment_m(p, verts[i - 1], verts[i]) for i in range(len(verts)))

    def clearance_m(self, p: Point) -> float:
        d = self.edge_distance_m(p)
        inside_m = d if self.contains(p) else -d
        return inside_m if self.kind is ZoneKind.INCLUSION else -inside_m

    def describe(self) -> str:
        return f"{self.kind.value} polygon"


Zone = CircleZone | PolygonZone

_POLYGONS = {mi.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: ZoneKind.INCLUSION,
             mi.CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: ZoneKind.EXCLUSION}
_CIRCLES = {mi.CMD_NAV_FENCE_CIRCLE_INCLUSION: ZoneKind.INCLUSION,
            mi.CMD_NAV_FENCE_CIRCLE_EXCLUSION: ZoneKind.EXCLUSION}


@dataclass(frozen=True)
class Fence:
    """The zones of one FENCE plan and the frame they are measured in."""

    frame: LocalFrame | None
    zones: tuple[Zone, ...]

    @property
    def empty(self) -> bool:
        return not self.zones

    def to_ne(self, lat_deg: float, lon_deg: float) -> Point:
        assert self.frame is not None
        return self.frame.to_ne(lat_deg, lon_deg)

    def clearance_m(self, p: Point) -> tuple[float, Zone | None]:
        """The fence's clearance at ``p`` and the zone that limits it (``inf, None``: no zones)."""
        best_m, worst = math.inf, None
        for zone in self.zones:
            c = zone.clearance_m(p)
            if c < best_m:
                best_m, worst = c, zone
        return best_m, worst

    def clearance_at_m(self, lat_deg: float, lon_deg: float) -> tuple[float, Zone | None]:
        if self.empty:
            return math.inf, None
        return self.clearance_m(self.to_ne(lat_deg, lon_deg))


NO_FENCE = Fence(None, ())


def fence_from_plan(plan: list[MissionItem]) -> Fence:
    """The zones of a (validated) FENCE plan; incomplete polygons are skipped."""
    if not plan:
        return NO_FENCE
    frame = LocalFrame(plan[0].lat_deg, plan[0].lon_deg)
    zones: list[Zone] = []
    i = 0
    while i < len(plan):
        item = plan[i]
        if item.command in _CIRCLES:
            zones.append(CircleZone(_CIRCLES[item.command], frame.to_ne(item.lat_deg, item.lon_deg),
                                    float(item.param1)))
            i += 1
        elif item.command in _POLYGONS:
            count = int(item.param1) if math.isfinite(item.param1) else 0
            group = plan[i:i + count]
            if count >= 3 and len(group) == count and all(g.command == item.command for g in group):
                zones.append(PolygonZone(_POLYGONS[item.command],
                                         tuple(frame.to_ne(g.lat_deg, g.lon_deg) for g in group)))
                i += count
            else:
                i += 1
        else:
            i += 1
    return Fence(frame, tuple(zones))
