"""LOITER (Rover 5): stay at the point where the mode was entered, actively.

A water jet idles with thrust (the simulated boat creeps at about 0.7 m/s at idle), so what
"holding a point" means depends on the current:

- current stronger than idle speed: keep station bow into the current
  (:class:`~companion.modes.navigation.StationTask`), the jet stemming the current;
- weaker current: the boat cannot stand still, so it orbits the point on the smallest circle it
  holds under control (:class:`~companion.modes.circle_item.CircleTask`, radius
  ``max(USV_TURN_RAD, LOIT_RADIUS - 0.5 m)``).

With a water-current estimate (``host.water_current``, ``USV_HOLD_MODE`` 1) the choice is made
at once from it (:func:`companion.modes.holding.hold_task`): bow into a current stronger than
``USV_HOLD_CREEP``, else a drift-compensated orbit at ``USV_TURN_RAD``, except that a current
between ``USV_HOLD_TRY`` and ``USV_HOLD_CREEP`` is first held bow-on too (wind from ahead can
hold the boat there), given up for the orbit when the current does not set the idling boat back
(:func:`companion.modes.creep.trial_creeping`); a keeper in a stronger current is given up when the
creep signature below shows or the idling boat goes on up the current
(:func:`companion.modes.creep.creeping_up`); in slack water with
``USV_HOLD_ESTOP`` 1 it stops the engine and drifts, restarting to return when the drift
reaches ``USV_HOLD_DRIFT``.  Without one it learns:
it starts by keeping station and switches to orbiting after about 3 s (net, leaky count) of the
creep signature: the jet idles, the bow is on the station heading (within 45 degrees) and the
boat still makes headway over ground (more than 0.2 m/s), so the current cannot hold it back.
Distance from the point is not evidence: a boat that must turn round into a strong current, or
that motors back up to its point, is outside LOIT_RADIUS without the current being weak
(``docs/tuning.md``).  It switches back when the orbit is pushed off its circle by more than its
radius for about 8 s.  Either way it holds the point actively, unlike ArduPilot Rover, which
drifts to the edge of LOIT_RADIUS and drives back (issue 20842).
"""

from __future__ import annotations

from companion.control.target import ControlRequest
from companion.messages import ModeNumber, NavState
from companion.modes.base import ModeOutput, StandardMode
from companion.modes.circle_item import CircleTask
from companion.modes.creep import CreepWatch, creeping_up, orbit_instead, trial_creeping
from companion.modes.holding import CurrentStationTask, EngineStopTask, engine_stop_task, hold_task
from companion.modes.host import ModeHost
from companion.modes.navigation import NavMode, StationTask, param

STATION_AFTER_S = 8.0


class LoiterMode(NavMode):
    number = ModeNumber.LOITER
    name = "LOITER"
    standard_mode = StandardMode.POSITION_HOLD
    description = "Loiter: actively hold the entry point (bow into the current, or orbit it in slack water)."

    def __init__(self) -> None:
        super().__init__()
        self.point = (0.0, 0.0)
        self.watch = CreepWatch()
        self.up_watch = CreepWatch()
        """Evidence for :func:`~companion.modes.creep.creeping_up`, counted beside ``watch``'s."""

    def enter(self, host: ModeHost) -> None:
        super().enter(host)
        nav = host.nav()
        assert nav is not None  # requirements() checked the position estimate
        self.point = (nav.lat_deg, nav.lon_deg)
        self.task = (engine_stop_task(host, self.point, nav)
                     or hold_task(host, self.point, nav, try_station=True)
                     or StationTask(host.params, self.point, nav.heading_rad))
        self.watch = CreepWatch()
        self.up_watch = CreepWatch()

    def _orbit_radius_m(self, host: ModeHost) -> float:
        params = host.params
        return max(params.get("USV_TURN_RAD"), param(params, "LOIT_RADIUS") - 0.5)

    def update(self, host: ModeHost, nav: NavState) -> ModeOutput:
        dt = self.dt(nav)
        task = self.task
        if isinstance(task, EngineStopTask) and task.update(nav):
            self.run_task(host, nav, task, dt)  # telemetry target; the station keeper waits
            return ControlRequest.idle(ignition_on=False)
        if isinstance(task, StationTask | CurrentStationTask):
            # the jet idles bow on its station heading and still makes headway, or (with the
            # estimate) the idling boat goes on up the current: too weak a drift (wind against the
            # current can cancel what the estimate says)
            trial = task if isinstance(task, CurrentStationTask) and task.trial else None
            if (trial_creeping(host, nav, trial, self.watch, dt) if trial is not None
                    else self.watch.creeping(host, nav, task.keeper.heading_rad, dt)
                    or (isinstance(task, CurrentStationTask)
                        and creeping_up(host, nav, task, self.up_watch, dt))):
                if isinstance(task, CurrentStationTask):
                    self.task = orbit_instead(host, task, nav)
                else:
                    self.task = CircleTask(host.params, self.point, self._orbit_radius_m(host))
        elif isinstance(task, CircleTask):
            # pushed off the circle by more than its radius: the current is too strong to orbit
            failing = task.on_circle_since_s is not None and abs(task.radial_error_m) > task.radius_m
            if self.watch.count(failing, dt, STATION_AFTER_S):
                self.task = StationTask(host.params, self.point, nav.heading_rad)
        if self.task is not None:
            return self.run_task(host, nav, self.task, dt)
        return None
