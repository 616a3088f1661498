"""The control stack one navigating mode drives: controller family + actuator mapping.

:class:`ControlSystem` is created once per vehicle (:mod:`companion.runtime`), reads its tuning
from the parameter table (rebuilt when a parameter changes), picks the controller family from
``USV_CTRL_TYPE`` on every step (so it can be switched while moving; the new family starts from
the current actuator state), and RETURNS the :class:`~companion.messages.ActuatorCommand` for
the active mode's :class:`~companion.control.target.ControlRequest` to the pipeline
(:meth:`ControlSystem.apply`); the guidance :class:`~companion.messages.Setpoint` goes on
``setpoint`` for observers.  The active-model family needs the identified qLPV model and the estimator's model
error, which the pipeline hands over every sample (:meth:`ControlSystem.use_model_error`), and,
when that error is the water-relative model's, the current it was estimated
against (``ModelError.water_ne_mps``); the vehicle's current estimate (:meth:`ControlSystem.use_current`)
gives the commanded speed through the water and is what guidance reads;
without a model it falls back to PID and says so once.  Station-keeping targets
(``ControlTarget.hold_station``) are steered by PID unless ``USV_STN_CTRL`` is 1.
"""

from __future__ import annotations

import logging
import math

from companion.angles import wrap_2pi
from companion.bus import Bus
from companion.clock import Clock, StepTimer
from companion.control.active_model import ActiveModelController
from companion.control.actuator import ActuatorMapper
from companion.control.params import (
    CTRL_ACTIVE_MODEL,
    CTRL_PID,
    STN_CTRL_PID,
    active_model_config,
    actuator_limits,
    pid_config,
)
from companion.control.pid_family import PidController
from companion.control.target import ControlOutput, ControlRequest, ControlTarget, CourseSpeedController
from companion.messages import (
    SETPOINT_TOPIC,
    STATUS_TEXT_TOPIC,
    ActuatorCommand,
    CurrentEstimate,
    ModelError,
    NavState,
    Setpoint,
    Severity,
    StatusText,
)
from companion.models.qlpv import QLPVModel
from companion.params import ParamStore

log = logging.getLogger(__name__)

MODEL_ERROR_STALE_S = 0.5
"""An estimate older than this (clock time) is not used by the active-model law."""


class ControlSystem:
    """Controller families and actuator mapping for one vehicle."""

    def __init__(self, params: ParamStore, clock: Clock, bus: Bus, model: QLPVModel | None) -> None:
        self.params = params
        self.clock = clock
        self.model = model
        self._families: dict[int, CourseSpeedController] = {}
        self._active_type: int | None = None
        self.mapper = ActuatorMapper(actuator_limits(params))
        self._timer = StepTimer()
        """The step uses sensor time, clamped (shared by :meth:`step` and :meth:`direct`)."""
        self.last_output: ControlOutput | None = None
        self.last_target: ControlTarget | None = None
        self._model_error: ModelError | None = None
        self._current: CurrentEstimate | None = None
        self._warned_no_model = False
        self._setpoint = bus.topic(SETPOINT_TOPIC)
        self._status = bus.topic(STATUS_TEXT_TOPIC)
        params.add_listener(self._on_param)

    def _on_param(self, name: str, value: float) -> None:
        if name.startswith("USV_") and name != "USV_CTRL_TYPE":
            self._families.clear()  # rebuilt with the new tuning on the next step
            self.mapper.limits = actuator_limits(self.params)

    def use_model_error(self, estimate: ModelError) -> None:
        """The estimator's latest model error (chapter Eq. 5), for the active-model law."""
        self._model_error = estimate

    def use_current(self, estimate: CurrentEstimate) -> None:
        """The estimator's latest water current (the current-augmented filter only)."""
        self._current = estimate

    @property
    def water_current(self) -> CurrentEstimate | None:
        """The latest water-current estimate, ``None`` without one or when it is stale (no
        estimate for :data:`MODEL_ERROR_STALE_S`): what guidance may use for crab and holding."""
        est = self._current
        if est is None or self.clock.now_s() - est.t_s > MODEL_ERROR_STALE_S:
            return None
        return est

    def _current_ne(self) -> tuple[float, float] | None:
        est = self.water_current
        return None if est is None else (est.north_mps, est.east_mps)

    def _fresh_model_error(self) -> ModelError | None:
        msg = self._model_error
        if msg is None or self.clock.now_s() - msg.t_s > MODEL_ERROR_STALE_S:
            return None
        return msg

    def _delta_nu(self) -> tuple[float, float, float] | None:
        msg = self._fresh_model_error()
        return None if msg is None else msg.delta_nu

    def _model_current_ne(self) -> tuple[float, float] | None:
        """The current the model error was estimated against (``None`` over ground or stale)."""
        msg = self._fresh_model_error()
        return None if msg is None else msg.water_ne_mps

    def family_type(self, target: ControlTarget | None = None) -> int:
        """The controller family that will run for ``target``: PID for station keeping unless
        ``USV_STN_CTRL`` is 1, else ``USV_CTRL_TYPE`` (the active model needs a model)."""
        if (target is not None and target.hold_station
                and int(self.params.get("USV_STN_CTRL")) == STN_CTRL_PID):
            return CTRL_PID
        wanted = int(self.params.get("USV_CTRL_TYPE"))
        if wanted == CTRL_ACTIVE_MODEL and self.model is None:
            if not self._warned_no_model:
                self._warned_no_model = True
                self._status.publish(StatusText(self.clock.now_s(), Severity.WARNING,
                                                "Active-model control: no identified model; using PID"))
            return CTRL_PID
        return wanted

    def _family(self, kind: int) -> CourseSpeedController:
        fam = self._families.get(kind)
        if fam is None:
            p = self.params
            if kind == CTRL_ACTIVE_MODEL and self.model is not None:
                fam = ActiveModelController(self.model, active_model_config(p), delta_nu=self._delta_nu,
                                            current=self._current_ne, model_current=self._model_current_ne)
            else:
                fam = PidController(pid_config(p))
            self._families[kind] = fam
        return fam

    def apply(self, nav: NavState, request: ControlRequest) -> ActuatorCommand:
        """The pipeline's controller stage: the actuator command for the mode's ``request``."""
        if request.target is not None:
            return self.step(nav, request.target, ignition_on=request.ignition_on)
        return self.direct(nav, request.nozzle_rad, request.throttle, ignition_on=request.ignition_on)

    def reset(self) -> None:
        """Forget timing and integrators (a mode was entered)."""
        self._timer.reset()
        self._active_type = None

    def step(self, nav: NavState, target: ControlTarget, *, ignition_on: bool = True) -> ActuatorCommand:
        """Run one control period for ``target``; the actuator command for the servo frame."""
        dt = self._timer.step(nav.t_s)
        kind = self.family_type(target)
        fam = self._family(kind)
        if kind != self._active_type:
            fam.reset(nav)
            self._active_type = kind
        if not (math.isfinite(target.course_rad) and math.isfinite(target.speed_mps)):
            target = ControlTarget(nav.heading_rad, 0.0, is_heading=True)
        out = fam.update(nav, target, dt, self.mapper.saturation)
        nozzle, throttle, _ = self.mapper.apply(out.nozzle_rad, out.throttle, dt)
        self.last_output, self.last_target = out, target
        self._setpoint.publish(Setpoint(nav.t_s, wrap_2pi(target.course_rad), target.speed_mps))
        return ActuatorCommand(t_s=nav.t_s, nozzle_rad=nozzle, throttle=throttle, ignition_on=ignition_on)

    def direct(self, nav: NavState, nozzle_rad: float, throttle: float, *,
               ignition_on: bool = True) -> ActuatorCommand:
        """Pass a nozzle angle and throttle (MANUAL) through the actuator limits and slew rates."""
        dt = self._timer.step(nav.t_s)
        if not (math.isfinite(nozzle_rad) and math.isfinite(throttle)):
            nozzle_rad, throttle = 0.0, 0.0
        nozzle, thr, _ = self.mapper.apply(nozzle_rad, throttle, dt)
        return ActuatorCommand(t_s=nav.t_s, nozzle_rad=nozzle, throttle=thr, ignition_on=ignition_on)
