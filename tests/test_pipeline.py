"""The 100 Hz pipeline's contract: stages in order, each given the previous one's result, one
servo frame per sample, observers on the bus, and a failing controller sends the boat to HOLD."""

from __future__ import annotations

from typing import Any

from companion.actuators.servo import ServoMap
from companion.bus import TopicKey
from companion.messages import (
    ACTUATOR_CMD_TOPIC,
    MODEL_ERROR_TOPIC,
    SERVO_OUT_TOPIC,
    STATUS_TEXT_TOPIC,
    WATER_CURRENT_TOPIC,
    ActuatorCommand,
    CurrentEstimate,
    ModelError,
    ModeNumber,
    NavState,
    ServoOutputs,
)
from companion.pipeline import LoopStats, Pipeline, ServoOutput
from tests.mavlink.helpers import make_ctx, make_vehicle, publish_nav


class RecordingEstimator:
    """Returns a fixed model error (and, like the current filter, a water current) and remembers
    which command it was told was applied."""

    def __init__(self) -> None:
        self.applied: list[ActuatorCommand | None] = []
        self.current: CurrentEstimate | None = None

    def step(self, nav: NavState, applied: ActuatorCommand | None) -> ModelError:
        self.applied.append(applied)
        self.current = CurrentEstimate.from_components(nav.t_s, 0.0, 0.5, 1e-4, 1e-4, 1.0)
        return ModelError(nav.t_s, (0.1, 0.0, 0.0))


def _pipeline():  # type: ignore[no-untyped-def]
    ctx = make_ctx()
    vehicle = make_vehicle(ctx)
    estimator = RecordingEstimator()
    output = ServoOutput(ServoMap(ctx.params), ctx.clock, ctx.bus, LoopStats())
    pipeline = Pipeline(bus=ctx.bus, estimator=estimator, modes=vehicle.update_mode,
                        controller=vehicle.control, output=output, mode_failed=vehicle.mode_failed)
    vehicle.start_modes()
    return ctx, vehicle, estimator, pipeline


def _sample(ctx, pipeline, t_s: float) -> tuple[NavState, ServoOutputs]:  # type: ignore[no-untyped-def]
    ctx.clock.advance_to(t_s)
    nav = publish_nav(ctx, u_mps=2.0)
    return nav, pipeline.on_sample(nav, ack=f"{t_s:.2f}")


def test_stages_hand_their_results_on_and_observers_see_them() -> None:
    ctx, vehicle, estimator, pipeline = _pipeline()
    seen: dict[TopicKey[Any], list[object]] = {MODEL_ERROR_TOPIC: [], ACTUATOR_CMD_TOPIC: [],
                                               SERVO_OUT_TOPIC: [], WATER_CURRENT_TOPIC: []}
    for key, received in seen.items():
        ctx.bus.topic(key).add_listener(received.append)
    _sample(ctx, pipeline, 1.0)  # HOLD: idle, engine off
    assert vehicle.arm() is None and vehicle.set_mode(ModeNumber.CRUISE) is None
    vehicle.speed_override_mps = 5.0
    _sample(ctx, pipeline, 1.01)
    _, second = _sample(ctx, pipeline, 1.02)
    # the estimator is told the command applied since the last sample: none, then the last one
    assert estimator.applied == [None, seen[ACTUATOR_CMD_TOPIC][0], seen[ACTUATOR_CMD_TOPIC][1]]
    # the controller flew the active model's law with the estimate the pipeline handed over
    assert vehicle.control._delta_nu() == (0.1, 0.0, 0.0)
    # and guidance sees the water current the estimator found (observers too)
    current = vehicle.control.water_current
    assert current is not None and current.east_mps == 0.5 and seen[WATER_CURRENT_TOPIC][-1] == current
    assert len(seen[MODEL_ERROR_TOPIC]) == len(seen[ACTUATOR_CMD_TOPIC]) == len(seen[SERVO_OUT_TOPIC]) == 3
    cmd = seen[ACTUATOR_CMD_TOPIC][2]
    assert isinstance(cmd, ActuatorCommand) and cmd.throttle > 0.0 and cmd.ignition_on
    assert second == seen[SERVO_OUT_TOPIC][2] and second.pulse_us == pipeline.output.servo_map.pulses(cmd)
    assert pipeline.stats.samples == pipeline.stats.frames == 3
    stages = {"nav_publish", "estimator", "modes", "controller", "servo_frame"}
    assert set(pipeline.stats.per_sample_us()) == stages


def test_hold_commands_directly_and_a_mode_without_news_keeps_the_last_command() -> None:
    ctx, vehicle, _, pipeline = _pipeline()
    _, out = _sample(ctx, pipeline, 1.0)
    assert vehicle.modes.current.number == ModeNumber.HOLD
    assert pipeline.last_command == ActuatorCommand(1.0, 0.0, 0.0, ignition_on=False)
    assert out.pulse_us[2] == 1100  # throttle idle
    pipeline.modes = lambda nav: None
    _sample(ctx, pipeline, 1.01)
    assert pipeline.last_command is not None and pipeline.last_command.t_s == 1.0


def test_a_failing_controller_sends_the_boat_to_hold() -> None:
    ctx, vehicle, _, pipeline = _pipeline()
    texts: list[str] = []
    ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(lambda s: texts.append(s.text))
    _sample(ctx, pipeline, 0.5)
    assert vehicle.arm() is None and vehicle.set_mode(ModeNumber.CRUISE) is None

    def broken(*args: object, **kwargs: object) -> ActuatorCommand:
        raise FloatingPointError("nan in the law")

    vehicle.control.step = broken  # type: ignore[method-assign]
    _sample(ctx, pipeline, 1.0)
    assert vehicle.modes.current.number == ModeNumber.HOLD
    assert "CRUISE failed (nan in the law); switching to HOLD" in texts
    assert pipeline.stats.stage_errors == {"controller": 1}
    _, out = _sample(ctx, pipeline, 1.01)
    assert pipeline.last_command is not None and pipeline.last_command.throttle == 0.0
    assert out.pulse_us[2] == 1100
