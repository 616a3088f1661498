"""HOLD (Rover 4): throttle to idle and nozzle centred.  A boat in HOLD drifts with wind and current.

Minimal version from the MAVLink issue (publishes the idle command each sample); the
guidance/control issue owns the behaviour.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from companion.messages import ActuatorCommand, NavState
from companion.modes.base import Mode

if TYPE_CHECKING:
    from companion.vehicle import Vehicle


class HoldMode(Mode):
    number = 4
    name = "HOLD"
    standard_mode = None
    description = "Hold: engine idle, nozzle centred; the boat drifts with wind and current."

    def update(self, vehicle: Vehicle, nav: NavState) -> None:
        vehicle.ctx.bus.topic("actuator_cmd", ActuatorCommand).publish(
            ActuatorCommand(t_s=nav.t_s, nozzle_rad=0.0, throttle=0.0, ignition_on=vehicle.armed)
        )
