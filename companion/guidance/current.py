"""Guidance's own estimate of the water current, and the crab heading that cancels it.

A water-jet boat running straight has almost no sway through the water, so the sideways part of
its velocity over ground is the current's component across the bow (Fossen 2021, Eq. 2.115 with
``v_r ~ 0``).  With ``h_perp(psi) = (-sin psi, cos psi)`` the unit vector to starboard::

    y   = v_g . h_perp(psi)                 observed: current across the bow (m/s)
    c^ += (dt / tau) * (y - c^ . h_perp) * h_perp

is a least-mean-squares observer of the earth-frame current ``c^`` (north, east) that learns the
component across the bow on every heading the boat steers; legs in two directions (a corner, the
approach to a point) make the whole vector observable.  Samples taken while turning faster than
``max_turn_rate_radps`` are skipped (a turning hull slips sideways through the water).  The
estimate includes the wind's leeway, which is also a drift the guidance must steer against.

With ``c^`` known, the heading that makes good a course ``chi`` at water speed ``U_w`` is (solve
``U_w sin(psi - chi) + c^ . h_perp(chi) = 0``)::

    psi = chi - asin(c_perp / U_w),   c_perp = c^ . h_perp(chi)

the crab feed-forward: it changes the moment the desired course changes (corners, circles) instead
of waiting for the measured crab angle or an integral to build up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.guidance.geo import wrap_2pi, wrap_pi

MAX_CRAB_SIN = 0.8
"""Largest |sin| of the crab angle the feed-forward asks for (53 deg): more is not steerable."""


@dataclass(frozen=True, slots=True)
class ObserverGains:
    tau_s: float = 6.0
    """Time constant of the observer along each observed direction (s)."""
    max_turn_rate_radps: float = 0.12
    """Samples taken while turning faster than this are skipped (sideslip)."""
    min_speed_mps: float = 0.3
    """Below this speed over ground the heading and velocity say little; skipped."""
    current_max_mps: float = 3.0
    """Bound on the estimate."""

    def __post_init__(self) -> None:
        if not (self.tau_s > 0 and self.max_turn_rate_radps > 0 and self.current_max_mps > 0):
            raise ValueError(f"invalid current observer gains {self}")


class CurrentObserver:
    """Earth-frame current (north, east m/s) from over-ground velocity and heading (module docstring)."""

    def __init__(self, gains: ObserverGains | None = None) -> None:
        self.gains = gains or ObserverGains()
        self.north_mps = 0.0
        self.east_mps = 0.0
        self.observed_s = 0.0
        """Seconds of samples the estimate has learnt from."""
        self._seen_n = 0.0
        self._seen_e = 0.0

    @property
    def current_ne_mps(self) -> tuple[float, float]:
        return (self.north_mps, self.east_mps)

    @property
    def converged(self) -> bool:
        """Both directions have been observed for at least one time constant."""
        return min(self._seen_n, self._seen_e) >= self.gains.tau_s

    def agrees(self, current_ne_mps: tuple[float, float], tolerance_mps: float) -> bool:
        """Whether ``current_ne_mps`` is within ``tolerance_mps`` of the estimate on the north and
        the east axis, each checked once it has been observed for one time constant (after one
        straight leg only the component across it is known)."""
        g = self.gains
        if self._seen_n >= g.tau_s and abs(current_ne_mps[0] - self.north_mps) > tolerance_mps:
            return False
        return not (self._seen_e >= g.tau_s and abs(current_ne_mps[1] - self.east_mps) > tolerance_mps)

    def update(self, vel_north_mps: float, vel_east_mps: float, heading_rad: float, r_radps: float,
               dt_s: float) -> None:
        g = self.gains
        if not (dt_s > 0 and math.isfinite(vel_north_mps) and math.isfinite(vel_east_mps)
                and math.isfinite(heading_rad)):
            return
        if abs(r_radps) > g.max_turn_rate_radps or math.hypot(vel_north_mps, vel_east_mps) < g.min_speed_mps:
            return
        pn, pe = -math.sin(heading_rad), math.cos(heading_rad)
        y = vel_north_mps * pn + vel_east_mps * pe
        k = min(1.0, dt_s / g.tau_s) * (y - (self.north_mps * pn + self.east_mps * pe))
        self.north_mps += k * pn
        self.east_mps += k * pe
        mag = math.hypot(self.north_mps, self.east_mps)
        if mag > g.current_max_mps:
            self.north_mps *= g.current_max_mps / mag
            self.east_mps *= g.current_max_mps / mag
        self.observed_s += dt_s
        self._seen_n += dt_s * pn * pn
        self._seen_e += dt_s * pe * pe


def crab_heading(course_rad: float, water_speed_mps: float, current_ne_mps: tuple[float, float]) -> float:
    """Heading (rad, [0, 2 pi)) that makes good ``course_rad`` through ``current_ne_mps`` at
    ``water_speed_mps`` (module docstring); the crab is capped at asin(:data:`MAX_CRAB_SIN`)."""
    c_perp = -current_ne_mps[0] * math.sin(course_rad) + current_ne_mps[1] * math.cos(course_rad)
    s = c_perp / max(water_speed_mps, 1e-3)
    s = max(-MAX_CRAB_SIN, min(MAX_CRAB_SIN, s))
    return wrap_2pi(course_rad - math.asin(s))


def water_speed_mps(vel_north_mps: float, vel_east_mps: float, current_ne_mps: tuple[float, float]) -> float:
    """Speed through the water: |v_g - c^| (m/s)."""
    return math.hypot(vel_north_mps - current_ne_mps[0], vel_east_mps - current_ne_mps[1])


def steady_crab_rad(course_rad: float, water_speed_mps: float, current_ne_mps: tuple[float, float]) -> float:
    """The crab angle, course over ground less heading (rad, -pi..pi), that makes good ``course_rad``
    through ``current_ne_mps`` at ``water_speed_mps`` in steady running (:func:`crab_heading`)."""
    return wrap_pi(course_rad - crab_heading(course_rad, water_speed_mps, current_ne_mps))
