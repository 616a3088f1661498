"""Upload-time checks of the payload mission items (dialect ``USV_CMD_NAV_*``).

Registered with :func:`companion.mission.validate.register_item_check` by
:class:`~companion.payloads.service.PayloadService` (:func:`register_mission_checks`), so a
ground station learns at upload, with the MAV_MISSION_* code of the offending parameter,
that an item could not run:

``USV_CMD_NAV_SAMPLE_HERE`` (31001)
    param1 bottle: a whole number 0-4 (0 = next empty; NaN = next) -> INVALID_PARAM1;
    param2 circle radius: 0/NaN (USV_SMPL_CIRC_M) or within USV_SMPL_CIRC_M's range
    -> INVALID_PARAM2; param3 fill time: 0/NaN or within USV_SMPL_FILL_S's
    range -> INVALID_PARAM3; param4 volume: 0/NaN or within (0, USV_SMPL_BTL_ML max]
    -> INVALID_PARAM4.
``USV_CMD_NAV_LAUNCH_AT`` (31000)
    param1 bearing: NaN (keep the heading on arrival) or finite in [0, 360] -> INVALID_PARAM1;
    param2 hold: 0/NaN (USV_LNCH_HOLD_S) or within USV_LNCH_HOLD_S's range -> INVALID_PARAM2.

Both need finite coordinates on the globe (``INVALID_PARAM5_X`` / ``INVALID_PARAM6_Y``),
checked here again for the float MISSION_ITEM encoding.  Ranges come from the parameter
table (:mod:`companion.payloads.params`), so they follow the parameters' documented limits.
"""

from __future__ import annotations

import math

from companion.mission import validate as v
from companion.mission.items import MissionItem
from companion.payloads.params import PARAMS
from mavlink_dialect import UsvCmd

_RANGES = {p.name: (float(p.min), float(p.max)) for p in PARAMS}


def _default(x: float) -> bool:
    """0 and NaN select the parameter default (MAVLink: NaN = unchanged/default)."""
    return math.isnan(x) or x == 0.0


def _in_range(x: float, name: str) -> bool:
    lo, hi = _RANGES[name]
    return math.isfinite(x) and lo <= x <= hi


def _check_coordinates(item: MissionItem) -> v.ItemProblem | None:
    lat_deg, lon_deg = item.lat_deg, item.lon_deg
    if not (math.isfinite(lat_deg) and -90.0 <= lat_deg <= 90.0):
        return v.ItemProblem(v.INVALID_PARAM5_X, f"item {item.seq}: latitude {lat_deg} is not valid")
    if not (math.isfinite(lon_deg) and -180.0 <= lon_deg <= 180.0):
        return v.ItemProblem(v.INVALID_PARAM6_Y, f"item {item.seq}: longitude {lon_deg} is not valid")
    return None


def check_sample_here(item: MissionItem) -> v.ItemProblem | None:
    """USV_CMD_NAV_SAMPLE_HERE: bottle, circle radius, fill time, volume, coordinates."""
    s = item.seq
    bottle = item.param1
    if not math.isnan(bottle) and not (math.isfinite(bottle) and bottle == int(bottle) and 0 <= bottle <= 4):
        return v.ItemProblem(v.INVALID_PARAM1, f"item {s}: bottle {bottle:g} not 0-4 (0 = next)")
    if not _default(item.param2) and not _in_range(item.param2, "USV_SMPL_CIRC_M"):
        lo, hi = _RANGES["USV_SMPL_CIRC_M"]
        return v.ItemProblem(v.INVALID_PARAM2, f"item {s}: radius {item.param2:g} m not in {lo:g}-{hi:g} m")
    if not _default(item.param3) and not _in_range(item.param3, "USV_SMPL_FILL_S"):
        lo, hi = _RANGES["USV_SMPL_FILL_S"]
        return v.ItemProblem(v.INVALID_PARAM3, f"item {s}: fill {item.param3:g} s not in {lo:g}-{hi:g} s")
    if not _default(item.param4) and not (math.isfinite(item.param4)
                                          and 0.0 < item.param4 <= _RANGES["USV_SMPL_BTL_ML"][1]):
        hi = _RANGES["USV_SMPL_BTL_ML"][1]
        return v.ItemProblem(v.INVALID_PARAM4, f"item {s}: volume {item.param4:g} mL not in 0-{hi:g} mL")
    return _check_coordinates(item)


def check_launch_at(item: MissionItem) -> v.ItemProblem | None:
    """USV_CMD_NAV_LAUNCH_AT: bearing, hold time, coordinates."""
    s = item.seq
    bearing = item.param1
    if not math.isnan(bearing) and not (math.isfinite(bearing) and 0.0 <= bearing <= 360.0):
        return v.ItemProblem(v.INVALID_PARAM1, f"item {s}: bearing {bearing:g} deg not in 0-360 (NaN = keep)")
    if not _default(item.param2) and not _in_range(item.param2, "USV_LNCH_HOLD_S"):
        lo, hi = _RANGES["USV_LNCH_HOLD_S"]
        return v.ItemProblem(v.INVALID_PARAM2, f"item {s}: hold {item.param2:g} s not in {lo:g}-{hi:g} s")
    return _check_coordinates(item)


def register_mission_checks() -> None:
    """Register both checks (idempotent; both items need a position)."""
    v.register_item_check(UsvCmd.NAV_SAMPLE_HERE, check_sample_here, needs_position=True)
    v.register_item_check(UsvCmd.NAV_LAUNCH_AT, check_launch_at, needs_position=True)
