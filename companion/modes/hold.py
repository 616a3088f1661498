"""HOLD (Rover 4): throttle to idle and nozzle centred.  A boat in HOLD drifts with wind and current."""

from __future__ import annotations

from companion.messages import ActuatorCommand, ModeNumber, NavState
from companion.modes.base import Mode
from companion.modes.host import ModeHost


class HoldMode(Mode):
    number = ModeNumber.HOLD
    name = "HOLD"
    standard_mode = None
    description = "Hold: engine idle, nozzle centred; the boat drifts with wind and current."

    def update(self, host: ModeHost, nav: NavState) -> ActuatorCommand:
        """Idle and centred at once (no slew), as the command in force."""
        return ActuatorCommand(t_s=nav.t_s, nozzle_rad=0.0, throttle=0.0, ignition_on=host.armed)
