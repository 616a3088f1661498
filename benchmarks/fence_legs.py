"""Geofence leg checks: how long the vehicle's loop is held by checking a whole mission's legs
against the fence (at upload, at a new fence, on entering AUTO), all legs at once
(:func:`companion.fence.legs.legs_problem`) and one leg at a time for comparison."""

from __future__ import annotations

import itertools
import math
import time
from typing import Any

from companion.fence.legs import leg_problem, legs_problem
from companion.fence.zones import Fence, PolygonZone, ZoneKind
from companion.guidance.geo import LocalFrame


def _fence(vertices: int) -> Fence:
    """A round inclusion polygon of radius 1 km with ``vertices`` corners and a rock in the middle."""
    step_rad = 2 * math.pi / vertices
    ring = tuple((1000.0 * math.cos(step_rad * i), 1000.0 * math.sin(step_rad * i)) for i in range(vertices))
    rock = ((-20.0, -20.0), (-20.0, 20.0), (20.0, 20.0), (20.0, -20.0))
    return Fence(LocalFrame(41.77, 123.43), (PolygonZone(ZoneKind.INCLUSION, ring),
                                              PolygonZone(ZoneKind.EXCLUSION, rock)))


def run(quick: bool) -> dict[str, Any]:
    legs_n, vertices = (200, 50) if quick else (999, 196)
    fence = _fence(vertices)
    points = [(500.0 * math.cos(0.1 * i), 500.0 * math.sin(0.1 * i)) for i in range(legs_n + 1)]
    legs = list(itertools.pairwise(points))
    t0 = time.perf_counter()
    if legs_problem(fence, legs, 2.0) is not None:
        raise RuntimeError("the benchmark route should be allowed")
    batched_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for a, b in legs:
        leg_problem(fence, a, b, 2.0)
    one_by_one_s = time.perf_counter() - t0
    return {"legs": legs_n, "fence_vertices": vertices + 4, "all_legs_at_once_s": round(batched_s, 4),
            "one_leg_at_a_time_s": round(one_by_one_s, 4)}
