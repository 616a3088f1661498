"""GPS point tracking: approach a point and circle it at a given radius.

The course law is the orbit vector field of Beard and McLain (Small Unmanned Aircraft, 2012,
Eq. 10.13), the circular-path counterpart of the LOS law of Fossen's handbook (section 12.4):
with ``phi`` the bearing from the centre to the boat, ``d`` the distance and ``lam`` = +1 for
clockwise (starboard turn) circling, -1 for anticlockwise::

    e_r   = d - R                                      radial error (m)
    chi_d = phi + lam * (pi/2 + atan(k * (e_r + ki * integral(e_r)) / R))

Far away (``d >> R``) the atan tends to pi/2 and the boat heads straight for the point
(approach); on the circle it follows the tangent.  The integral of the radial error plays the
role of ILOS's integral state in a current.  The feed-forward course rate for steady circling
is ``lam * U / d``.  The radius defaults to the boat's minimum turning radius (the chapter's
water-sampling experiment, Fig. 12), so callers pass ``max(radius, min_turn_radius)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.guidance.geo import distance_bearing, wrap_2pi


@dataclass(frozen=True, slots=True)
class CircleGains:
    k_orbit: float = 2.0
    """Convergence gain k (dimensionless): larger turns onto the circle more sharply."""
    ki_per_s: float = 0.05
    """Integral gain on the radial error (1/s)."""
    integral_max_m: float = 3.0
    """Bound on the integral term (m)."""

    def __post_init__(self) -> None:
        if not (self.k_orbit > 0 and self.ki_per_s >= 0 and self.integral_max_m >= 0):
            raise ValueError(f"invalid circle gains {self}")


@dataclass(frozen=True, slots=True)
class CircleOutput:
    course_rad: float
    course_rate_radps: float
    radial_error_m: float
    distance_m: float


class CircleTracker:
    """Circle a centre point (north-east metres) at ``radius_m``; clockwise when ``clockwise``."""

    def __init__(self, centre_ne: tuple[float, float], radius_m: float, clockwise: bool = True,
                 gains: CircleGains | None = None) -> None:
        if not (radius_m > 0 and math.isfinite(radius_m)):
            raise ValueError(f"circle radius must be positive, got {radius_m}")
        self.centre_ne = centre_ne
        self.radius_m = radius_m
        self.lam = 1.0 if clockwise else -1.0
        self.gains = gains or CircleGains()
        self.integral_m = 0.0

    def set_clockwise(self, clockwise: bool) -> None:
        """Circle clockwise (starboard turn) or anticlockwise from now on."""
        self.lam = 1.0 if clockwise else -1.0

    def update(self, pos_ne: tuple[float, float], speed_mps: float, dt_s: float) -> CircleOutput:
        g = self.gains
        dn, de = pos_ne[0] - self.centre_ne[0], pos_ne[1] - self.centre_ne[1]
        d, phi = distance_bearing(dn, de)
        e_r = d - self.radius_m
        # integrate only near the circle, where the radial error reflects current, not approach
        if abs(e_r) < self.radius_m:
            self.integral_m += g.ki_per_s * e_r * dt_s
            self.integral_m = min(g.integral_max_m, max(-g.integral_max_m, self.integral_m))
        arg = g.k_orbit * (e_r + self.integral_m) / self.radius_m
        chi = phi + self.lam * (math.pi / 2.0 + math.atan(arg))
        rate = self.lam * speed_mps / max(d, 0.5 * self.radius_m) if abs(e_r) < self.radius_m else 0.0
        return CircleOutput(course_rad=wrap_2pi(chi), course_rate_radps=rate, radial_error_m=e_r,
                            distance_m=d)
