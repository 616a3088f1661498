"""LOITER (Rover 5): keep station where the mode was entered, bow into the current.

Active station keeping (:class:`~companion.modes.navigation.StationTask`): the boat holds the
point against current and wind instead of drifting to the edge of LOIT_RADIUS and driving back
as ArduPilot Rover does (issue 20842).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from companion.messages import NavState
from companion.modes.base import STANDARD_MODE_POSITION_HOLD
from companion.modes.navigation import NavMode, StationTask

if TYPE_CHECKING:
    from companion.vehicle import Vehicle


class LoiterMode(NavMode):
    number = 5
    name = "LOITER"
    standard_mode = STANDARD_MODE_POSITION_HOLD
    description = "Loiter: actively keep station where the mode was entered, bow into the current."

    def enter(self, vehicle: Vehicle) -> None:
        super().enter(vehicle)
        nav = vehicle.nav()
        assert nav is not None  # requirements() checked the position estimate
        self.task = StationTask(vehicle.ctx.params, (nav.lat_deg, nav.lon_deg), nav.heading_rad)

    def update(self, vehicle: Vehicle, nav: NavState) -> None:
        if self.task is not None:
            self.run_task(vehicle, nav, self.task)
