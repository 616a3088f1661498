"""Helpers for the upload-time checks of payload mission items.

A payload's mission action carries its check (:class:`~companion.modes.auto_items.MissionAction`),
so a ground station learns at upload, with the MAV_MISSION_* code of the offending parameter,
that an item could not run.  Ranges come from the payload's parameter table, so they follow the
parameters' documented limits; 0 and NaN select the parameter's default.
"""

from __future__ import annotations

import math

from companion.guidance.geo import Coordinate, lat_lon_problem
from companion.mission import validate as v
from companion.mission.items import MissionItem
from companion.params import ParamDef


def is_default(x: float) -> bool:
    """0 and NaN select the parameter default (MAVLink: NaN = unchanged/default)."""
    return math.isnan(x) or x == 0.0


def param_range(params: tuple[ParamDef, ...], name: str) -> tuple[float, float]:
    p = next(p for p in params if p.name == name)
    return float(p.min), float(p.max)


def in_range(x: float, bounds: tuple[float, float]) -> bool:
    return math.isfinite(x) and bounds[0] <= x <= bounds[1]


def check_coordinates(item: MissionItem) -> v.ItemProblem | None:
    """Finite coordinates on the globe (also for the float MISSION_ITEM encoding)."""
    if (bad := lat_lon_problem(item.lat_deg, item.lon_deg)) is None:
        return None
    code = v.INVALID_PARAM6_Y if bad.coordinate is Coordinate.LONGITUDE else v.INVALID_PARAM5_X
    return v.ItemProblem(code, f"item {item.seq}: {bad.text}")
