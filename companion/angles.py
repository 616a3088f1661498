"""Angle wrapping, and a vector's component along a heading, shared by guidance, control and
telemetry (radians)."""

from __future__ import annotations

import math


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def wrap_2pi(angle_rad: float) -> float:
    """Wrap an angle to [0, 2*pi) (headings and courses, clockwise from north)."""
    return angle_rad % (2.0 * math.pi)


def current_along_mps(heading_rad: float, current_ne_mps: tuple[float, float] | None) -> float:
    """The current's component along the bow (m/s, positive from astern); 0 without an estimate."""
    return current_body_mps(heading_rad, current_ne_mps)[0]


def current_body_mps(heading_rad: float, current_ne_mps: tuple[float, float] | None) -> tuple[float, float]:
    """``R(psi)^T V_c`` for one heading: the current along the bow (positive from astern) and across
    it (positive toward starboard), m/s; (0, 0) without an estimate
    (:func:`companion.models.current.current_body` does it for arrays of a log)."""
    if current_ne_mps is None:
        return 0.0, 0.0
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return current_ne_mps[0] * c + current_ne_mps[1] * s, -current_ne_mps[0] * s + current_ne_mps[1] * c


def upstream_rad(current_ne_mps: tuple[float, float]) -> float:
    """The heading straight into the current ``(north, east)`` m/s (bow upstream)."""
    return math.atan2(-current_ne_mps[1], -current_ne_mps[0])


def angle_between_rad(a_ne: tuple[float, float], b_ne: tuple[float, float]) -> float:
    """The angle (0..pi) between two (north, east) vectors' directions."""
    return abs(wrap_pi(math.atan2(a_ne[1], a_ne[0]) - math.atan2(b_ne[1], b_ne[0])))
