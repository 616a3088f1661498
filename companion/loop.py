"""The 100 Hz control loop driven by the GPS-INS: one servo frame per navigation sample.

For every navigation sample parsed from the GPS-INS bytes, :class:`ControlLoop`

1. publishes the :class:`~companion.messages.NavState` on ``nav``;
2. runs its ordered synchronous stages ``fn(nav)`` (estimator, mode/guidance, controllers;
   each publishes on the bus; a failing stage is logged and counted, the others still run);
3. writes exactly ONE servo frame built from the latest ``actuator_cmd``
   (default when none: engine off, throttle 0, nozzle centred) merged with the payloads'
   ``payload_cmd``, and publishes it on ``servo_out``.

The one-frame-per-sample rule is what the simulator's lockstep waits for (the frame's ACK
is the sample's GPS time field).  Without samples for ``USV_NAV_TMO_S`` the
:class:`HardwareIoService` still refreshes the frame at 10 Hz, so failsafe commands reach
the servos when the GPS-INS is silent.

Other services get the loop with :func:`get_control_loop` (one per context) and add their
stages at construction: ``get_control_loop(ctx).add_stage("ukf", estimator.update)``.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from companion.actuators.servo import ServoMap, encode_frame
from companion.app import BaseService, Context, Service
from companion.messages import ActuatorCommand, NavState, ServoOutputs
from companion.sensors.gpsins import GpsInsParser
from companion.transport import ByteLink, open_link

log = logging.getLogger(__name__)

StageFn = Callable[[NavState], None]

GNSS_LINK_KEY = "gnss_link"
SERVO_LINK_KEY = "servo_link"
"""``ctx.extras`` keys under which the simulator (or a test) puts ready-made links."""


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
        listeners) and of building the servo frame, since the last :meth:`reset_timing`."""
        n = max(1, self.samples - self._timed_samples)
        out = {name: 1e6 * t / n for name, t in self.stage_time_s.items()}
        out["servo_frame"] = 1e6 * self.frame_time_s / max(1, self.frames - self._timed_frames)
        return out

    def reset_timing(self) -> None:
        """Start timing afresh (e.g. after a warm-up that compiled or cached things)."""
        self._timed_samples, self._timed_frames = self.samples, self.frames
        self.stage_time_s = dict.fromkeys(self.stage_time_s, 0.0)
        self.frame_time_s = 0.0


class ControlLoop:
    """Ordered synchronous stages run once per navigation sample, then one servo frame."""

    def __init__(self, ctx: Context) -> None:
        from companion.payloads.topics import PAYLOAD_CMD_TOPIC, PayloadCommand

        self.ctx = ctx
        self.stages: list[tuple[str, StageFn]] = []
        self.stats = LoopStats()
        self.output: ByteLink | None = None
        self.servo_map = ServoMap(ctx.params)
        bus = ctx.bus
        self._nav = bus.topic("nav", NavState)
        self._cmd = bus.topic("actuator_cmd", ActuatorCommand)
        self._payload = bus.topic(PAYLOAD_CMD_TOPIC, PayloadCommand)
        self._servo_out = bus.topic("servo_out", ServoOutputs)
        self.last_sample_s: float | None = None
        self._safe_us: int | None = None
        ctx.params.add_listener(self._on_param)

    def _on_param(self, name: str, _value: float) -> None:
        if name == "USV_LNCH_SAFE_US":
            self._safe_us = None

    def add_stage(self, name: str, fn: StageFn, *, before: str | None = None) -> None:
        """Append a stage (or insert it before the stage named ``before``)."""
        if any(n == name for n, _ in self.stages):
            raise ValueError(f"control loop stage {name!r} already exists")
        if before is None:
            self.stages.append((name, fn))
            return
        names = [n for n, _ in self.stages]
        if before not in names:
            raise ValueError(f"no control loop stage {before!r} (stages: {names})")
        self.stages.insert(names.index(before), (name, fn))

    def remove_stage(self, name: str) -> None:
        self.stages = [(n, f) for n, f in self.stages if n != name]

    def on_nav(self, nav: NavState, ack: str = "") -> ServoOutputs:
        """Run one control step for ``nav`` and write its servo frame."""
        stats = self.stats
        stats.samples += 1
        self.last_sample_s = nav.t_s
        clock = time.perf_counter
        times = stats.stage_time_s
        t0 = clock()
        self._nav.publish(nav)
        t1 = clock()
        times["nav_publish"] = times.get("nav_publish", 0.0) + (t1 - t0)
        for name, fn in self.stages:
            try:
                fn(nav)
            except Exception:
                stats.stage_errors[name] = stats.stage_errors.get(name, 0) + 1
                if stats.stage_errors[name] <= 3:
                    log.exception("control loop stage %s failed", name)
            t0, t1 = t1, clock()
            times[name] = times.get(name, 0.0) + (t1 - t0)
        return self.write_frame(ack)

    def _launcher_safe_us(self) -> int:
        if self._safe_us is None:
            params = self.ctx.params
            self._safe_us = round(params.get("USV_LNCH_SAFE_US")) if "USV_LNCH_SAFE_US" in params else 1100
        return self._safe_us

    def current_pulses(self) -> tuple[int, ...]:
        """Pulses of the latest ``actuator_cmd`` with the payloads' ``payload_cmd`` merged in
        (as :func:`companion.payloads.topics.merge_into_actuator_command`: no payload
        command means launcher safe and pump off)."""
        cmd = self._cmd.latest() or ActuatorCommand(t_s=self.ctx.clock.now_s())
        payload = self._payload.latest()
        safe = self._safe_us if self._safe_us is not None else self._launcher_safe_us()
        if payload is None:
            return self.servo_map.pulses(cmd, launcher_pulse_us=1900, launcher_safe_us=safe, valve_bottle=0,
                                         launcher_trigger=False, pump_on=False)
        return self.servo_map.pulses(cmd, launcher_pulse_us=payload.trigger_pulse_us, launcher_safe_us=safe,
                                     valve_bottle=payload.valve_bottle,
                                     launcher_trigger=payload.launcher_trigger, pump_on=payload.pump_on)

    def write_frame(self, ack: str = "") -> ServoOutputs:
        t0 = time.perf_counter()
        pulses = self.current_pulses()
        out = ServoOutputs(t_s=self.ctx.clock.now_s(), pulse_us=pulses)
        self._servo_out.publish(out)
        self.stats.frames += 1
        frame = encode_frame(ack, pulses)
        self.stats.frame_time_s += time.perf_counter() - t0  # the peer's handling is not ours
        if self.output is not None:
            self.output.write(frame)
        return out


def get_control_loop(ctx: Context) -> ControlLoop:
    """The context's one control loop (created on first use, kept in ``ctx.extras``)."""
    loop = ctx.extras.get("control_loop")
    if loop is None:
        loop = ControlLoop(ctx)
        ctx.extras["control_loop"] = loop
    assert isinstance(loop, ControlLoop)
    return loop


class HardwareIoService(BaseService):
    """Opens the GPS-INS and servo links, parses sensors into the loop, refreshes servos."""

    name = "hardware-io"

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.loop = get_control_loop(ctx)
        self.parser = GpsInsParser(ctx.clock, ctx.bus, self.loop.on_nav)
        self.gnss: ByteLink | None = None
        self.servo: ByteLink | None = None

    def _link(self, key: str, setting: str, baud: int) -> ByteLink | None:
        given = self.ctx.extras.get(key)
        if given is not None:
            return given  # type: ignore[return-value]
        spec = str(self.ctx.config[setting])
        if not spec:
            return None
        return open_link(spec, self.ctx.clock, baud, what=setting)

    async def start(self) -> None:
        baud = int(self.ctx.config["sensors.gnss_baud"])
        self.gnss = self._link(GNSS_LINK_KEY, "sensors.gnss_port", baud)
        self.servo = self._link(SERVO_LINK_KEY, "servos.port", baud)
        if self.gnss is None:
            log.warning("no GPS-INS link (sensors.gnss_port is empty): the control loop will not run")
        else:
            self.gnss.set_receiver(self.parser.feed)
            await self.gnss.open()
        if self.servo is not None:
            await self.servo.open()
            if self.servo is not self.gnss:
                self.servo.set_receiver(lambda _data: None)
        self.loop.output = self.servo

    async def run(self) -> None:
        clock = self.ctx.clock
        timeout_s = self.ctx.params.get("USV_NAV_TMO_S") if "USV_NAV_TMO_S" in self.ctx.params else 0.5
        while True:
            await clock.sleep(0.1)
            last = self.loop.last_sample_s
            if last is None or clock.now_s() - last > timeout_s:
                self.loop.write_frame("")

    async def stop(self) -> None:
        self.loop.output = None
        for link in (self.gnss, self.servo):
            if link is not None:
                await link.close()
        await asyncio.sleep(0)


def build_hardware_services(ctx: Context) -> list[Service]:
    """The sensor/loop/actuator services (first in the companion's start-up order)."""
    return [HardwareIoService(ctx)]
