"""Upload-time validation of mission, fence and rally items.

An item the boat could not execute is refused while it is uploaded, with the
MAV_MISSION_RESULT code the protocol defines for the problem, so the operator learns it
at the ground station instead of in the middle of a flood.  Checks:

* the frame is one the boat understands (global frames, or MAV_FRAME_MISSION for
  commands without a position) -> ``MAV_MISSION_UNSUPPORTED_FRAME``;
* the command is known for that mission type -> ``MAV_MISSION_UNSUPPORTED``;
* positions are finite and on the globe (|lat| <= 90, |lon| <= 180, not 0/0 for a
  navigation item) -> ``MAV_MISSION_INVALID_PARAM5_X`` / ``..._PARAM6_Y``;
* parameters a command needs are finite and in range -> ``MAV_MISSION_INVALID_PARAMn``.

NaN in an optional parameter (e.g. yaw in param4 of a waypoint, which MAVSDK and QGC send)
means "unchanged" as the MAVLink specification says, and is accepted.  Altitude is unused
on a boat; a NaN altitude is accepted for the same reason.  A vehicle validates with a
:class:`MissionValidator` that also knows its payloads' mission commands and their checks;
:func:`validate_item` / :func:`validate_plan` use the built-in commands only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from companion.guidance.geo import Coordinate, lat_lon_problem
from companion.mission import items as mi
from companion.mission.items import MissionItem, MissionType

MAX_ITEMS: dict[int, int] = {MissionType.MISSION: 1000, MissionType.FENCE: 200, MissionType.RALLY: 50}
"""Capacity per mission type (larger uploads get MAV_MISSION_NO_SPACE)."""

MAX_SPEED_MPS = 12.0
"""Fastest speed a DO_CHANGE_SPEED may ask for (the boat's 36 km/h top speed is 10 m/s)."""

# MAV_MISSION_RESULT codes.
ACCEPTED = 0
ERROR = 1
UNSUPPORTED_FRAME = 2
UNSUPPORTED = 3
NO_SPACE = 4
INVALID = 5
INVALID_PARAM1 = 6
INVALID_PARAM2 = 7
INVALID_PARAM3 = 8
INVALID_PARAM4 = 9
INVALID_PARAM5_X = 10
INVALID_PARAM6_Y = 11
INVALID_PARAM7 = 12
INVALID_SEQUENCE = 13
DENIED = 14
OPERATION_CANCELLED = 15


@dataclass(frozen=True, slots=True)
class ItemProblem:
    """Why an item was refused: a MAV_MISSION_RESULT code and a sentence for the operator."""

    code: int
    reason: str


ItemCheck = Callable[[MissionItem], ItemProblem | None]

# command -> needs a position
_MISSION_COMMANDS: dict[int, bool] = {
    mi.CMD_NAV_WAYPOINT: True,
    mi.CMD_NAV_LOITER_UNLIM: True,
    mi.CMD_NAV_LOITER_TURNS: True,
    mi.CMD_NAV_LOITER_TIME: True,
    mi.CMD_NAV_RETURN_TO_LAUNCH: False,
    mi.CMD_NAV_DELAY: False,
    mi.CMD_CONDITION_DELAY: False,
    mi.CMD_DO_JUMP: False,
    mi.CMD_DO_CHANGE_SPEED: False,
    mi.CMD_DO_SET_HOME: False,
    mi.CMD_DO_SET_SERVO: False,
    mi.CMD_DO_SET_RELAY: False,
    **{c: True for c in range(mi.CMD_USER_WAYPOINT_FIRST, mi.CMD_USER_WAYPOINT_LAST + 1)},
    **{c: False for c in range(mi.CMD_USER_FIRST, mi.CMD_USER_LAST + 1)},
}
_FENCE_COMMANDS: dict[int, bool] = {
    mi.CMD_NAV_FENCE_RETURN_POINT: True,  # QGC's "breach return"; stored, not used (Rover returns home)
    mi.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: True,
    mi.CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: True,
    mi.CMD_NAV_FENCE_CIRCLE_INCLUSION: True,
    mi.CMD_NAV_FENCE_CIRCLE_EXCLUSION: True,
}
_RALLY_COMMANDS: dict[int, bool] = {mi.CMD_NAV_RALLY_POINT: True}
_COMMANDS_BY_TYPE = {MissionType.MISSION: _MISSION_COMMANDS, MissionType.FENCE: _FENCE_COMMANDS,
                     MissionType.RALLY: _RALLY_COMMANDS}


_POLYGON_VERTICES = (mi.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, mi.CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)


def polygon_groups_problem(plan: list[MissionItem]) -> str | None:
    """Why the polygon vertices of a FENCE plan do not form whole polygons (each run of one vertex
    command holds exactly param1 items, param1 the same in all of them), or ``None``."""
    i = 0
    while i < len(plan):
        item = plan[i]
        if item.command not in _POLYGON_VERTICES:
            i += 1
            continue
        count = int(item.param1) if math.isfinite(item.param1) else 0
        group = plan[i:i + count]
        if count < 3 or len(group) < count or any(
                g.command != item.command or g.param1 != item.param1 for g in group):
            return f"item {item.seq}: polygon of {item.param1:g} vertices is incomplete"
        i += count
    return None


@dataclass(frozen=True, slots=True)
class ItemRule:
    """A mission command beyond the built-in ones: position needed, and an extra check."""

    needs_position: bool
    check: ItemCheck | None = None


def _finite(value: float) -> bool:
    return math.isfinite(value)


def _check_position(item: MissionItem) -> ItemProblem | None:
    lat_deg, lon_deg = item.lat_deg, item.lon_deg
    if not item.is_global:
        return ItemProblem(UNSUPPORTED_FRAME, f"item {item.seq}: frame {item.frame} is not a global frame")
    if (bad := lat_lon_problem(lat_deg, lon_deg, zero_is_missing=True)) is not None:
        code = INVALID_PARAM6_Y if bad.coordinate is Coordinate.LONGITUDE else INVALID_PARAM5_X
        return ItemProblem(code, f"item {item.seq}: {bad.text}")
    if math.isinf(item.z):
        return ItemProblem(INVALID_PARAM7, f"item {item.seq}: altitude {item.z} is not finite")
    return None


def _check_params(item: MissionItem) -> ItemProblem | None:
    c, s = item.command, item.seq
    if c == mi.CMD_DO_CHANGE_SPEED:
        speed = item.param2
        if not _finite(speed) or not (speed == -1.0 or speed == -2.0 or 0.0 <= speed <= MAX_SPEED_MPS):
            return ItemProblem(INVALID_PARAM2, f"item {s}: speed {speed} m/s outside [0, {MAX_SPEED_MPS:g}]")
    if c in (mi.CMD_NAV_WAYPOINT,) and _finite(item.param1) and item.param1 < 0:
        return ItemProblem(INVALID_PARAM1, f"item {s}: negative hold time {item.param1} s")
    if c in (mi.CMD_NAV_WAYPOINT,) and _finite(item.param2) and item.param2 < 0:
        return ItemProblem(INVALID_PARAM2, f"item {s}: negative acceptance radius {item.param2} m")
    if c in (mi.CMD_NAV_LOITER_TIME, mi.CMD_NAV_DELAY, mi.CMD_CONDITION_DELAY) and (
            not _finite(item.param1) or item.param1 < (-1.0 if c == mi.CMD_NAV_DELAY else 0.0)):
        return ItemProblem(INVALID_PARAM1, f"item {s}: time {item.param1} s must be finite and >= 0")
    if c == mi.CMD_NAV_LOITER_TURNS and (not _finite(item.param1) or item.param1 <= 0):
        return ItemProblem(INVALID_PARAM1, f"item {s}: turns {item.param1} must be > 0")
    if c == mi.CMD_DO_JUMP and (not _finite(item.param1) or item.param1 < 0
                               or item.param1 != int(item.param1)):
        return ItemProblem(INVALID_PARAM1, f"item {s}: jump target {item.param1} is not an item number")
    if c in (mi.CMD_NAV_FENCE_CIRCLE_INCLUSION, mi.CMD_NAV_FENCE_CIRCLE_EXCLUSION) and (
            not _finite(item.param1) or item.param1 <= 0):
        return ItemProblem(INVALID_PARAM1, f"item {s}: fence radius {item.param1} m must be > 0")
    if c in (mi.CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, mi.CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION) and (
            not _finite(item.param1) or item.param1 < 3):
        return ItemProblem(INVALID_PARAM1, f"item {s}: polygon needs >= 3 vertices, got {item.param1}")
    return None


class MissionValidator:
    """Upload checks of one vehicle: the built-in commands plus ``extra`` (its payloads')."""

    def __init__(self, extra: Mapping[int, ItemRule] | None = None) -> None:
        self.extra = dict(extra or {})
        self._mission_commands = {**_MISSION_COMMANDS,
                                  **{c: rule.needs_position for c, rule in self.extra.items()}}

    def validate_item(self, item: MissionItem, *, home_item: bool = False) -> ItemProblem | None:
        """Check one item; ``None`` when it is fine.  ``home_item``: item 0 of an ArduPilot mission."""
        if not 0 <= item.autocontinue <= 1 or not 0 <= item.current <= 2:
            return ItemProblem(INVALID, f"item {item.seq}: current/autocontinue must be 0 or 1")
        if home_item:
            # ArduPilot ignores the content of item 0 (it is replaced by home); accept anything sane.
            return None
        try:
            mtype = MissionType(item.mission_type)
        except ValueError:
            return ItemProblem(UNSUPPORTED, f"mission type {item.mission_type} is not supported")
        table = self._mission_commands if mtype == MissionType.MISSION else _COMMANDS_BY_TYPE[mtype]
        if item.command not in table:
            return ItemProblem(UNSUPPORTED, f"item {item.seq}: command {item.command} is not supported "
                                            f"in a {mtype.name.lower()} plan")
        needs_position = table[item.command]
        if needs_position:
            problem = _check_position(item)
        elif item.frame not in mi.GLOBAL_FRAMES | {mi.FRAME_MISSION}:
            problem = ItemProblem(UNSUPPORTED_FRAME, f"item {item.seq}: frame {item.frame} is not supported")
        else:
            problem = None
        problem = problem or _check_params(item)
        rule = self.extra.get(item.command)
        if problem is None and rule is not None and rule.check is not None:
            problem = rule.check(item)
        return problem

    def validate_plan(self, plan: list[MissionItem], *, home_first: bool) -> ItemProblem | None:
        """Check a whole plan: sequence numbers, capacity, every item, DO_JUMP targets."""
        if not plan:
            return None
        mtype = plan[0].mission_type
        if len(plan) > MAX_ITEMS.get(mtype, 0):
            capacity = MAX_ITEMS.get(mtype, 0)
            return ItemProblem(NO_SPACE, f"{len(plan)} items exceed the capacity of {capacity}")
        for index, item in enumerate(plan):
            if item.seq != index:
                return ItemProblem(INVALID_SEQUENCE, f"item {index} arrived with seq {item.seq}")
            problem = self.validate_item(item, home_item=home_first and index == 0
                                         and mtype == MissionType.MISSION)
            if problem is not None:
                return problem
            if item.command == mi.CMD_DO_JUMP and int(item.param1) >= len(plan):
                return ItemProblem(INVALID_PARAM1,
                                   f"item {index}: jump target {int(item.param1)} does not exist")
        if mtype == MissionType.FENCE and (reason := polygon_groups_problem(plan)) is not None:
            return ItemProblem(INVALID_PARAM1, reason)
        return None

    def needs_position(self, item: MissionItem) -> bool:
        """Whether ``item`` is a command with a position (a place the boat is sent to, in a mission)."""
        table = self._mission_commands if item.mission_type == MissionType.MISSION else \
            _COMMANDS_BY_TYPE.get(MissionType(item.mission_type), {})
        return bool(table.get(item.command, False))


BUILT_IN = MissionValidator()
"""The built-in commands only (no payload checks)."""


def validate_item(item: MissionItem, *, home_item: bool = False) -> ItemProblem | None:
    """:meth:`MissionValidator.validate_item` with the built-in commands."""
    return BUILT_IN.validate_item(item, home_item=home_item)


def validate_plan(plan: list[MissionItem], *, home_first: bool) -> ItemProblem | None:
    """:meth:`MissionValidator.validate_plan` with the built-in commands."""
    return BUILT_IN.validate_plan(plan, home_first=home_first)
