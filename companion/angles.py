"""Angle wrapping shared by guidance, control and telemetry (radians)."""

from __future__ import annotations

import math


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def wrap_2pi(angle_rad: float) -> float:
    """Wrap an angle to [0, 2*pi) (headings and courses, clockwise from north)."""
    return angle_rad % (2.0 * math.pi)
