"""The legs a mission drives, and the first item or leg a vehicle refuses.

AUTO drives straight from one positional item to the next (:mod:`companion.modes.auto_items`),
so the route of a mission is the list of straight legs:

* home -> the first positional item (when home is known);
* each positional item -> the next one;
* NAV_RETURN_TO_LAUNCH: the last point -> home (home is the next leg's start);
* DO_JUMP repeated (param2 != 0): the last point -> the first positional item at or after the
  jump target, as well as on to the next positional item after the jump;
* DO_SET_HOME moves home for the legs that follow (param1 = 1: the last point, else its position).

:func:`route_problem` checks every place first (an item outside is refused with
MAV_MISSION_INVALID_PARAM5_X, its position being what is wrong), then every leg
(MAV_MISSION_INVALID: each item may be fine, their sequence is not), each with a sentence naming
the item or the leg ("leg 2-3: leaves the inclusion polygon").
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from companion.guidance.geo import lat_lon_problem
from companion.mission import items as mi
from companion.mission import validate as v
from companion.mission.items import MissionItem

LatLon = tuple[float, float]
PlaceCheck = Callable[[float, float], str | None]
"""``check(lat_deg, lon_deg)``: why the boat may not go there, or ``None``."""
Legs = Sequence[tuple[LatLon, LatLon]]
LegsCheck = Callable[[Legs], tuple[int, str] | None]
"""``check(legs)``: the first of the (start, end) legs the boat may not drive straight and why, or
``None`` (all legs at once: a geofence checks them as arrays)."""
HOME = "home"


@dataclass(frozen=True, slots=True)
class Leg:
    """One straight leg of a mission, named by its ends (item numbers or ``home``)."""

    start_label: str
    end_label: str
    start: LatLon
    end: LatLon
    note: str = ""

    @property
    def name(self) -> str:
        return f"leg {self.start_label}-{self.end_label}" + (f" ({self.note})" if self.note else "")


def _first_positional(items: Sequence[MissionItem], from_seq: int,
                      needs_position: Callable[[MissionItem], bool]) -> MissionItem | None:
    return next((i for i in items if i.seq >= from_seq and needs_position(i)), None)


def mission_legs(items: Sequence[MissionItem], home: LatLon | None,
                 needs_position: Callable[[MissionItem], bool]) -> list[Leg]:
    """The straight legs of ``items`` (the mission without a home placeholder), module doc."""
    legs: list[Leg] = []
    last: tuple[str, LatLon] | None = None if home is None else (HOME, home)
    for item in items:
        if needs_position(item):
            here = (item.lat_deg, item.lon_deg)
            if last is not None:
                legs.append(Leg(last[0], str(item.seq), last[1], here))
            last = (str(item.seq), here)
        elif item.command == mi.CMD_NAV_RETURN_TO_LAUNCH and home is not None:
            if last is not None:
                legs.append(Leg(last[0], HOME, last[1], home))
            last = (HOME, home)
        elif item.command == mi.CMD_DO_JUMP and int(item.param2) != 0 and last is not None:
            target = _first_positional(items, int(item.param1), needs_position)
            if target is not None:
                legs.append(Leg(last[0], str(target.seq), last[1], (target.lat_deg, target.lon_deg),
                                f"DO_JUMP {item.seq}"))
        elif item.command == mi.CMD_DO_SET_HOME:
            if item.param1 == 1 and last is not None:
                home = last[1]
            elif item.is_global and lat_lon_problem(item.lat_deg, item.lon_deg, zero_is_missing=True) is None:
                home = (item.lat_deg, item.lon_deg)
    return legs


def route_problem(items: Sequence[MissionItem], home: LatLon | None,
                  needs_position: Callable[[MissionItem], bool], place_problem: PlaceCheck,
                  legs_problem: LegsCheck) -> v.ItemProblem | None:
    """The first positional item, then the first leg, the vehicle refuses (module doc), or ``None``."""
    for item in items:
        if needs_position(item) and (reason := place_problem(item.lat_deg, item.lon_deg)) is not None:
            return v.ItemProblem(v.INVALID_PARAM5_X, f"item {item.seq}: {reason}")
    legs = mission_legs(items, home, needs_position)
    if (found := legs_problem([(leg.start, leg.end) for leg in legs])) is not None:
        return v.ItemProblem(v.INVALID, f"{legs[found[0]].name}: {found[1]}")
    return None
