"""Geofence parameters: ArduPilot's names and values (FENCE_ENABLE, FENCE_ACTION, FENCE_MARGIN)
plus the boat's prediction constants (``USV_FENCE_*``)."""

from __future__ import annotations

import enum

from companion.params import ParamDef


class FenceAction(enum.IntEnum):
    """FENCE_ACTION values: ArduPilot Rover's failsafe actions (``FailsafeAction``) this boat has."""

    REPORT_ONLY = 0
    RTL = 1
    """RTL, or HOLD when RTL cannot start (no home)."""
    HOLD = 2
    ENGINE_STOP = 5
    """Rover's "Terminate": disarm, which turns the ignition off."""


PARAMS: tuple[ParamDef, ...] = (
    ParamDef("FENCE_ENABLE", 0, 0, 1, "",
             "Geofence: 0 off (zones stored, not enforced), 1 enforced (breach action, target and mission "
             "checks, pre-arm check).", is_int=True, choices=((0, "Disabled"), (1, "Enabled"))),
    ParamDef("FENCE_ACTION", int(FenceAction.RTL), 0, 5, "",
             "What a predicted breach does (armed only): 0 report only, 1 RTL (HOLD without home), 2 HOLD "
             "(the boat then drifts), 5 engine stop (disarm).", is_int=True,
             choices=((0, "Report only"), (1, "RTL or Hold"), (2, "Hold"), (5, "Engine stop"))),
    ParamDef("FENCE_MARGIN", 2.0, 0.0, 100.0, "m",
             "Distance kept from the fence: targets and mission items closer than this to a boundary are "
             "refused, and the breach action starts when the predicted stop point comes closer."),
    ParamDef("USV_FENCE_REACT", 1.0, 0.0, 10.0, "s",
             "Fence prediction: time between the check and the action taking effect (travel at the current "
             "speed over ground)."),
    ParamDef("USV_FENCE_YAWR", 30.0, 5.0, 120.0, "deg/s",
             "Fence prediction: turn rate the boat reaches when turning away (turning radius = speed / this; "
             "measured in SITL: 35 deg/s at 2.7 m/s, 58 deg/s at 10 m/s with full nozzle)."),
)
