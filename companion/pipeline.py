"""The 100 Hz pipeline: one GPS-INS sample in, one servo frame out (chapter Fig. 6).

Every navigation sample parsed from the GPS-INS bytes runs :meth:`Pipeline.on_sample`, one
synchronous pass through these stages, each a plain method call that RETURNS its result to
the next:

1. **sample** -- the :class:`~companion.messages.NavState` from the GPS-INS parser
   (:mod:`companion.sensors.gpsins`), first checked by **NavHealth**
   (:class:`~companion.navhealth.stage.NavHealth`): GPS loss is flown on the INS dead reckoning
   for a bounded time; a sample that cannot steer (frozen solution, stale IMU) goes no further
   and the frame carries the degraded action's command;
2. **estimator** -- the qLPV model + UKF of Eq. 5-11 (:class:`~companion.estimation.service.
   EstimatorStage`): the model error delta_nu, given the actuator command applied since the
   last sample; handed to the controller (:meth:`ControlSystem.use_model_error`), and with the
   current-augmented filter the water current (:meth:`ControlSystem.use_current`, which guidance
   reads as ``control.water_current``);
2b. **fence** -- the geofence (:class:`~companion.fence.guard.FenceGuard`): the boat and its
   predicted stop point against the FENCE plan; a new breach switches the mode (FENCE_ACTION)
   before the mode computes this sample's command;
3. **modes** -- the active mode (:class:`~companion.modes.manager.ModeManager`, run against the
   vehicle): its target (mission item, guided point, loiter point, pilot sticks) through
   guidance (LOS path following, circle, station keeping), returned as a
   :class:`~companion.control.target.ControlRequest` (HOLD returns its command as it is;
   ``None``: nothing new, the last command stays);
4. **controller** -- the control system (:meth:`ControlSystem.apply`): the controller family
   (PID or active model, Fig. 6) and the actuator mapping (limits, slew rates), giving the
   :class:`~companion.messages.ActuatorCommand`;
5. **servo frame** -- the command, the payloads' outputs (their declared servo channels) and the
   operator's servo overrides as pulse widths (:class:`ServoOutput`), written as ONE ``$PUSVS``
   frame to the servo link.

The bus carries what observers watch (telemetry, logs, payloads, later MQTT): the pipeline
publishes ``nav``, ``model_error`` (and ``water_current`` with the current filter),
``actuator_cmd`` and ``servo_out``; no stage reads another
stage's result from the bus.  A stage that raises is logged and counted
(:attr:`LoopStats.stage_errors`) and the frame is still written.

The one-frame-per-sample rule is what the simulator's lockstep waits for (the frame's ACK is
the sample's GPS time field).  Without samples the hardware service refreshes the frame at
10 Hz (:mod:`companion.hardware`), so failsafe commands still reach the servos.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ParamSpec, Protocol, TypeVar

from companion.actuators.servo import ServoMap, encode_frame
from companion.bus import Bus
from companion.clock import Clock
from companion.control.target import ControlRequest
from companion.messages import (
    ACTUATOR_CMD_TOPIC,
    MODEL_ERROR_TOPIC,
    NAV_TOPIC,
    SERVO_OUT_TOPIC,
    WATER_CURRENT_TOPIC,
    ActuatorCommand,
    CurrentEstimate,
    ModelError,
    NavState,
    ServoOutputs,
)
from companion.transport import ByteLink

log = logging.getLogger(__name__)

P = ParamSpec("P")
R = TypeVar("R")


class Estimator(Protocol):
    """Stage 2: the model error estimate of one sample (``None``: sample skipped); with the
    current filter, also the water current (:attr:`current`, else ``None``)."""

    current: CurrentEstimate | None

    def step(self, nav: NavState, applied: ActuatorCommand | None) -> ModelError | None: ...


ModesStage = Callable[[NavState], ControlRequest | ActuatorCommand | None]
"""Stage 3: what the active mode asks of the controller for one sample."""


class NavCheck(Protocol):
    """Stage 1: the GPS-INS health check (:class:`~companion.navhealth.stage.NavHealth`)."""

    def check(self, nav: NavState) -> NavState | None: ...

    def fallback(self, now_s: float) -> ActuatorCommand | None: ...


GuardStage = Callable[[NavState], None]
"""Stage 2b: a check of the sample that may change the vehicle's mode (the geofence)."""


class Controller(Protocol):
    """Stage 4 (:class:`~companion.control.system.ControlSystem`): the estimate in, the mode's
    request out as an actuator command."""

    def use_model_error(self, estimate: ModelError) -> None: ...

    def use_current(self, estimate: CurrentEstimate) -> None: ...

    def apply(self, nav: NavState, request: ControlRequest) -> ActuatorCommand: ...


@dataclass
class LoopStats:
    """Counters and wall-clock time (``time.perf_counter``) spent per stage, for profiling
    (``usv bench``: ``sim_sitl``); :meth:`per_sample_us` gives the mean cost per sample."""

    samples: int = 0
    frames: int = 0
    stage_errors: dict[str, int] = field(default_factory=dict)
    stage_time_s: dict[str, float] = field(default_factory=dict)
    frame_time_s: float = 0.0
    _timed_samples: int = 0
    _timed_frames: int = 0

    def per_sample_us(self) -> dict[str, float]:
        """Mean microseconds per sample of each stage (``nav_publish``: the ``nav`` topic's
        observers) and of building the servo frame, since the last :meth:`reset_timing`."""
        n = max(1, self.samples - self._timed_samples)
        out = {name: 1e6 * t / n for name, t in self.stage_time_s.items()}
        out["servo_frame"] = 1e6 * self.frame_time_s / max(1, self.frames - self._timed_frames)
        return out

    def reset_timing(self) -> None:
        """Start timing afresh (e.g. after a warm-up that compiled or cached things)."""
        self._timed_samples, self._timed_frames = self.samples, self.frames
        self.stage_time_s = dict.fromkeys(self.stage_time_s, 0.0)
        self.frame_time_s = 0.0


class ServoOutput:
    """Stage 4: actuator command + payload outputs + overrides -> pulse widths -> one servo frame.

    :attr:`servo_map` knows the channel map, the payloads' servo channels and the operator's
    DO_SET_SERVO / DO_SET_RELAY overrides of free outputs.
    """

    def __init__(self, servo_map: ServoMap, clock: Clock, bus: Bus, stats: LoopStats) -> None:
        self.servo_map = servo_map
        self.clock = clock
        self.stats = stats
        self.link: ByteLink | None = None
        """Where frames go (the servo controller); set by the hardware service while it runs."""
        self._servo_out = bus.topic(SERVO_OUT_TOPIC)

    def write(self, cmd: ActuatorCommand | None, ack: str = "") -> ServoOutputs:
        """Build, publish and send the frame for ``cmd`` (``None``: nothing commanded yet, which
        is engine off, throttle 0, nozzle centred); ``ack`` answers a GPS-INS sample."""
        t0 = time.perf_counter()
        pulses = self.servo_map.pulses(cmd or ActuatorCommand(t_s=self.clock.now_s()))
        out = ServoOutputs(t_s=self.clock.now_s(), pulse_us=pulses)
        self._servo_out.publish(out)
        self.stats.frames += 1
        frame = encode_frame(ack, pulses)
        self.stats.frame_time_s += time.perf_counter() - t0  # the peer's handling is not ours
        if self.link is not None:
            self.link.write(frame)
        return out


class Pipeline:
    """The synchronous sample -> estimator -> modes -> controller -> servo frame pass (module doc).

    ``fence``: the geofence stage (``None``: no fence checks, as on the bare hardware seam).
    ``estimator`` and ``controller`` are ``None`` on the bare hardware seam, where ``modes`` is a
    test's or a benchmark's function returning actuator commands.  ``mode_failed`` is told when
    the controller raises on a mode's request (the vehicle then falls back to HOLD, as for a
    mode that raises itself).
    """

    def __init__(self, *, bus: Bus, estimator: Estimator | None, modes: ModesStage,
                 controller: Controller | None, output: ServoOutput,
                 mode_failed: Callable[[Exception], None] | None = None,
                 fence: GuardStage | None = None, nav_health: NavCheck | None = None) -> None:
        self.nav_health = nav_health
        self.estimator = estimator
        self.fence = fence
        self.modes = modes
        self.controller = controller
        self.output = output
        self.mode_failed = mode_failed
        self.stats = output.stats
        self.last_command: ActuatorCommand | None = None
        """The command in force: the last one the modes stage returned."""
        self.last_sample_s: float | None = None
        self._t = 0.0
        self._nav = bus.topic(NAV_TOPIC)
        self._model_error = bus.topic(MODEL_ERROR_TOPIC)
        self._current = bus.topic(WATER_CURRENT_TOPIC)
        self._command = bus.topic(ACTUATOR_CMD_TOPIC)

    def on_sample(self, nav: NavState, ack: str = "") -> ServoOutputs:
        """Run the pipeline for one navigation sample and write its servo frame."""
        self.stats.samples += 1
        self.last_sample_s = nav.t_s
        self._t = time.perf_counter()
        if self.nav_health is not None and self._checked(nav) is None:  # 1. unusable sample
            self._use_fallback(nav.t_s)
            return self.output.write(self.last_command, ack)
        self._nav.publish(nav)  # 1. sample (observers: home position, telemetry, payloads)
        self._lap("nav_publish")
        controller = self.controller
        if self.estimator is not None:  # 2. model error delta_nu (Eq. 5-11)
            estimate = self._stage("estimator", None, self.estimator.step, nav, self.last_command)
            if estimate is not None:
                self._model_error.publish(estimate)
                if controller is not None:
                    controller.use_model_error(estimate)
                current = self.estimator.current
                if current is not None:
                    self._current.publish(current)
                    if controller is not None:
                        controller.use_current(current)
        if self.fence is not None:  # 2b. geofence: a predicted breach changes the mode first
            self._stage("fence", None, self.fence, nav)
        request = self._stage("modes", None, self.modes, nav)  # 3. the active mode's target
        command: ActuatorCommand | None = None
        if not isinstance(request, ControlRequest):  # HOLD's own command, a seam driver's, or None
            command = request
        elif controller is not None:  # 4. controller family + actuator mapping
            command = self._stage("controller", self.mode_failed, controller.apply, nav, request)
        if command is not None:
            self.last_command = command
            self._command.publish(command)
        return self.output.write(self.last_command, ack)  # 5. one servo frame

    def refresh(self) -> ServoOutputs:
        """Write the frame of the command in force again (no sample: the 10 Hz refresh), or the
        navigation fault's command once NavHealth declares the GPS-INS silent."""
        if self.nav_health is not None:
            self._use_fallback(self.output.clock.now_s())
        return self.output.write(self.last_command)

    def _checked(self, nav: NavState) -> NavState | None:
        """NavHealth's verdict on ``nav`` (a failing check passes the sample on, counted)."""
        assert self.nav_health is not None
        try:
            return self.nav_health.check(nav)
        except Exception:
            errors = self.stats.stage_errors
            errors["nav_health"] = errors.get("nav_health", 0) + 1
            if errors["nav_health"] <= 3:
                log.exception("pipeline stage nav_health failed")
            return nav
        finally:
            self._lap("nav_health")

    def _use_fallback(self, now_s: float) -> None:
        assert self.nav_health is not None
        command = self._stage("nav_fallback", None, self.nav_health.fallback, now_s)
        if command is not None:
            self.last_command = command
            self._command.publish(command)

    def _stage(self, name: str, on_error: Callable[[Exception], None] | None, fn: Callable[P, R],
               *args: P.args, **kwargs: P.kwargs) -> R | None:
        try:
            result: R | None = fn(*args, **kwargs)
        except Exception as exc:
            errors = self.stats.stage_errors
            errors[name] = errors.get(name, 0) + 1
            if errors[name] <= 3:
                log.exception("pipeline stage %s failed", name)
            result = None
            if on_error is not None:
                on_error(exc)
        self._lap(name)
        return result

    def _lap(self, name: str) -> None:
        t0, self._t = self._t, time.perf_counter()
        times = self.stats.stage_time_s
        times[name] = times.get(name, 0.0) + (self._t - t0)
