"""RTL (Rover 11): return to home along a straight leg, then hold it (as GUIDED holds its point:
:mod:`companion.modes.holding`)."""

from __future__ import annotations

from companion.messages import ModeNumber, NavState
from companion.modes.base import ModeOutput, StandardMode
from companion.modes.creep import CreepWatch, orbit_if_creeping
from companion.modes.holding import ApproachTask, BrakingGoto, goto_task, hold_task
from companion.modes.host import ModeHost
from companion.modes.navigation import GotoTask, NavMode, StationTask, param, wp_speed_mps


class RtlMode(NavMode):
    number = ModeNumber.RTL
    name = "RTL"
    standard_mode = StandardMode.SAFE_RECOVERY
    description = "Return to launch: go home at WP_SPEED, then keep station at home."

    def requirements(self, host: ModeHost) -> str | None:
        if host.home is None:
            return "home position not set"
        return super().requirements(host)

    def enter(self, host: ModeHost) -> None:
        super().enter(host)
        self.watch = CreepWatch()
        nav = host.nav()
        assert nav is not None and host.home is not None
        params = host.params
        home = (host.home.lat_deg, host.home.lon_deg)
        self.task = goto_task(host, (nav.lat_deg, nav.lon_deg), home, wp_speed_mps(params),
                              param(params, "WP_RADIUS"))

    def update(self, host: ModeHost, nav: NavState) -> ModeOutput:
        task = self.task
        if isinstance(task, GotoTask | ApproachTask | BrakingGoto) and task.reached:
            near = task.distance_m <= param(host.params, "WP_RADIUS")
            host.status("RTL: home reached, keeping station" if near
                        else f"RTL: {task.distance_m:.0f} m from home, bow into the current: braking onto it")
            self.task = (hold_task(host, task.end, nav)
                         or StationTask(host.params, task.end, nav.heading_rad))
        dt = self.dt(nav)
        self.task = orbit_if_creeping(host, nav, self.task, self.watch, dt)
        if self.task is not None:
            return self.run_task(host, nav, self.task, dt)
        return None
