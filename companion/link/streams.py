"""Per-link telemetry stream rates: defaults, SET_MESSAGE_INTERVAL and REQUEST_DATA_STREAM.

Each link has its own :class:`StreamRates` (a radio at 57600 baud and a loopback MAVSDK
script want different rates).  Rates are kept as intervals in seconds of the vehicle clock;
:meth:`StreamRates.due` returns the message ids to send now and schedules the next time
without drift.  REQUEST_DATA_STREAM's groups follow ArduPilot's (``GCS_MAVLink``) so
MAVProxy's and QGC's stream requests have the effect they have on ArduPilot.
"""

from __future__ import annotations

import math

from companion.link.dialect import mav
from mavlink_dialect import usv

# Message ids, from pymavlink's dialect (common.xml, development.xml) and the boat's (usv.xml).
HEARTBEAT = mav.MAVLINK_MSG_ID_HEARTBEAT
SYS_STATUS = mav.MAVLINK_MSG_ID_SYS_STATUS
SYSTEM_TIME = mav.MAVLINK_MSG_ID_SYSTEM_TIME
GPS_RAW_INT = mav.MAVLINK_MSG_ID_GPS_RAW_INT
ATTITUDE = mav.MAVLINK_MSG_ID_ATTITUDE
GLOBAL_POSITION_INT = mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
SERVO_OUTPUT_RAW = mav.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW
MISSION_CURRENT = mav.MAVLINK_MSG_ID_MISSION_CURRENT
NAV_CONTROLLER_OUTPUT = mav.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT
RC_CHANNELS = mav.MAVLINK_MSG_ID_RC_CHANNELS
VFR_HUD = mav.MAVLINK_MSG_ID_VFR_HUD
POSITION_TARGET_GLOBAL_INT = mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT
BATTERY_STATUS = mav.MAVLINK_MSG_ID_BATTERY_STATUS
AUTOPILOT_VERSION = mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION
HOME_POSITION = mav.MAVLINK_MSG_ID_HOME_POSITION
EXTENDED_SYS_STATE = mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE
AVAILABLE_MODES = mav.MAVLINK_MSG_ID_AVAILABLE_MODES
CURRENT_MODE = mav.MAVLINK_MSG_ID_CURRENT_MODE
USV_MODEL_STATUS = usv.MAVLINK_MSG_ID_USV_MODEL_STATUS
FENCE_STATUS = mav.MAVLINK_MSG_ID_FENCE_STATUS
USV_CURRENT_ESTIMATE = usv.MAVLINK_MSG_ID_USV_CURRENT_ESTIMATE
NAMED_VALUE_FLOAT = mav.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT

MAX_RATE_HZ = 50.0
"""Highest stream rate a link accepts (the scheduler never wakes more often than this)."""

DEFAULT_RATES_HZ: dict[int, float] = {
    HEARTBEAT: 1.0,
    SYS_STATUS: 1.0,
    SYSTEM_TIME: 1.0,
    GPS_RAW_INT: 2.0,
    ATTITUDE: 4.0,
    GLOBAL_POSITION_INT: 4.0,
    SERVO_OUTPUT_RAW: 2.0,
    MISSION_CURRENT: 1.0,
    NAV_CONTROLLER_OUTPUT: 2.0,
    RC_CHANNELS: 2.0,
    VFR_HUD: 4.0,
    POSITION_TARGET_GLOBAL_INT: 2.0,
    BATTERY_STATUS: 1.0,
    HOME_POSITION: 0.2,
    EXTENDED_SYS_STATE: 1.0,
    CURRENT_MODE: 1.0,
    USV_MODEL_STATUS: 1.0,
    FENCE_STATUS: 1.0,
    USV_CURRENT_ESTIMATE: 1.0,
    NAMED_VALUE_FLOAT: 1.0,
}
"""Rates every new link starts with (roughly ArduPilot's SRx defaults for a telemetry radio);
payloads add their status messages (:class:`~companion.link.manager.LinkManager`)."""

# REQUEST_DATA_STREAM groups (MAV_DATA_STREAM) as ArduPilot maps them.
DATA_STREAM_GROUPS: dict[int, tuple[int, ...]] = {
    mav.MAV_DATA_STREAM_RAW_SENSORS: (),  # no raw IMU on this vehicle
    mav.MAV_DATA_STREAM_EXTENDED_STATUS: (SYS_STATUS, MISSION_CURRENT, GPS_RAW_INT, NAV_CONTROLLER_OUTPUT,
                                          POSITION_TARGET_GLOBAL_INT, FENCE_STATUS),
    mav.MAV_DATA_STREAM_RC_CHANNELS: (SERVO_OUTPUT_RAW, RC_CHANNELS),
    mav.MAV_DATA_STREAM_RAW_CONTROLLER: (),
    mav.MAV_DATA_STREAM_POSITION: (GLOBAL_POSITION_INT,),
    mav.MAV_DATA_STREAM_EXTRA1: (ATTITUDE,),
    mav.MAV_DATA_STREAM_EXTRA2: (VFR_HUD,),
    mav.MAV_DATA_STREAM_EXTRA3: (SYSTEM_TIME, BATTERY_STATUS, EXTENDED_SYS_STATE, USV_MODEL_STATUS,
                                  USV_CURRENT_ESTIMATE, NAMED_VALUE_FLOAT),
}
DATA_STREAM_ALL = mav.MAV_DATA_STREAM_ALL


class StreamRates:
    """Message id -> send interval for one link, with drift-free due times."""

    def __init__(self, defaults: dict[int, float] | None = None,
                 groups: dict[int, tuple[int, ...]] | None = None) -> None:
        self._defaults_hz = dict(DEFAULT_RATES_HZ if defaults is None else defaults)
        self._groups = DATA_STREAM_GROUPS if groups is None else groups
        self._interval_s: dict[int, float] = {m: 1.0 / hz for m, hz in self._defaults_hz.items() if hz > 0}
        self._next_s: dict[int, float] = {}

    def interval_s(self, msg_id: int) -> float | None:
        """Current interval, or ``None`` when the message is not streamed."""
        return self._interval_s.get(msg_id)

    def rate_hz(self, msg_id: int) -> float:
        interval = self._interval_s.get(msg_id)
        return 0.0 if interval is None else 1.0 / interval

    def set_interval_us(self, msg_id: int, interval_us: float) -> None:
        """SET_MESSAGE_INTERVAL semantics: -1 stop, 0 default rate, > 0 interval in microseconds."""
        if not math.isfinite(interval_us):
            raise ValueError(f"interval {interval_us} is not a number")
        if interval_us < 0:
            self._interval_s.pop(msg_id, None)
        elif interval_us == 0:
            hz = self._defaults_hz.get(msg_id, 0.0)
            if hz > 0:
                self._interval_s[msg_id] = 1.0 / hz
            else:
                self._interval_s.pop(msg_id, None)
        else:
            self._interval_s[msg_id] = max(interval_us * 1e-6, 1.0 / MAX_RATE_HZ)
        self._next_s.pop(msg_id, None)

    def set_rate_hz(self, msg_id: int, rate_hz: float) -> None:
        if rate_hz <= 0:
            self._interval_s.pop(msg_id, None)
        else:
            self._interval_s[msg_id] = 1.0 / min(rate_hz, MAX_RATE_HZ)
        self._next_s.pop(msg_id, None)

    def request_data_stream(self, stream_id: int, rate_hz: float, start: bool) -> None:
        """REQUEST_DATA_STREAM: set every message of the group (0 = all groups)."""
        groups = self._groups.values() if stream_id == DATA_STREAM_ALL else (
            self._groups.get(stream_id, ()),)
        for group in groups:
            for msg_id in group:
                self.set_rate_hz(msg_id, rate_hz if start else 0.0)

    def next_due_s(self, now_s: float) -> float | None:
        """When the next message of this link is due (``now_s`` if one was just (re)configured
        and not yet scheduled), or ``None`` when no stream is on.

        The scheduled ids are always a subset of the streamed ones (every change of an interval
        drops the id's schedule), so "one is unscheduled" is a comparison of sizes and the
        earliest time the minimum over the schedule (the telemetry task asks this at every wake)."""
        if not self._interval_s:
            return None
        if len(self._next_s) < len(self._interval_s):
            return now_s
        return min(self._next_s.values())

    def due(self, now_s: float) -> list[int]:
        """Message ids whose time has come; their next time is scheduled."""
        earliest_s = self.next_due_s(now_s)
        if earliest_s is not None and now_s + 1e-9 < earliest_s:
            return []  # nothing due (the common case on all but the link that set the wake-up)
        out: list[int] = []
        for msg_id, interval in self._interval_s.items():
            next_s = self._next_s.get(msg_id)
            if next_s is None:
                self._next_s[msg_id] = now_s + interval
                out.append(msg_id)
            elif now_s + 1e-9 >= next_s:
                next_s += interval
                if next_s < now_s:  # fell behind (pause, slow link): resynchronise, do not burst
                    next_s = now_s + interval
                self._next_s[msg_id] = next_s
                out.append(msg_id)
        return out
