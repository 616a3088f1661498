"""The mode interface every vehicle mode implements (ArduPilot Rover's ``Mode`` shape).

A mode is a small object with ``enter``/``update``/``exit`` run against a
:class:`~companion.modes.host.ModeHost` (what it may read and request): ``update`` turns the
navigation solution into what it asks of the controller and RETURNS it: a
:class:`~companion.control.target.ControlRequest` (a target to follow, or sticks through the
actuator limits), an :class:`~companion.messages.ActuatorCommand` to apply as it is (HOLD), or
``None`` (nothing new this sample).  The pipeline's controller stage does the rest.  A mode never
talks MAVLink and never writes outputs itself.
The MAVLink face of modes (heartbeat custom_mode, DO_SET_MODE, AVAILABLE_MODES,
CURRENT_MODE, POSITION_TARGET_GLOBAL_INT, NAV_CONTROLLER_OUTPUT) lives in
:mod:`companion.mavlink` and reads only the attributes defined here.

Numbers are ArduPilot Rover's custom-mode numbers (:class:`~companion.messages.ModeNumber`:
MANUAL 0, HOLD 4, LOITER 5, AUTO 10, RTL 11, GUIDED 15) so that QGroundControl, MAVProxy and
MAVSDK decode them; a mode Rover lacks takes a number Rover does not use (CRUISE 20).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import ClassVar

from companion.control.target import ControlRequest
from companion.messages import ActuatorCommand, NavState
from companion.modes.host import ModeHost

ModeOutput = ControlRequest | ActuatorCommand | None
"""What a mode's ``update`` returns for the controller stage."""


class StandardMode(enum.IntEnum):
    """MAV_STANDARD_MODE values (MAVLink common.xml), repeated here so modes need no pymavlink."""

    NON_STANDARD = 0
    POSITION_HOLD = 1
    ORBIT = 2
    CRUISE = 3
    SAFE_RECOVERY = 5
    MISSION = 6


@dataclass(frozen=True, slots=True)
class NavTarget:
    """Where the active mode is steering to, for POSITION_TARGET_GLOBAL_INT and NAV_CONTROLLER_OUTPUT.

    Modes that navigate (GUIDED, LOITER, AUTO, RTL) publish one by assigning
    ``self.nav_target``; ``None`` means "no position target" (MANUAL, HOLD).
    """

    lat_deg: float
    lon_deg: float
    speed_mps: float = 0.0
    wp_dist_m: float = 0.0
    target_bearing_rad: float = 0.0
    nav_bearing_rad: float = 0.0
    xtrack_error_m: float = 0.0
    speed_error_mps: float = 0.0


class Mode:
    """Base class of a vehicle mode.

    Subclasses set the class attributes and override what they need.  A mode object is
    created once per vehicle by :class:`companion.modes.manager.ModeManager`; ``enter`` and
    ``exit`` bracket each period in which the mode is active.

    Attributes:
        number: ArduPilot Rover custom-mode number (heartbeat ``custom_mode``).
        name: upper-case name shown by ground stations (``"HOLD"``).
        standard_mode: ``MAV_STANDARD_MODE`` value, or ``None`` when the mode has no standard twin.
        description: one line for the operator (AVAILABLE_MODES, documentation).
        autonomous: the mode drives itself (heartbeat ``MAV_MODE_FLAG_AUTO_ENABLED``).
        guided: the mode follows ground-station targets (``MAV_MODE_FLAG_GUIDED_ENABLED``).
        manual_input: RC/MANUAL_CONTROL input drives the boat (``MAV_MODE_FLAG_MANUAL_INPUT_ENABLED``).
        user_selectable: offered to operators (else ``MAV_MODE_PROPERTY_NOT_USER_SELECTABLE``).
        nav_target: the current position target (see :class:`NavTarget`), maintained by the mode.
    """

    number: ClassVar[int] = -1
    name: ClassVar[str] = "UNDEFINED"
    standard_mode: ClassVar[StandardMode | None] = None
    description: ClassVar[str] = ""
    autonomous: ClassVar[bool] = False
    guided: ClassVar[bool] = False
    manual_input: ClassVar[bool] = False
    user_selectable: ClassVar[bool] = True

    def __init__(self) -> None:
        self.nav_target: NavTarget | None = None

    def requirements(self, host: ModeHost) -> str | None:
        """Why this mode cannot be entered now (shown to the operator), or ``None`` if it can."""
        return None

    def enter(self, host: ModeHost) -> None:
        """Called once when the mode becomes active (after :meth:`requirements` passed)."""
        return None

    def update(self, host: ModeHost, nav: NavState) -> ModeOutput:
        """Called by the pipeline on every navigation sample (100 Hz) while active: what the
        mode asks of the controller (``None``: the last command stays)."""
        return None

    def exit(self, host: ModeHost) -> None:
        """Called once when another mode takes over."""
        self.nav_target = None

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name} ({self.number})>"


def requires_position(host: ModeHost) -> str | None:
    """Shared requirement: a valid position estimate (navigating modes use it)."""
    nav = host.nav()
    if nav is None or not nav.position_valid:
        return "no position estimate"
    return None
