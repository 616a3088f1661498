"""Mission items as the vehicle stores them: one frozen record per MISSION_ITEM_INT.

Coordinates keep MAVLink's integer encoding (degrees x 1e7 in ``x``/``y`` for global
frames) so a download returns exactly what was uploaded; :attr:`MissionItem.lat_deg` and
:attr:`MissionItem.lon_deg` give degrees.  ``mission_type`` is MAV_MISSION_TYPE (0 mission,
1 fence, 2 rally).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from typing import Any


class MissionType(enum.IntEnum):
    """MAV_MISSION_TYPE."""

    MISSION = 0
    FENCE = 1
    RALLY = 2


# MAV_FRAME values used by mission items.
FRAME_GLOBAL = 0
FRAME_LOCAL_NED = 1
FRAME_MISSION = 2
FRAME_GLOBAL_RELATIVE_ALT = 3
FRAME_LOCAL_ENU = 4
FRAME_GLOBAL_INT = 5
FRAME_GLOBAL_RELATIVE_ALT_INT = 6
FRAME_GLOBAL_TERRAIN_ALT = 10
FRAME_GLOBAL_TERRAIN_ALT_INT = 11
GLOBAL_FRAMES = frozenset({FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_INT,
                           FRAME_GLOBAL_RELATIVE_ALT_INT, FRAME_GLOBAL_TERRAIN_ALT,
                           FRAME_GLOBAL_TERRAIN_ALT_INT})

# MAV_CMD values the vehicle understands in missions.
CMD_NAV_WAYPOINT = 16
CMD_NAV_LOITER_UNLIM = 17
CMD_NAV_LOITER_TURNS = 18
CMD_NAV_LOITER_TIME = 19
CMD_NAV_RETURN_TO_LAUNCH = 20
CMD_NAV_DELAY = 93
CMD_DO_JUMP = 177
CMD_DO_CHANGE_SPEED = 178
CMD_DO_SET_HOME = 179
CMD_DO_SET_SERVO = 183
CMD_DO_SET_RELAY = 181
CMD_CONDITION_DELAY = 112
CMD_NAV_FENCE_RETURN_POINT = 5000
CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
CMD_NAV_FENCE_CIRCLE_INCLUSION = 5003
CMD_NAV_FENCE_CIRCLE_EXCLUSION = 5004
CMD_NAV_RALLY_POINT = 5100
CMD_USER_WAYPOINT_FIRST = 31000
CMD_USER_WAYPOINT_LAST = 31004
CMD_USER_FIRST = 31010
CMD_USER_LAST = 31014


@dataclass(frozen=True, slots=True)
class MissionItem:
    """One MISSION_ITEM_INT (field names as in the MAVLink message)."""

    seq: int
    frame: int
    command: int
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    current: int = 0
    autocontinue: int = 1
    mission_type: int = MissionType.MISSION

    @property
    def lat_deg(self) -> float:
        return self.x / 1e7

    @property
    def lon_deg(self) -> float:
        return self.y / 1e7

    @property
    def alt_m(self) -> float:
        return self.z

    @property
    def is_global(self) -> bool:
        return self.frame in GLOBAL_FRAMES

    def with_seq(self, seq: int) -> MissionItem:
        return replace(self, seq=seq)

    def to_dict(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in self.__slots__}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> MissionItem:
        return cls(
            seq=int(data["seq"]), frame=int(data["frame"]), command=int(data["command"]),
            param1=float(data.get("param1", 0.0)), param2=float(data.get("param2", 0.0)),
            param3=float(data.get("param3", 0.0)), param4=float(data.get("param4", 0.0)),
            x=int(data.get("x", 0)), y=int(data.get("y", 0)), z=float(data.get("z", 0.0)),
            current=int(data.get("current", 0)), autocontinue=int(data.get("autocontinue", 1)),
            mission_type=int(data.get("mission_type", 0)),
        )

    @classmethod
    def at(cls, seq: int, command: int, lat_deg: float, lon_deg: float, *, alt_m: float = 0.0,
           param1: float = 0.0, param2: float = 0.0, param3: float = 0.0, param4: float = 0.0) -> MissionItem:
        """A positional item (``command`` at a position, relative altitude frame)."""
        return cls(seq=seq, frame=FRAME_GLOBAL_RELATIVE_ALT_INT, command=command, param1=param1,
                   param2=param2, param3=param3, param4=param4, x=round(lat_deg * 1e7),
                   y=round(lon_deg * 1e7), z=alt_m)

    @classmethod
    def waypoint(cls, seq: int, lat_deg: float, lon_deg: float, *, alt_m: float = 0.0,
                 hold_s: float = 0.0, accept_radius_m: float = 0.0) -> MissionItem:
        """A NAV_WAYPOINT at a position (helper for tests and scripts)."""
        return cls.at(seq, CMD_NAV_WAYPOINT, lat_deg, lon_deg, alt_m=alt_m, param1=hold_s,
                      param2=accept_radius_m)

    @classmethod
    def home(cls, lat_deg: float, lon_deg: float, alt_m: float = 0.0) -> MissionItem:
        """Item 0 of an ArduPilot mission: the home position."""
        return cls(seq=0, frame=FRAME_GLOBAL, command=CMD_NAV_WAYPOINT, x=round(lat_deg * 1e7),
                   y=round(lon_deg * 1e7), z=alt_m)
