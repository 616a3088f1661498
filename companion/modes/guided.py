"""GUIDED (Rover 15): go where the ground station says (DO_REPOSITION, SET_POSITION_TARGET_GLOBAL_INT).

The target is the host's ``guided_target`` (set by the MAVLink services).  The boat follows the leg
from where it was when the target arrived to the target at WP_SPEED (or the target's speed),
then holds it (:mod:`companion.modes.holding`: bow into a strong current, arriving bow into it;
a drift-compensated orbit in a weak one, or where the station keeper creeps; without a current
estimate the station keeper); a target with a radius (DO_REPOSITION param3) is circled instead.
Without a target the boat keeps station where GUIDED was entered.
"""

from __future__ import annotations

from companion.messages import GuidedTarget, ModeNumber, NavState
from companion.modes.base import ModeOutput
from companion.modes.circle_item import CircleTask
from companion.modes.creep import CreepWatch, orbit_if_creeping
from companion.modes.holding import ApproachTask, BrakingGoto, goto_task, hold_task
from companion.modes.host import ModeHost
from companion.modes.navigation import GotoTask, NavMode, StationTask, wp_speed_mps


class GuidedMode(NavMode):
    number = ModeNumber.GUIDED
    name = "GUIDED"
    standard_mode = None
    description = "Guided: go to the point the ground station sends, then keep station (or circle) there."
    guided = True

    def __init__(self) -> None:
        super().__init__()
        self._target: GuidedTarget | None = None

    def enter(self, host: ModeHost) -> None:
        super().enter(host)
        self.watch = CreepWatch()
        nav = host.nav()
        assert nav is not None
        self._target = None
        here = (nav.lat_deg, nav.lon_deg)
        self.task = (hold_task(host, here, nav, try_station=True)
                     or StationTask(host.params, here, nav.heading_rad))

    def update(self, host: ModeHost, nav: NavState) -> ModeOutput:
        params = host.params
        target = host.guided_target
        if target is not None and target is not self._target:
            self._target = target
            speed = wp_speed_mps(params, target.speed_mps)
            self.task = goto_task(host, (nav.lat_deg, nav.lon_deg), (target.lat_deg, target.lon_deg), speed)
        task = self.task
        arriving = isinstance(task, GotoTask | ApproachTask | BrakingGoto) and task.reached
        if arriving and self._target is not None:
            point = (self._target.lat_deg, self._target.lon_deg)
            if self._target.radius_m and self._target.radius_m > 0:
                self.task = CircleTask(params, point, self._target.radius_m)
            else:
                self.task = (hold_task(host, point, nav, try_station=True)
                             or StationTask(params, point, nav.heading_rad))
        dt = self.dt(nav)
        self.task = orbit_if_creeping(host, nav, self.task, self.watch, dt)
        if self.task is not None:
            return self.run_task(host, nav, self.task, dt)
        return None
