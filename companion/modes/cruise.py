"""CRUISE (custom mode 20): course hold at the heading and speed of entry; steer with the sticks.

ArduPilot Rover has no course-hold mode (issue 12251).  Number 20 is outside Rover's mode numbers
(0-16) so ground stations that decode Rover modes never confuse it; it is announced in
AVAILABLE_MODES with MAV_STANDARD_MODE_CRUISE.  The pilot's steering (MAVLink MANUAL_CONTROL
``y`` from a ground station, else RC channel 1; :mod:`companion.control.manual_input`) turns the
held heading at up to USV_TURN_MAX times the stick deflection; a DO_CHANGE_SPEED
(the host's ``speed_override_mps``) changes the held speed.  Stick centred: the boat holds its
heading (the bow stays where it was; it does not crab).
"""

from __future__ import annotations

import math

from companion.angles import wrap_2pi
from companion.control.target import ControlRequest, ControlTarget
from companion.messages import ModeNumber, NavState
from companion.modes.base import StandardMode, requires_position
from companion.modes.host import ModeHost
from companion.modes.navigation import NavMode


class CruiseMode(NavMode):
    number = ModeNumber.CRUISE
    name = "CRUISE"
    standard_mode = StandardMode.CRUISE
    description = "Cruise: hold heading and speed of entry; sticks turn the heading and trim the speed."

    def __init__(self) -> None:
        super().__init__()
        self.heading_rad = 0.0
        self.speed_mps = 0.0
        self._override: float | None = None

    def requirements(self, host: ModeHost) -> str | None:
        return requires_position(host)

    def enter(self, host: ModeHost) -> None:
        super().enter(host)
        nav = host.nav()
        assert nav is not None
        self.heading_rad = nav.heading_rad
        self.speed_mps = max(0.0, nav.u_mps)
        self._override = host.speed_override_mps
        self.nav_target = None

    def update(self, host: ModeHost, nav: NavState) -> ControlRequest:
        dt = self.dt(nav)
        inp = host.pilot_input()
        if inp is not None:
            turn_max = math.radians(host.params.get("USV_TURN_MAX"))
            self.heading_rad = wrap_2pi(self.heading_rad + inp.steering * turn_max * dt)
        override = host.speed_override_mps
        if override is not None and override != self._override and math.isfinite(override):
            self.speed_mps = max(0.0, override)
        self._override = override
        target = ControlTarget(self.heading_rad, self.speed_mps, is_heading=True)
        return ControlRequest.follow(target, ignition_on=host.armed)
