"""Who the vehicle says it is: HEARTBEAT, AUTOPILOT_VERSION, mode reports, the boot banner.

Profiles (setting ``vehicle.profile``):

* ``ardurover`` (default): ``MAV_AUTOPILOT_ARDUPILOTMEGA`` with ArduPilot Rover's mode
  numbers.  QGroundControl and MAVSDK only offer mode switching, go-to, pause and RTL for
  autopilots they know, so the boat borrows Rover's identity on the wire.  It does not hide
  what it is: AUTOPILOT_VERSION carries this product's version and vendor/product ids, and a
  boot STATUSTEXT names it.
* ``generic``: ``MAV_AUTOPILOT_GENERIC``; modes are reached through MAVLink standard modes
  (AVAILABLE_MODES, CURRENT_MODE, MAV_CMD_DO_SET_STANDARD_MODE), answered in both profiles.
"""

from __future__ import annotations

from typing import Any

from companion import __version__ as _version
from companion.link.dialect import mav
from companion.modes.base import Mode
from companion.vehicle import Vehicle

PRODUCT_NAME = "usv-companion"
VENDOR_ID = 0x1209  # pid.codes (open-source hardware/software vendor id)
PRODUCT_ID = 0x0C57

MAVLINK_VERSION = 3
"""HEARTBEAT.mavlink_version: MAVLink 2 sends 3 (common.xml)."""

CAPABILITIES = (
    mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mav.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mav.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | mav.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
)
"""MAV_PROTOCOL_CAPABILITY bits; C-cast parameter encoding is what ArduPilot declares."""


def version_tuple() -> tuple[int, int, int]:
    parts = [int(p) if p.isdigit() else 0 for p in str(_version).split(".")[:3]]
    while len(parts) < 3:
        parts.append(0)
    return parts[0], parts[1], parts[2]


def flight_sw_version() -> int:
    """major.minor.patch packed as AUTOPILOT_VERSION expects (last byte: FIRMWARE_VERSION_TYPE_OFFICIAL)."""
    major, minor, patch = version_tuple()
    return (major << 24) | (minor << 16) | (patch << 8) | 255


def autopilot_id(vehicle: Vehicle) -> int:
    return mav.MAV_AUTOPILOT_ARDUPILOTMEGA if vehicle.profile == "ardurover" else mav.MAV_AUTOPILOT_GENERIC


def base_mode(vehicle: Vehicle) -> int:
    mode = vehicle.modes.current
    flags = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if vehicle.armed:
        flags |= mav.MAV_MODE_FLAG_SAFETY_ARMED
    if mode.manual_input:
        flags |= mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    if mode.guided:
        flags |= mav.MAV_MODE_FLAG_GUIDED_ENABLED
    if mode.autonomous:
        flags |= mav.MAV_MODE_FLAG_AUTO_ENABLED
    return int(flags)


def system_state(vehicle: Vehicle) -> int:
    if vehicle.in_failsafe:
        return int(mav.MAV_STATE_CRITICAL)
    return int(mav.MAV_STATE_ACTIVE if vehicle.armed else mav.MAV_STATE_STANDBY)


def heartbeat(vehicle: Vehicle) -> Any:
    return mav.MAVLink_heartbeat_message(
        mav.MAV_TYPE_SURFACE_BOAT, autopilot_id(vehicle), base_mode(vehicle),
        vehicle.modes.current.number, system_state(vehicle), MAVLINK_VERSION)


def autopilot_version(vehicle: Vehicle, system_id: int) -> Any:
    git = b"usvcomp"  # flight_custom_version: 8 bytes of product tag
    return mav.MAVLink_autopilot_version_message(
        CAPABILITIES, flight_sw_version(), 0, 0, 0, list(git.ljust(8, b"\0")), [0] * 8, [0] * 8,
        VENDOR_ID, PRODUCT_ID, system_id, [0] * 18)


def boot_banner() -> str:
    major, minor, patch = version_tuple()
    return f"{PRODUCT_NAME} {major}.{minor}.{patch} (USV companion; ArduRover-compatible MAVLink)"


def standard_mode_of(mode: Mode) -> int:
    return int(mode.standard_mode) if mode.standard_mode is not None else 0


def available_modes(vehicle: Vehicle) -> list[Any]:
    """One AVAILABLE_MODES message per mode (development.xml standard-modes protocol)."""
    modes = vehicle.modes.available()
    out = []
    for index, mode in enumerate(modes, start=1):
        properties = 0 if mode.user_selectable else mav.MAV_MODE_PROPERTY_NOT_USER_SELECTABLE
        name = mode.name.encode("ascii", "replace")[:35]
        out.append(mav.MAVLink_available_modes_message(len(modes), index, standard_mode_of(mode),
                                                       mode.number, properties, name))
    return out


def current_mode(vehicle: Vehicle) -> Any:
    mode = vehicle.modes.current
    # intended_custom_mode: a mode change is never pending here, the intended mode is the mode
    return mav.MAVLink_current_mode_message(standard_mode_of(mode), mode.number, mode.number)
