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
    abeam   = centre + (R + ABEAM_M) p_hat

The boat first runs to a point abeam of the circle, ``ABEAM_M`` outside it on the hold point's
side (never across the circle's inside), and from there the station keeper
(:class:`companion.guidance.holding.CurrentStationKeeper`) ferries it across the current onto the
hold point, bow within 70 deg of up-current, with ``c`` as its feed-forward (no exploratory loop
while an integral learns it).

A current weaker than the jet's idle creep ``U_0`` cannot be stemmed on a point: bow into it the
boat creeps upstream at ``U_0 - |c|`` (0.2 m/s in 0.5 m/s).  There the hold point is turned
``downstream_rad`` along the circle, downstream of the line across the current, so that the
creep runs along a chord of the circle instead of off it::

    hold = centre + R (cos a p_hat + sin a c_hat)

creeping ``s`` upstream from it the distance from the centre is ``sqrt((R sin a - s)^2 + R^2 cos^2 a)``:
with ``a`` = 30 deg and R = 2 m it stays within 0.3 m of R for the first 2 m (10 s at 0.2 m/s,
longer than a sample's pumping).  The boat is brought there from straight downstream of the hold
point (:func:`below_route`): bow into the current, the current brakes it.
"""

from __future__ import annotations

import math

from companion.guidance.geo import distance_to_segment_m

Point = tuple[float, float]

ABEAM_M = 5.0
"""The boat first goes this far outside the circle, abeam of the hold point."""


def stem_route(centre_ne: Point, radius_m: float, current_ne_mps: tuple[float, float],
               pos_ne: Point, abeam_m: float = ABEAM_M, downstream_rad: float = 0.0) -> list[Point]:
    """[abeam, hold] (north-east metres) for a boat at ``pos_ne``: the abeam point ``abeam_m``
    outside the circle across the current, the hold point turned ``downstream_rad`` from the
    line across the current toward downstream."""
    speed = math.hypot(*current_ne_mps)
    if speed <= 0.0:
        raise ValueError("stem_route needs a current")
    cn, ce = current_ne_mps[0] / speed, current_ne_mps[1] / speed
    rel_n, rel_e = pos_ne[0] - centre_ne[0], pos_ne[1] - centre_ne[1]
    side = 1.0 if (-ce * rel_n + cn * rel_e) <= 0.0 else -1.0  # which side of the current line
    pn, pe = side * ce, -side * cn  # unit vector across the current, toward the boat's side
    ca, sa = math.cos(downstream_rad), math.sin(downstream_rad)
    hold = (centre_ne[0] + radius_m * (ca * pn + sa * cn), centre_ne[1] + radius_m * (ca * pe + sa * ce))
    abeam = (centre_ne[0] + (radius_m + abeam_m) * pn, centre_ne[1] + (radius_m + abeam_m) * pe)
    return [abeam, hold]


def below_route(centre_ne: Point, radius_m: float, current_ne_mps: tuple[float, float], pos_ne: Point,
                abeam_ne: Point, hold_ne: Point, below_m: float, clear_m: float) -> list[Point]:
    """[below] or [abeam, below]: the point ``below_m`` straight downstream of ``hold_ne``, by the
    abeam point when the straight way there from ``pos_ne`` passes within ``clear_m`` of the circle."""
    speed = math.hypot(*current_ne_mps)
    if speed <= 0.0:
        raise ValueError("below_route needs a current")
    cn, ce = current_ne_mps[0] / speed, current_ne_mps[1] / speed
    below = (hold_ne[0] + below_m * cn, hold_ne[1] + below_m * ce)
    crosses = distance_to_segment_m(centre_ne, pos_ne, below) < radius_m + clear_m
    return [abeam_ne, below] if crosses else [below]
