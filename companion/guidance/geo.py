"""Geodesy, the product's one module for it: angles, positions and a local flat-earth frame.

For the distances a flood-rescue boat covers on one mission (< 10 km) a tangent-plane
projection about a fixed origin (home) is standard practice (Fossen, Handbook of Marine Craft
Hydrodynamics and Motion Control, 2nd ed., section 2.5.2 "flat-Earth navigation"): the error
against the ellipsoid is below 1 cm per km.  The meridian and prime-vertical radii of the WGS-84
ellipsoid at the origin latitude scale degrees to metres (:class:`LocalFrame`,
:func:`distance_m`).  Angles: :func:`wrap_pi`, :func:`wrap_2pi` (defined in
:mod:`companion.angles`, which the control package imports without guidance, re-exported here);
positions: :func:`lat_lon_problem`.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from companion.angles import wrap_2pi, wrap_pi

__all__ = ["WGS84_A_M", "WGS84_E2", "Coordinate", "LocalFrame", "PositionProblem", "distance_bearing",
           "distance_m", "distance_to_segment_m", "lat_lon_problem", "valid_lat_lon", "wrap_2pi", "wrap_pi"]

WGS84_A_M = 6378137.0
"""WGS-84 semi-major axis."""
WGS84_E2 = 6.69437999014e-3
"""WGS-84 first eccentricity squared."""


class Coordinate(enum.Enum):
    """Which part of a position is wrong (mission uploads answer with a per-field error code)."""

    LATITUDE = "latitude"
    LONGITUDE = "longitude"
    BOTH = "position"


@dataclass(frozen=True, slots=True)
class PositionProblem:
    coordinate: Coordinate
    text: str


def lat_lon_problem(lat_deg: float, lon_deg: float, *,
                    zero_is_missing: bool = False) -> PositionProblem | None:
    """Why (``lat_deg``, ``lon_deg``) is not a position on the globe, or ``None``: the one
    validator of positions from ground stations, missions and sensors.

    ``zero_is_missing``: also refuse exactly 0, 0, which clients send for "no coordinates".
    """
    if not (math.isfinite(lat_deg) and -90.0 <= lat_deg <= 90.0):
        return PositionProblem(Coordinate.LATITUDE, f"latitude {lat_deg:g} outside [-90, 90]")
    if not (math.isfinite(lon_deg) and -180.0 <= lon_deg <= 180.0):
        return PositionProblem(Coordinate.LONGITUDE, f"longitude {lon_deg:g} outside [-180, 180]")
    if zero_is_missing and lat_deg == 0.0 and lon_deg == 0.0:
        return PositionProblem(Coordinate.BOTH, "position 0,0 (missing coordinates)")
    return None


def valid_lat_lon(lat_deg: float, lon_deg: float) -> bool:
    """True when both are finite and inside [-90, 90] x [-180, 180]."""
    return lat_lon_problem(lat_deg, lon_deg) is None


def _radii_m(lat_deg: float) -> tuple[float, float]:
    """(meridian radius R_N, prime-vertical radius R_E) of WGS-84 at ``lat_deg``."""
    s = math.sin(math.radians(lat_deg))
    den = 1.0 - WGS84_E2 * s * s
    r_e = WGS84_A_M / math.sqrt(den)
    r_n = WGS84_A_M * (1.0 - WGS84_E2) / den**1.5
    return r_n, r_e


@dataclass(frozen=True, slots=True)
class LocalFrame:
    """Tangent plane at (``lat0_deg``, ``lon0_deg``): x north, y east, in metres."""

    lat0_deg: float
    lon0_deg: float

    def __post_init__(self) -> None:
        if not valid_lat_lon(self.lat0_deg, self.lon0_deg) or abs(self.lat0_deg) > 89.0:
            raise ValueError(f"invalid frame origin ({self.lat0_deg}, {self.lon0_deg})")

    @property
    def _radii_m(self) -> tuple[float, float]:
        """(meridian radius R_N, prime-vertical radius R_E) at the origin latitude."""
        return _radii_m(self.lat0_deg)

    def to_ne(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """Geodetic degrees -> (north_m, east_m) relative to the origin."""
        r_n, r_e = self._radii_m
        d_lon = (lon_deg - self.lon0_deg + 180.0) % 360.0 - 180.0
        north_m = math.radians(lat_deg - self.lat0_deg) * r_n
        east_m = math.radians(d_lon) * r_e * math.cos(math.radians(self.lat0_deg))
        return north_m, east_m

    def to_lat_lon(self, north_m: float, east_m: float) -> tuple[float, float]:
        """(north_m, east_m) relative to the origin -> geodetic degrees."""
        r_n, r_e = self._radii_m
        lat_deg = self.lat0_deg + math.degrees(north_m / r_n)
        lon_deg = self.lon0_deg + math.degrees(east_m / (r_e * math.cos(math.radians(self.lat0_deg))))
        lon_deg = (lon_deg + 180.0) % 360.0 - 180.0
        return lat_deg, lon_deg


def distance_m(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """Horizontal distance (m) between two nearby positions: the flat-earth projection of
    :class:`LocalFrame` about their mean latitude (never raises; NaN in, NaN out)."""
    lat_mid_deg = 0.5 * (lat1_deg + lat2_deg)
    r_n, r_e = _radii_m(lat_mid_deg)
    d_lon_deg = (lon2_deg - lon1_deg + 180.0) % 360.0 - 180.0
    north_m = math.radians(lat2_deg - lat1_deg) * r_n
    east_m = math.radians(d_lon_deg) * r_e * math.cos(math.radians(lat_mid_deg))
    return math.hypot(north_m, east_m)


def distance_to_segment_m(p_ne: tuple[float, float], a_ne: tuple[float, float],
                          b_ne: tuple[float, float]) -> float:
    """Distance (m) from the point ``p_ne`` to the segment ``a_ne -> b_ne`` (north-east metres)."""
    dn, de = b_ne[0] - a_ne[0], b_ne[1] - a_ne[1]
    length2 = dn * dn + de * de
    along = (p_ne[0] - a_ne[0]) * dn + (p_ne[1] - a_ne[1]) * de
    t = 0.0 if length2 == 0.0 else max(0.0, min(1.0, along / length2))  # a point: its distance
    return math.hypot(p_ne[0] - a_ne[0] - t * dn, p_ne[1] - a_ne[1] - t * de)


def turn_to_go_rad(lam: float, from_rad: float, to_rad: float) -> float:
    """The turn (rad, within +-pi) from the direction ``from_rad`` to ``to_rad`` the way ``lam``
    says (+1 clockwise, heading increasing; -1 counter-clockwise); negative when ``from_rad`` has
    already turned past ``to_rad`` that way."""
    return lam * wrap_pi(to_rad - from_rad)


def distance_bearing(north_m: float, east_m: float) -> tuple[float, float]:
    """Length (m) and bearing (rad, clockwise from north, [0, 2*pi)) of a north-east vector."""
    return math.hypot(north_m, east_m), wrap_2pi(math.atan2(east_m, north_m))


def along_across_m(pos_ne: tuple[float, float], ref_ne: tuple[float, float],
                   current_ne_mps: tuple[float, float]) -> tuple[float, float]:
    """Where ``pos_ne`` lies from ``ref_ne`` (m): downstream along the current (negative: upstream),
    and across it (positive: to the right looking downstream)."""
    cn, ce = current_ne_mps
    speed = max(math.hypot(cn, ce), 1e-6)
    dn, de = pos_ne[0] - ref_ne[0], pos_ne[1] - ref_ne[1]
    return (dn * cn + de * ce) / speed, (-dn * ce + de * cn) / speed
