"""The NavHealth pipeline stage: GPS-INS faults -> degraded action, STATUSTEXT, health bits.

Stage 1 of :mod:`companion.pipeline` (before the sample is published): every sample is assessed
by :class:`~companion.navhealth.detector.NavFaultDetector`.

* **GPS lost, INS working**: the sample is used as it is (the INS dead-reckons the position), so
  every mode keeps navigating; after USV_FS_DR_S the degraded action USV_FS_NAV_ACT (HOLD or
  engine stop) is taken if the GPS has not come back.
* **INS fault** (frozen solution, stale IMU or stuck gyro): the sample cannot steer the boat: it is
  not published, the estimator, fence and modes do not run, and the action is taken at once.
* **No data** (silent unit, or every sample dropped by the parser as NaN/out of range): seen by
  :meth:`NavHealth.fallback` from the servo refresh; the action at once.

While an INS fault or silence lasts, :meth:`NavHealth.fallback` gives the command the servos get:
HOLD's (idle, nozzle centred) or, for the engine stop, ignition off.  STATUSTEXT tells what
happened and when ("GPS lost: dead reckoning 30 s", "GPS lost 30 s: HOLD", "GPS-INS frozen: HOLD",
"GPS recovered after 42 s"); the mode is not restored on recovery (as the GCS failsafe).  A
:class:`~companion.messages.NavHealthState` goes on ``nav_health`` for SYS_STATUS; arming is
refused during a fault.
"""

from __future__ import annotations

from companion.bus import Bus
from companion.clock import Clock
from companion.messages import (
    NAV_HEALTH_TOPIC,
    ActuatorCommand,
    ModeNumber,
    NavHealthState,
    NavState,
    Severity,
)
from companion.navhealth.detector import NavAssessment, NavFaultDetector
from companion.navhealth.params import NavFaultAction
from companion.params import ParamStore
from companion.vehicle import Vehicle

PUBLISH_PERIOD_S = 1.0
_ACTION_TEXT = {NavFaultAction.REPORT_ONLY: "report only", NavFaultAction.HOLD: "HOLD",
                NavFaultAction.ENGINE_STOP: "engine stop"}


class NavHealth:
    """GPS-INS faults of one vehicle and its degraded action (module doc)."""

    def __init__(self, params: ParamStore, clock: Clock, bus: Bus, vehicle: Vehicle) -> None:
        self.params = params
        self.clock = clock
        self.vehicle = vehicle
        self.detector = NavFaultDetector()
        self._topic = bus.topic(NAV_HEALTH_TOPIC)
        self.fault = ""
        """The fault in force ("" when healthy)."""
        self.fault_since_s: float | None = None
        self.action_taken: NavFaultAction | None = None
        self._ins_ok = True
        self._next_publish_s = 0.0
        vehicle.add_prearm_check("navigation", self._prearm)

    def _prearm(self, vehicle: Vehicle) -> str | None:
        return f"navigation fault ({self.fault})" if self.fault else None

    # -- the pipeline stage -------------------------------------------------------------
    def check(self, nav: NavState) -> NavState | None:
        """The sample if it may drive the boat, else ``None`` (the degraded action is in force)."""
        verdict = self.detector.assess(nav)
        self._update(verdict, nav.t_s)
        return nav if verdict.ins_ok else None

    def fallback(self, now_s: float) -> ActuatorCommand | None:
        """The command for the servos while the GPS-INS gives nothing usable (``None``: keep the
        command in force).  Detects silence (called by the servo refresh without samples)."""
        if self.detector.silent(now_s) and self._ins_ok:
            self._update(NavAssessment(False, False, "no GPS-INS data"), now_s)
        if self._ins_ok or self.action_taken in (None, NavFaultAction.REPORT_ONLY):
            return None
        armed = self.vehicle.armed and self.action_taken != NavFaultAction.ENGINE_STOP
        return ActuatorCommand(t_s=now_s, nozzle_rad=0.0, throttle=0.0, ignition_on=armed)

    # -- state changes --------------------------------------------------------------------
    def _update(self, verdict: NavAssessment, now_s: float) -> None:
        vehicle = self.vehicle
        if verdict.fault != self.fault:
            if self.fault and not verdict.fault:
                assert self.fault_since_s is not None
                lost_s = now_s - self.fault_since_s
                name = "GPS" if self.fault == "GPS lost" else "GPS-INS"
                vehicle.status(f"{name} recovered after {lost_s:.1f} s", Severity.INFO)
                self.fault_since_s, self.action_taken = None, None
                if vehicle.failsafe_reason == "navigation":
                    vehicle.failsafe_reason = None
            elif verdict.fault:
                if not self.fault:
                    self.fault_since_s = now_s
                if verdict.ins_ok:
                    dr_s = self.params.get("USV_FS_DR_S")
                    vehicle.status(f"{verdict.fault}: dead reckoning {dr_s:.0f} s", Severity.WARNING)
                else:
                    self._act(verdict.fault)
            self.fault, self._ins_ok = verdict.fault, verdict.ins_ok
            vehicle.ins_fault = None if verdict.ins_ok else verdict.fault
            self._publish(now_s)
        if (self.fault and self.action_taken is None and self.fault_since_s is not None
                and now_s - self.fault_since_s >= self.params.get("USV_FS_DR_S")):
            self._act(f"{self.fault} {now_s - self.fault_since_s:.0f} s")
        if now_s >= self._next_publish_s:
            self._publish(now_s)

    def _act(self, what: str) -> None:
        """The degraded action, once per fault episode (nothing while disarmed but the report)."""
        vehicle = self.vehicle
        action = NavFaultAction(self.params.get_int("USV_FS_NAV_ACT"))
        self.action_taken = action
        if not vehicle.armed or action == NavFaultAction.REPORT_ONLY:
            vehicle.status(f"{what}", Severity.CRITICAL)
            return
        vehicle.status(f"{what}: {_ACTION_TEXT[action]}", Severity.CRITICAL)
        vehicle.failsafe_reason = vehicle.failsafe_reason or "navigation"
        if action == NavFaultAction.ENGINE_STOP:
            vehicle.disarm(reason="navigation fault")
        elif vehicle.modes.current.number != ModeNumber.HOLD:
            vehicle.set_mode(ModeNumber.HOLD)

    def _publish(self, now_s: float) -> None:
        self._next_publish_s = now_s + PUBLISH_PERIOD_S
        degraded = ""
        if self.fault and self.action_taken is None:
            degraded = "dead reckoning"
        elif self.action_taken is not None and self.action_taken != NavFaultAction.REPORT_ONLY:
            degraded = _ACTION_TEXT[self.action_taken].lower()
        self._topic.publish(NavHealthState(t_s=now_s, gps_ok=not self.fault, ins_ok=self._ins_ok,
                                           fault=self.fault, degraded_action=degraded))
