"""LOITER (Rover 5): stay at the point where the mode was entered, actively.

A water jet idles with thrust (the simulated boat creeps at about 0.7 m/s at idle), so what
"holding a point" means depends on the current:

- current stronger than idle speed: keep station bow into the current
  (:class:`~companion.modes.navigation.StationTask`), the jet stemming the current;
- weaker current: the boat cannot stand still, so it orbits the point on the smallest circle it
  holds under control (:class:`~companion.modes.navigation.CircleTask`, radius
  ``max(USV_TURN_RAD, LOIT_RADIUS - 0.5 m)``).

It starts by keeping station and switches to orbiting after about 8 s (net, leaky count) outside
LOIT_RADIUS while the jet idles or creeps ahead (the current cannot hold it back); it switches
back when the orbit is pushed off its circle by more than its radius for as long.  Either way it holds the
point actively, unlike ArduPilot Rover, which drifts to the edge of LOIT_RADIUS and drives back
(issue 20842).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from companion.control.system import control_of
from companion.messages import NavState
from companion.modes.base import STANDARD_MODE_POSITION_HOLD
from companion.modes.navigation import CircleTask, NavMode, StationTask, param

if TYPE_CHECKING:
    from companion.vehicle import Vehicle

IDLE_THROTTLE = 0.02
SWITCH_AFTER_S = 8.0


class LoiterMode(NavMode):
    number = 5
    name = "LOITER"
    standard_mode = STANDARD_MODE_POSITION_HOLD
    description = "Loiter: actively hold the entry point (bow into the current, or orbit it in slack water)."

    def __init__(self) -> None:
        super().__init__()
        self.point = (0.0, 0.0)
        self._evidence_s = 0.0
        self._last_nav_s: float | None = None

    def enter(self, vehicle: Vehicle) -> None:
        super().enter(vehicle)
        nav = vehicle.nav()
        assert nav is not None  # requirements() checked the position estimate
        self.point = (nav.lat_deg, nav.lon_deg)
        self.task = StationTask(vehicle.ctx.params, self.point, nav.heading_rad)
        self._evidence_s, self._last_nav_s = 0.0, None

    def _orbit_radius_m(self, vehicle: Vehicle) -> float:
        params = vehicle.ctx.params
        return max(params.get("USV_TURN_RAD"), param(params, "LOIT_RADIUS") - 0.5)

    def update(self, vehicle: Vehicle, nav: NavState) -> None:
        dt = 0.01 if self._last_nav_s is None else min(0.1, max(0.0, nav.t_s - self._last_nav_s))
        self._last_nav_s = nav.t_s
        task = self.task
        if isinstance(task, StationTask):
            # the point is not being held although the jet idles: the current is too weak to stem
            at_idle = control_of(vehicle.ctx).mapper.throttle <= IDLE_THROTTLE
            outside = task.distance_m > param(vehicle.ctx.params, "LOIT_RADIUS")
            failing = outside and (at_idle or nav.u_mps > 0.2)
            if self._count(failing, dt):
                self.task = CircleTask(vehicle.ctx.params, self.point, self._orbit_radius_m(vehicle))
        elif isinstance(task, CircleTask):
            # pushed off the circle by more than its radius: the current is too strong to orbit
            failing = task.on_circle_since_s is not None and abs(task.radial_error_m) > task.radius_m
            if self._count(failing, dt):
                self.task = StationTask(vehicle.ctx.params, self.point, nav.heading_rad)
        if self.task is not None:
            self.run_task(vehicle, nav, self.task)

    def _count(self, failing: bool, dt: float) -> bool:
        """Leaky evidence counter: True (and reset) after SWITCH_AFTER_S of net failure."""
        self._evidence_s = max(0.0, self._evidence_s + (dt if failing else -0.5 * dt))
        if self._evidence_s > SWITCH_AFTER_S:
            self._evidence_s = 0.0
            return True
        return False
