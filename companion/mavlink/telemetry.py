"""Telemetry builders: bus topics and vehicle state -> MAVLink messages.

One function per streamed message, each returning a message object or ``None`` when it has
nothing honest to say (no navigation solution yet, no guidance target).  :class:`Telemetry` is
one vehicle's set: these builders plus the status messages its payloads declare
(:mod:`companion.payloads.registry`).  The stream scheduler builds a message at most once per
tick and packs it per link.

Health bits in SYS_STATUS are honest: a sensor is *present* once its topic has published,
*healthy* while its data is fresh and valid.  The GPS-INS unit provides attitude, rates and
position, so the gyro/accel/mag/AHRS bits follow its attitude solution.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from companion.angles import wrap_pi
from companion.app import Context
from companion.link import streams as s
from companion.link.dialect import boat_module, mav
from companion.mavlink import current_report, identity
from companion.messages import (
    ACTUATOR_CMD_TOPIC,
    FENCE_TOPIC,
    MODEL_ERROR_TOPIC,
    NAV_HEALTH_TOPIC,
    NAV_TOPIC,
    RC_IN_TOPIC,
    SERVO_OUT_TOPIC,
    FixType,
    ModeNumber,
    NavState,
)
from companion.vehicle import Vehicle

FRESH_S = 1.0
"""Data older than this is unhealthy."""

UINT16_UNKNOWN = 65535

Builder = Callable[[Context, Vehicle], Any]

_SENSORS_INS = (mav.MAV_SYS_STATUS_SENSOR_3D_GYRO | mav.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                | mav.MAV_SYS_STATUS_SENSOR_3D_MAG | mav.MAV_SYS_STATUS_AHRS)
_SENSOR_GPS = mav.MAV_SYS_STATUS_SENSOR_GPS
_SENSOR_RC = mav.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
_SENSOR_MOTORS = mav.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
_SENSOR_PREARM = mav.MAV_SYS_STATUS_PREARM_CHECK


def time_boot_ms(ctx: Context, vehicle: Vehicle) -> int:
    return int(max(0.0, ctx.clock.now_s() - vehicle.boot_s) * 1000) & 0xFFFFFFFF


def _fresh(ctx: Context, t_s: float | None) -> bool:
    return t_s is not None and ctx.clock.now_s() - t_s <= FRESH_S


def _nav(ctx: Context) -> NavState | None:
    return ctx.bus.topic(NAV_TOPIC).latest()


def _cdeg_0_360(angle_rad: float) -> int:
    return round(math.degrees(angle_rad) % 360.0 * 100) % 36000


def sensor_bits(ctx: Context, vehicle: Vehicle) -> tuple[int, int, int]:
    """(present, enabled, health) for SYS_STATUS."""
    present = enabled = health = _SENSOR_PREARM
    # Geofence (as ArduPilot): present with a FENCE plan, enabled with FENCE_ENABLE, healthy unless in
    # a breach episode; the health bit is set without a fence too (MAVProxy announces a breach when it
    # is clear).
    fence = ctx.bus.topic(FENCE_TOPIC).latest()
    if fence is not None and fence.present:
        present |= mav.MAV_SYS_STATUS_GEOFENCE
        if fence.enabled:
            enabled |= mav.MAV_SYS_STATUS_GEOFENCE
    if fence is None or not (fence.present and fence.enabled and fence.breached):
        health |= mav.MAV_SYS_STATUS_GEOFENCE
    nav = _nav(ctx)
    nav_health = ctx.bus.topic(NAV_HEALTH_TOPIC).latest()  # NavHealth's verdict (frozen, stuck gyro)
    if nav is not None:
        present |= _SENSORS_INS | _SENSOR_GPS
        enabled |= _SENSORS_INS | _SENSOR_GPS
        if _fresh(ctx, nav.t_s) and nav.attitude_valid and (nav_health is None or nav_health.ins_ok):
            health |= _SENSORS_INS
        if (_fresh(ctx, nav.t_s) and nav.position_valid and nav.fix_type >= FixType.FIX_3D
                and (nav_health is None or nav_health.gps_ok)):
            health |= _SENSOR_GPS
    rc = ctx.bus.topic(RC_IN_TOPIC).latest()
    if rc is not None:
        present |= _SENSOR_RC
        enabled |= _SENSOR_RC
        if _fresh(ctx, rc.t_s):
            health |= _SENSOR_RC
    servo = ctx.bus.topic(SERVO_OUT_TOPIC).latest()
    if servo is not None:
        present |= _SENSOR_MOTORS
        enabled |= _SENSOR_MOTORS
        if _fresh(ctx, servo.t_s):
            health |= _SENSOR_MOTORS
    if vehicle.prearm_failures():
        health &= ~_SENSOR_PREARM
    return int(present), int(enabled), int(health)


def sys_status(ctx: Context, vehicle: Vehicle) -> Any:
    present, enabled, health = sensor_bits(ctx, vehicle)
    # No battery monitor on this boat yet: voltage/current/remaining are reported as unknown.
    return mav.MAVLink_sys_status_message(present, enabled, health, 0, UINT16_UNKNOWN, -1, -1, 0, 0, 0, 0,
                                          0, 0)


def system_time(ctx: Context, vehicle: Vehicle) -> Any:
    return mav.MAVLink_system_time_message(int(ctx.clock.unix_time_s() * 1e6), time_boot_ms(ctx, vehicle))


def gps_raw_int(ctx: Context, vehicle: Vehicle) -> Any:
    nav = _nav(ctx)
    if nav is None:
        return mav.MAVLink_gps_raw_int_message(0, 0, 0, 0, 0, UINT16_UNKNOWN, UINT16_UNKNOWN, UINT16_UNKNOWN,
                                               UINT16_UNKNOWN, 255)
    fix = int(nav.fix_type) if _fresh(ctx, nav.t_s) else int(FixType.NO_FIX)
    sog = nav.speed_over_ground_mps
    cog = nav.course_over_ground_rad
    return mav.MAVLink_gps_raw_int_message(
        int(ctx.clock.unix_time_s() * 1e6), fix, round(nav.lat_deg * 1e7), round(nav.lon_deg * 1e7),
        round(nav.alt_m * 1000), UINT16_UNKNOWN, UINT16_UNKNOWN, min(UINT16_UNKNOWN - 1, round(sog * 100)),
        _cdeg_0_360(cog) if sog > 0.05 else UINT16_UNKNOWN, min(254, max(0, nav.satellites)))


def global_position_int(ctx: Context, vehicle: Vehicle) -> Any:
    nav = _nav(ctx)
    if nav is None:
        return None
    home_alt_m = vehicle.home.alt_m if vehicle.home is not None else 0.0
    return mav.MAVLink_global_position_int_message(
        time_boot_ms(ctx, vehicle), round(nav.lat_deg * 1e7), round(nav.lon_deg * 1e7),
        round(nav.alt_m * 1000), round((nav.alt_m - home_alt_m) * 1000), round(nav.vel_north_mps * 100),
        round(nav.vel_east_mps * 100), 0, _cdeg_0_360(nav.heading_rad))


def attitude(ctx: Context, vehicle: Vehicle) -> Any:
    nav = _nav(ctx)
    if nav is None:
        return None
    return mav.MAVLink_attitude_message(time_boot_ms(ctx, vehicle), nav.roll_rad, nav.pitch_rad,
                                        wrap_pi(nav.heading_rad), 0.0, 0.0, nav.r_radps)


def vfr_hud(ctx: Context, vehicle: Vehicle) -> Any:
    nav = _nav(ctx)
    if nav is None:
        return None
    cmd = ctx.bus.topic(ACTUATOR_CMD_TOPIC).latest()
    throttle_pct = 0 if cmd is None else round(100 * max(0.0, min(1.0, cmd.throttle)))
    heading_deg = int(math.degrees(nav.heading_rad) % 360.0)
    # airspeed field: speed through the water is not measured; the surge speed u is the closest.
    return mav.MAVLink_vfr_hud_message(nav.u_mps, nav.speed_over_ground_mps, heading_deg, throttle_pct,
                                       nav.alt_m, 0.0)


def servo_output_raw(ctx: Context, vehicle: Vehicle) -> Any:
    servo = ctx.bus.topic(SERVO_OUT_TOPIC).latest()
    if servo is None:
        return None
    pulses = [int(p) & 0xFFFF for p in servo.pulse_us[:16]] + [0] * max(0, 16 - len(servo.pulse_us))
    return mav.MAVLink_servo_output_raw_message(int(servo.t_s * 1e6) & 0xFFFFFFFF, 0, *pulses)


def rc_channels(ctx: Context, vehicle: Vehicle) -> Any:
    rc = ctx.bus.topic(RC_IN_TOPIC).latest()
    if rc is None:
        return None
    chans = [int(p) & 0xFFFF for p in rc.channels_us[:18]]
    padded = chans + [UINT16_UNKNOWN] * (18 - len(chans))
    return mav.MAVLink_rc_channels_message(time_boot_ms(ctx, vehicle), len(chans), *padded, 255)


def home_position(ctx: Context, vehicle: Vehicle) -> Any:
    home = vehicle.home
    if home is None:
        return None
    return mav.MAVLink_home_position_message(round(home.lat_deg * 1e7), round(home.lon_deg * 1e7),
                                             round(home.alt_m * 1000), 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0],
                                             0.0, 0.0, 0.0, int(ctx.clock.unix_time_s() * 1e6))


def extended_sys_state(ctx: Context, vehicle: Vehicle) -> Any:
    landed = mav.MAV_LANDED_STATE_IN_AIR if vehicle.armed else mav.MAV_LANDED_STATE_ON_GROUND
    return mav.MAVLink_extended_sys_state_message(mav.MAV_VTOL_STATE_UNDEFINED, landed)


def battery_status(ctx: Context, vehicle: Vehicle) -> Any:
    # No battery monitor: every measured quantity is "unknown" as the message defines it.
    return mav.MAVLink_battery_status_message(0, mav.MAV_BATTERY_FUNCTION_ALL, mav.MAV_BATTERY_TYPE_UNKNOWN,
                                              32767, [UINT16_UNKNOWN] * 10, -1, -1, -1, -1)


def nav_controller_output(ctx: Context, vehicle: Vehicle) -> Any:
    target = vehicle.modes.current.nav_target
    if target is None:
        return None
    return mav.MAVLink_nav_controller_output_message(
        0.0, 0.0, round(math.degrees(wrap_pi(target.nav_bearing_rad))),
        round(math.degrees(wrap_pi(target.target_bearing_rad))), min(65535, max(0, round(target.wp_dist_m))),
        0.0, target.speed_error_mps, target.xtrack_error_m)


def position_target_global_int(ctx: Context, vehicle: Vehicle) -> Any:
    target = vehicle.modes.current.nav_target
    if target is None:
        return None
    ignore = (mav.POSITION_TARGET_TYPEMASK_VZ_IGNORE | mav.POSITION_TARGET_TYPEMASK_AX_IGNORE
              | mav.POSITION_TARGET_TYPEMASK_AY_IGNORE | mav.POSITION_TARGET_TYPEMASK_AZ_IGNORE
              | mav.POSITION_TARGET_TYPEMASK_YAW_IGNORE | mav.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
              | mav.POSITION_TARGET_TYPEMASK_VX_IGNORE | mav.POSITION_TARGET_TYPEMASK_VY_IGNORE)
    return mav.MAVLink_position_target_global_int_message(
        time_boot_ms(ctx, vehicle), mav.MAV_FRAME_GLOBAL_INT, ignore, round(target.lat_deg * 1e7),
        round(target.lon_deg * 1e7), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def mission_current(ctx: Context, vehicle: Vehicle) -> Any:
    mission_mode = 1 if vehicle.modes.current.number == ModeNumber.AUTO else 0
    return mav.MAVLink_mission_current_message(vehicle.current_seq, vehicle.mission_total,
                                               int(vehicle.mission_state), mission_mode)


def current_mode_msg(ctx: Context, vehicle: Vehicle) -> Any:
    return identity.current_mode(vehicle)


def fence_status(ctx: Context, vehicle: Vehicle) -> Any:
    """FENCE_STATUS while a FENCE plan is stored (as ArduPilot, nothing without one): breach_status 1
    during a breach episode (the boat or its predicted stop point within FENCE_MARGIN of a boundary),
    the episodes so far, BOUNDARY (the only kind on a boat) and the time the last one began."""
    fence = ctx.bus.topic(FENCE_TOPIC).latest()
    if fence is None or not fence.present:
        return None
    since_boot_s = 0.0 if fence.breach_time_s is None else max(0.0, fence.breach_time_s - vehicle.boot_s)
    breach_ms = int(since_boot_s * 1000)
    kind = mav.FENCE_BREACH_BOUNDARY if fence.breach_count else mav.FENCE_BREACH_NONE
    mitigation = mav.FENCE_MITIGATE_UNKNOWN if fence.enabled else mav.FENCE_MITIGATE_NONE
    return mav.MAVLink_fence_status_message(int(fence.breached), min(65535, fence.breach_count), kind,
                                            breach_ms & 0xFFFFFFFF, mitigation)


def usv_model_status(ctx: Context, vehicle: Vehicle) -> Any:
    usv = boat_module()
    if usv is None:
        return None
    topic = ctx.bus.topic(MODEL_ERROR_TOPIC)
    err = topic.latest()
    if err is None:
        return usv.MAVLink_usv_model_status_message(time_boot_ms(ctx, vehicle), *([math.nan] * 6), math.nan,
                                                    math.nan, 0, usv.USV_MODEL_HEALTH_NOT_RUNNING)
    stds = [math.sqrt(max(0.0, v)) for v in err.delta_nu_var]
    health = usv.USV_MODEL_HEALTH_OK if _fresh(ctx, err.t_s) else usv.USV_MODEL_HEALTH_NOT_RUNNING
    return usv.MAVLink_usv_model_status_message(time_boot_ms(ctx, vehicle), *err.delta_nu, *stds,
                                                err.innovation_nis, math.nan, topic.seq & 0xFFFFFFFF, health)


BUILDERS: dict[int, Builder] = {
    s.HEARTBEAT: lambda ctx, v: identity.heartbeat(v),
    s.SYS_STATUS: sys_status,
    s.SYSTEM_TIME: system_time,
    s.GPS_RAW_INT: gps_raw_int,
    s.ATTITUDE: attitude,
    s.GLOBAL_POSITION_INT: global_position_int,
    s.SERVO_OUTPUT_RAW: servo_output_raw,
    s.MISSION_CURRENT: mission_current,
    s.NAV_CONTROLLER_OUTPUT: nav_controller_output,
    s.RC_CHANNELS: rc_channels,
    s.VFR_HUD: vfr_hud,
    s.POSITION_TARGET_GLOBAL_INT: position_target_global_int,
    s.BATTERY_STATUS: battery_status,
    s.HOME_POSITION: home_position,
    s.EXTENDED_SYS_STATE: extended_sys_state,
    s.CURRENT_MODE: current_mode_msg,
    s.USV_MODEL_STATUS: usv_model_status,
    s.FENCE_STATUS: fence_status,
    s.USV_CURRENT_ESTIMATE: lambda ctx, v: current_report.usv_current_estimate(ctx, time_boot_ms(ctx, v)),
    s.NAMED_VALUE_FLOAT: lambda ctx, v: current_report.named_current_values(ctx, time_boot_ms(ctx, v)),
}
"""Message id -> builder for streamed and requested messages.  A builder returns one message, a
tuple of messages sent together (NAMED_VALUE_FLOAT: one per name), or ``None``."""


StatusBuilder = Callable[[int], Any]
"""A payload's status message from ``time_boot_ms``."""


class Telemetry:
    """The messages one vehicle streams or sends on request (REQUEST_MESSAGE)."""

    def __init__(self, ctx: Context, vehicle: Vehicle,
                 extra: Mapping[int, StatusBuilder] | None = None) -> None:
        self.ctx = ctx
        self.vehicle = vehicle
        self.extra = dict(extra or {})

    def known(self, msg_id: int) -> bool:
        """Whether this vehicle can build message ``msg_id``."""
        return int(msg_id) in BUILDERS or int(msg_id) in self.extra

    def build(self, msg_id: int) -> Any:
        """The current value of message ``msg_id`` (``None``: unknown id or nothing to report)."""
        builder = BUILDERS.get(int(msg_id))
        if builder is not None:
            return builder(self.ctx, self.vehicle)
        status = self.extra.get(int(msg_id))
        return None if status is None else status(time_boot_ms(self.ctx, self.vehicle))
