"""Which convention a mission upload follows: ArduPilot's home placeholder at item 0, or none.

Two kinds of clients upload missions to an ArduPilot-compatible vehicle:

* **ArduPilot convention** (QGroundControl and Mission Planner for ArduPilot firmware,
  MAVProxy and its ``.waypoints`` files): item 0 is a placeholder for the home position, a
  MAV_CMD_NAV_WAYPOINT in an *absolute-altitude* frame (MAV_FRAME_GLOBAL, QGC's
  ``MissionSettingsItem``; or its ``_INT`` twin) at the planned home; the mission starts at
  item 1, whose waypoints use relative-altitude frames.
* **Plain convention** (MAVSDK's Mission plugin, PX4-style clients): item 0 is the first
  real mission item; MAVSDK sends waypoints in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT.

:func:`classify` decides from the items themselves (see its docstring for the rule) and says
*why*, so the vehicle can tell the operator which convention it recognised.  When the items
do not decide it, the upload is ambiguous and must be refused loudly: silently dropping a
waypoint or silently steering to a placeholder are both worse than an error.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass

from companion.guidance.geo import LocalFrame
from companion.mission import items as mi
from companion.mission.items import MissionItem

HOME_MATCH_M = 25.0
"""A home-shaped item 0 this close to the vehicle's home is the placeholder (GPS and launch-site
drift between planning and upload); farther away, with nothing else to tell, it is ambiguous."""

ABSOLUTE_FRAMES = frozenset({mi.FRAME_GLOBAL, mi.FRAME_GLOBAL_INT})
"""Frames ArduPilot's home item is written in (QGC: MAV_FRAME_GLOBAL; MISSION_ITEM_INT clients may
send its _INT twin)."""


class Convention(enum.Enum):
    """How item 0 of an uploaded mission is to be read."""

    HOME_PLACEHOLDER = "item 0 = home"
    PLAIN = "item 0 = 1st item"


@dataclass(frozen=True, slots=True)
class Verdict:
    """The convention of an upload (``None``: ambiguous) and the reason, for the operator."""

    convention: Convention | None
    reason: str


def looks_like_home(item: MissionItem) -> bool:
    """Item 0 has the shape of ArduPilot's home placeholder: a NAV_WAYPOINT in an absolute frame."""
    return item.command == mi.CMD_NAV_WAYPOINT and item.frame in ABSOLUTE_FRAMES


def classify(plan: Sequence[MissionItem], home: tuple[float, float] | None) -> Verdict:
    """The convention of a complete MISSION upload, for a vehicle whose home is ``home`` (lat, lon).

    1. Item 0 that is not a NAV_WAYPOINT in an absolute frame is a real item (MAVSDK, whose
       waypoints are relative-altitude) -> PLAIN.
    2. A home-shaped item 0 is the placeholder when any of these holds:
       a. it has no position (0, 0): it cannot be a waypoint;
       b. it is the only positional item in an absolute frame while later ones use other frames
          (QGC, MAVProxy and Mission Planner write waypoints relative to home);
       c. it lies within :data:`HOME_MATCH_M` of the vehicle's home;
       d. it is the whole upload and the vehicle has no home yet (an empty ArduPilot mission).
    3. Otherwise (an absolute-frame waypoint away from home, in a plan written entirely in
       absolute frames, or with the home not yet known) the upload is ambiguous: ``None``.
    """
    if not plan:
        return Verdict(Convention.PLAIN, "empty mission")
    first = plan[0]
    if not looks_like_home(first):
        return Verdict(Convention.PLAIN, Convention.PLAIN.value)
    placeholder = Verdict(Convention.HOME_PLACEHOLDER, Convention.HOME_PLACEHOLDER.value)
    if first.x == 0 and first.y == 0:
        return placeholder
    later = [item for item in plan[1:] if item.is_global and (item.x, item.y) != (0, 0)]
    if later and not any(item.frame in ABSOLUTE_FRAMES for item in later):
        return placeholder
    if len(plan) == 1 and home is None:
        return placeholder
    if home is not None:
        off_m = math.hypot(*LocalFrame(*home).to_ne(first.lat_deg, first.lon_deg))
        if off_m <= HOME_MATCH_M:
            return placeholder
        where = f"{off_m:.0f} m from home"
    else:
        where = "home not known yet"
    return Verdict(None, f"item 0 ambiguous (absolute-frame waypoint, {where}): send it relative-alt "
                         "to fly it, or at home as ArduPilot's home placeholder")
