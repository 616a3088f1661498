"""The mode interface every vehicle mode implements (ArduPilot Rover's ``Mode`` shape).

A mode is a small object with ``enter``/``update``/``exit``: it turns the navigation
solution into targets (a :class:`~companion.messages.Setpoint` or an
:class:`~companion.messages.ActuatorCommand` on the bus) and never talks MAVLink itself.
The MAVLink face of modes (heartbeat custom_mode, DO_SET_MODE, AVAILABLE_MODES,
CURRENT_MODE, POSITION_TARGET_GLOBAL_INT, NAV_CONTROLLER_OUTPUT) lives in
:mod:`companion.mavlink` and reads only the attributes defined here.

Numbers are ArduPilot Rover's custom-mode numbers (MANUAL 0, ACRO 1, STEERING 3, HOLD 4,
LOITER 5, AUTO 10, RTL 11, SMART_RTL 12, GUIDED 15) so that QGroundControl, MAVProxy and
MAVSDK decode them; a mode Rover lacks takes a number Rover does not use (>= 20).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

from companion.messages import NavState

if TYPE_CHECKING:
    from companion.vehicle import Vehicle

# MAV_STANDARD_MODE values (MAVLink common.xml), repeated here so modes need no pymavlink import.
STANDARD_MODE_NON_STANDARD = 0
STANDARD_MODE_POSITION_HOLD = 1
STANDARD_MODE_ORBIT = 2
STANDARD_MODE_CRUISE = 3
STANDARD_MODE_SAFE_RECOVERY = 5
STANDARD_MODE_MISSION = 6


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
    standard_mode: ClassVar[int | None] = None
    description: ClassVar[str] = ""
    autonomous: ClassVar[bool] = False
    guided: ClassVar[bool] = False
    manual_input: ClassVar[bool] = False
    user_selectable: ClassVar[bool] = True

    def __init__(self) -> None:
        self.nav_target: NavTarget | None = None

    def requirements(self, vehicle: Vehicle) -> str | None:
        """Why this mode cannot be entered now (shown to the operator), or ``None`` if it can."""
        return None

    def enter(self, vehicle: Vehicle) -> None:
        """Called once when the mode becomes active (after :meth:`requirements` passed)."""
        return None

    def update(self, vehicle: Vehicle, nav: NavState) -> None:
        """Called by the control loop on every navigation sample (100 Hz) while active."""
        return None

    def exit(self, vehicle: Vehicle) -> None:
        """Called once when another mode takes over."""
        self.nav_target = None

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name} ({self.number})>"


def requires_position(vehicle: Vehicle) -> str | None:
    """Shared requirement: a valid position estimate (navigating modes use it)."""
    nav = vehicle.nav()
    if nav is None or not nav.position_valid:
        return "no position estimate"
    return None
