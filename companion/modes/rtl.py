"""RTL (Rover 11): return to home along a straight leg, then keep station there."""

from __future__ import annotations

from typing import TYPE_CHECKING

from companion.messages import NavState
from companion.modes.base import STANDARD_MODE_SAFE_RECOVERY
from companion.modes.navigation import GotoTask, NavMode, StationTask, param, wp_speed_mps

if TYPE_CHECKING:
    from companion.vehicle import Vehicle


class RtlMode(NavMode):
    number = 11
    name = "RTL"
    standard_mode = STANDARD_MODE_SAFE_RECOVERY
    description = "Return to launch: go home at WP_SPEED, then keep station at home."

    def requirements(self, vehicle: Vehicle) -> str | None:
        if vehicle.home is None:
            return "home position not set"
        return super().requirements(vehicle)

    def enter(self, vehicle: Vehicle) -> None:
        super().enter(vehicle)
        nav = vehicle.nav()
        assert nav is not None and vehicle.home is not None
        params = vehicle.ctx.params
        home = (vehicle.home.lat_deg, vehicle.home.lon_deg)
        self.task = GotoTask(params, (nav.lat_deg, nav.lon_deg), home, wp_speed_mps(params),
                             param(params, "WP_RADIUS"))

    def update(self, vehicle: Vehicle, nav: NavState) -> None:
        if isinstance(self.task, GotoTask) and self.task.reached:
            vehicle.status("RTL: home reached, keeping station")
            self.task = StationTask(vehicle.ctx.params, self.task.end, nav.heading_rad)
        if self.task is not None:
            self.run_task(vehicle, nav, self.task)
