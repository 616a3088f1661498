"""The pneumatic rope launcher (chapter section 4.1) and its interlocks.

A 30 MPa gas cylinder throws a rope with a lifebuoy up to 150 m when the trigger servo
is pulsed; the lifebuoy inflates 5 s after it hits the water.  The launcher is fixed to
the hull and throws along the bow, so the launch bearing is the boat's heading.  Firing
near people by mistake is dangerous, so firing needs ALL of:

1. the vehicle is armed;
2. the RC/GCS selector switch gives the companion control (not the RC transmitter);
3. the cylinder pressure is at least ``USV_LNCH_MIN_MPA`` (a fresh reading);
4. a shot is left;
5. the launcher itself was armed by a separate command (two-step arm-then-fire) and its
   window of ``USV_LNCH_ARM_S`` has not expired.

Physical conditions (1-4) are checked first, so a refusal names the most fundamental
reason.  Arming checks 1-4 as well.  Disarming the vehicle or giving control to the RC
makes the launcher safe at once.  Each launch is logged with time, position, heading and
pressure in the durable :class:`~companion.payloads.samplelog.SampleLog`.
"""

from __future__ import annotations

import enum
import logging
import math
import sqlite3

from companion.app import Context
from companion.messages import (
    NAV_TOPIC,
    PAYLOAD_SENSORS_TOPIC,
    RC_IN_TOPIC,
    VEHICLE_STATUS_TOPIC,
    ControlSource,
    RcInput,
    VehicleStatus,
)
from companion.payloads.samplelog import LaunchRecord, SampleLog
from companion.payloads.topics import PayloadOutputs

log = logging.getLogger(__name__)

SENSOR_STALE_S = 3.0
"""A payload sensor reading older than this is not trusted for the pressure interlock."""


class LauncherState(enum.IntEnum):
    """USV_LAUNCHER_STATE of the dialect."""

    SAFE = 0
    ARMED = 1
    FIRING = 2
    EMPTY = 3


class Interlock(enum.IntFlag):
    """USV_LAUNCHER_INTERLOCK of the dialect: a set bit is a satisfied condition."""

    VEHICLE_ARMED = 1
    LAUNCHER_ARMED = 2
    PRESSURE_OK = 4
    COMPANION_CONTROL = 8
    SHOT_AVAILABLE = 16


class RopeLauncher:
    """Arm-then-fire state machine with interlocks; outputs go through :class:`PayloadOutputs`."""

    def __init__(self, ctx: Context, outputs: PayloadOutputs, samplelog: SampleLog | None = None) -> None:
        self.ctx = ctx
        self.outputs = outputs
        self.samplelog = samplelog
        self.armed_until_s: float | None = None
        self.firing = False
        self.shots_left = ctx.params.get_int("USV_LNCH_SHOTS")
        self.last_launch: LaunchRecord | None = None
        self._safe_us: int | None = None
        if samplelog is not None:
            if (launches := samplelog.launches()):
                self.last_launch = launches[-1]
            if (saved := samplelog.shots_left()) is not None:
                self.shots_left = saved  # the counter survives a restart (a reload is a USV_LNCH_SHOTS set)
        ctx.params.add_listener(self._on_param)
        ctx.params.add_set_listener(self._on_param_set)
        ctx.bus.topic(VEHICLE_STATUS_TOPIC).add_listener(self._on_vehicle_status)
        ctx.bus.topic(RC_IN_TOPIC).add_listener(self._on_rc)
        outputs.set(launcher_trigger=False, trigger_pulse_us=ctx.params.get_int("USV_LNCH_SAFE_US"))

    # -- inputs -------------------------------------------------------------------------------
    def _on_param(self, name: str, value: float) -> None:
        if name == "USV_LNCH_SAFE_US":
            self._safe_us = None

    def _on_param_set(self, name: str, value: float) -> None:
        """Every accepted USV_LNCH_SHOTS set is a reload, even with the value it already had."""
        if name == "USV_LNCH_SHOTS":
            self.shots_left = int(value)
            if self.samplelog is not None:
                try:
                    self.samplelog.set_shots_left(self.shots_left)
                except sqlite3.Error as exc:
                    log.warning("launcher shot count not saved: %s", exc)
            log.info("launcher reloaded: %d shot(s)", self.shots_left)

    def _on_vehicle_status(self, status: VehicleStatus) -> None:
        if not status.armed and self.armed_until_s is not None:
            self.make_safe("vehicle disarmed")

    def _on_rc(self, rc: RcInput) -> None:
        if rc.source != ControlSource.COMPANION and self.armed_until_s is not None:
            self.make_safe("RC took control")

    def vehicle_armed(self) -> bool:
        """The vehicle's arming state as it last published it (``vehicle_status``)."""
        status = self.ctx.bus.topic(VEHICLE_STATUS_TOPIC).latest()
        return bool(status and status.armed)

    def safe_pulse_us(self) -> int:
        """The trigger servo's safe pulse (USV_LNCH_SAFE_US, read once per change)."""
        if self._safe_us is None:
            self._safe_us = round(self.ctx.params.get_or("USV_LNCH_SAFE_US", 1100))
        return self._safe_us

    def pressure_mpa(self) -> float | None:
        """The latest fresh cylinder pressure, or None if unknown/stale."""
        reading = self.ctx.bus.topic(PAYLOAD_SENSORS_TOPIC).latest()
        if reading is None or self.ctx.clock.now_s() - reading.t_s > SENSOR_STALE_S:
            return None
        p = reading.cylinder_pressure_mpa
        return p if math.isfinite(p) else None

    def control_source(self) -> ControlSource | None:
        rc = self.ctx.bus.topic(RC_IN_TOPIC).latest()
        return None if rc is None else rc.source

    # -- state --------------------------------------------------------------------------------
    def arm_time_left_s(self) -> float:
        if self.armed_until_s is None:
            return 0.0
        return max(0.0, self.armed_until_s - self.ctx.clock.now_s())

    def state(self) -> LauncherState:
        if self.firing:
            return LauncherState.FIRING
        if self.shots_left <= 0:
            return LauncherState.EMPTY
        return LauncherState.ARMED if self.arm_time_left_s() > 0 else LauncherState.SAFE

    def interlocks(self) -> Interlock:
        bits = Interlock(0)
        if self.vehicle_armed():
            bits |= Interlock.VEHICLE_ARMED
        if self.arm_time_left_s() > 0:
            bits |= Interlock.LAUNCHER_ARMED
        pressure = self.pressure_mpa()
        if pressure is not None and pressure >= self.ctx.params.get("USV_LNCH_MIN_MPA"):
            bits |= Interlock.PRESSURE_OK
        if self.control_source() == ControlSource.COMPANION:
            bits |= Interlock.COMPANION_CONTROL
        if self.shots_left > 0:
            bits |= Interlock.SHOT_AVAILABLE
        return bits

    def _physical_refusal(self) -> str | None:
        """Reason why neither arming nor firing is allowed now (interlocks 1-4), or None."""
        if not self.vehicle_armed():
            return "launcher: vehicle not armed"
        source = self.control_source()
        if source is None:
            return "launcher: selector state unknown"
        if source != ControlSource.COMPANION:
            return "launcher: RC has control (selector)"
        pressure = self.pressure_mpa()
        min_mpa = self.ctx.params.get("USV_LNCH_MIN_MPA")
        if pressure is None:
            return "launcher: cylinder pressure unknown"
        if pressure < min_mpa:
            return f"launcher: pressure low {pressure:.1f}<{min_mpa:.1f} MPa"
        if self.shots_left <= 0:
            return "launcher: no shot left"
        return None

    # -- commands -----------------------------------------------------------------------------
    def arm(self, window_s: float | None = None) -> str | None:
        """Arm for ``window_s`` (default USV_LNCH_ARM_S); returns a refusal reason or None."""
        if self.firing:
            return "launcher: busy firing"
        if (reason := self._physical_refusal()) is not None:
            return reason
        max_window = self.ctx.params.definition("USV_LNCH_ARM_S").max
        if window_s is None or not math.isfinite(window_s) or window_s <= 0:
            window_s = self.ctx.params.get("USV_LNCH_ARM_S")
        window_s = min(window_s, max_window)
        self.armed_until_s = self.ctx.clock.now_s() + window_s
        log.info("launcher armed for %.1f s", window_s)
        return None

    def make_safe(self, why: str = "") -> None:
        if self.armed_until_s is not None:
            log.info("launcher safe%s", f" ({why})" if why else "")
        self.armed_until_s = None

    def fire_refusal(self) -> str | None:
        """Why FIRE would be refused right now (interlocks 1-5), or None."""
        if self.firing:
            return "launcher: busy firing"
        if (reason := self._physical_refusal()) is not None:
            return reason
        if self.armed_until_s is None:
            return "launcher: not armed (send ARM first)"
        if self.arm_time_left_s() <= 0:
            return "launcher: arm window expired"
        return None

    async def fire(self, mission_seq: int | None = None) -> str | None:
        """Pulse the trigger servo once if every interlock holds; returns a refusal reason or None."""
        if (reason := self.fire_refusal()) is not None:
            if reason == "launcher: arm window expired":
                self.armed_until_s = None
            return reason
        params = self.ctx.params
        self.firing = True
        self.armed_until_s = None  # one arm, one shot
        nav = self.ctx.bus.topic(NAV_TOPIC).latest()
        pressure = self.pressure_mpa()
        t_unix_s = self.ctx.clock.unix_time_s()
        try:
            self.outputs.set(launcher_trigger=True, trigger_pulse_us=params.get_int("USV_LNCH_PWM_US"))
            await self.ctx.clock.sleep(params.get("USV_LNCH_PULSE_S"))
        finally:
            self.outputs.set(launcher_trigger=False, trigger_pulse_us=params.get_int("USV_LNCH_SAFE_US"))
            self.firing = False
        self.shots_left = shots_left = max(0, self.shots_left - 1)
        heading_deg = math.degrees(nav.heading_rad) % 360.0 if nav is not None else None
        lat = nav.lat_deg if nav is not None else None
        lon = nav.lon_deg if nav is not None else None
        launch_id = 0
        if self.samplelog is not None:
            launch_id = self.samplelog.add_launch(
                t_unix_s=t_unix_s,
                lat_deg=lat,
                lon_deg=lon,
                heading_deg=heading_deg,
                pressure_mpa=pressure,
                mission_seq=mission_seq,
                shots_left=shots_left,
            )
        self.last_launch = LaunchRecord(launch_id, t_unix_s, lat, lon, heading_deg, pressure, mission_seq)
        log.info("launch: %s", self.last_launch)
        return None
