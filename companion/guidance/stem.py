"""Holding on a circle in a current the boat cannot circle in: stem the current on the circle.

A jet boat that cannot reverse circles a point by turning through the water; in a current ``c``
every lap of period ``T = 2 pi R_w / U_w`` carries it ``c T`` downstream (at the simulated boat's
tightest turn, R_w ~ 1.7 m at U_w ~ 1 m/s, that is 5-10 m per lap in 0.5-1.2 m/s: the sampling
circle's measured error).  To close the circle over ground the water-relative turn must tighten on
the downstream side by the factor ``(U_g / (U_g - c))^2`` (curvature of the water path at the
downstream point of a ground circle of radius R travelled at U_g), which the hull cannot do once
``c`` is a sizeable part of its speed.  So above a current threshold the circle item keeps
station ON the circle instead, the way a coxswain stems a tide: the hold point is where the
circle meets the line through the centre across the current, on the side the boat is on::

    c_hat = c / |c|,  p_hat = c_hat rotated 90 deg toward the boat
    hold    = centre + R p_hat
    staging = hold + D c_hat                      (D down-current of the hold point)

The boat runs to ``staging`` (abeam of the circle first when it comes from up-current), turns into
the current there and follows the line ``staging -> hold``, which touches the circle at ``hold``
only: it never crosses the circle's inside.  On the hold point the station keeper
(:mod:`companion.guidance.station`) starts with its current estimate seeded from ``c`` (no
exploratory loop while an integral learns it).
"""

from __future__ import annotations

import math

Point = tuple[float, float]

STAGING_M = 8.0
"""D: how far down-current of the hold point the boat turns into the current."""
ABEAM_M = 5.0
"""Coming from up-current, the boat first passes this far outside the circle, abeam of it."""


def stem_route(centre_ne: Point, radius_m: float, current_ne_mps: tuple[float, float],
               pos_ne: Point) -> list[Point]:
    """Waypoints (north-east metres) from ``pos_ne`` to the hold point, which is the last one."""
    speed = math.hypot(*current_ne_mps)
    if speed <= 0.0:
        raise ValueError("stem_route needs a current")
    cn, ce = current_ne_mps[0] / speed, current_ne_mps[1] / speed
    rel_n, rel_e = pos_ne[0] - centre_ne[0], pos_ne[1] - centre_ne[1]
    side = 1.0 if (-ce * rel_n + cn * rel_e) <= 0.0 else -1.0  # which side of the current line
    pn, pe = side * ce, -side * cn  # unit vector across the current, toward the boat's side
    hold = (centre_ne[0] + radius_m * pn, centre_ne[1] + radius_m * pe)
    staging = (hold[0] + STAGING_M * cn, hold[1] + STAGING_M * ce)
    route = [staging, hold]
    if rel_n * cn + rel_e * ce < STAGING_M / 2.0:  # not yet well down-current: go round abeam
        abeam = (centre_ne[0] + (radius_m + ABEAM_M) * pn, centre_ne[1] + (radius_m + ABEAM_M) * pe)
        route.insert(0, abeam)
    return route
