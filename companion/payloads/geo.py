"""Small geodesy helpers for the payloads (equirectangular, fine over a few hundred metres)."""

from __future__ import annotations

import math

EARTH_RADIUS_M = 6_371_000.0


def distance_m(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Horizontal distance between two points (equirectangular approximation)."""
    lat_mid = math.radians(0.5 * (lat1_deg + lat2_deg))
    dn = math.radians(lat2_deg - lat1_deg) * EARTH_RADIUS_M
    de = math.radians(lon2_deg - lon1_deg) * EARTH_RADIUS_M * math.cos(lat_mid)
    return math.hypot(dn, de)


def bearing_deg(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Bearing from point 1 to point 2, degrees clockwise from north in [0, 360)."""
    lat_mid = math.radians(0.5 * (lat1_deg + lat2_deg))
    dn = math.radians(lat2_deg - lat1_deg)
    de = math.radians(lon2_deg - lon1_deg) * math.cos(lat_mid)
    return math.degrees(math.atan2(de, dn)) % 360.0


def angle_diff_deg(a_deg: float, b_deg: float) -> float:
    """Signed smallest difference a - b in (-180, 180]."""
    d = (a_deg - b_deg + 180.0) % 360.0 - 180.0
    return 180.0 if d == -180.0 else d
