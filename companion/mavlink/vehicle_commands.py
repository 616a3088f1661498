"""The vehicle's built-in commands (arming, modes, navigation, home, servos, message requests).

Each handler checks its parameters (NaN and out-of-range values are DENIED with a reason)
and calls :class:`~companion.vehicle.Vehicle`; none touches actuators directly.
:class:`VehicleCommands` holds the handlers of one vehicle; :meth:`VehicleCommands.register`
adds them to that vehicle's command registry.
"""

from __future__ import annotations

import math
from typing import Any

from companion.actuators.overrides import N_RELAYS, override_refusal, relay_channel
from companion.actuators.servo import N_CHANNELS, ServoMap
from companion.clock import Clock
from companion.guidance.geo import lat_lon_problem
from companion.link import streams
from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.mavlink import identity
from companion.mavlink.commands import MAV_RESULT, CommandRegistry, CommandRequest, CommandResult
from companion.mavlink.telemetry import Telemetry
from companion.messages import GuidedTarget, ModeNumber
from companion.mission.validate import MAX_SPEED_MPS
from companion.params import ParamStore
from companion.vehicle import FORCE_MAGIC, Vehicle

SERVO_CHANNELS = 16
"""DO_SET_SERVO accepts MAVLink's 16 channels; those beyond the frame's 8 are refused as not wired."""
SERVO_MIN_US = 500
SERVO_MAX_US = 2500



def _is_int(x: float) -> bool:
    return math.isfinite(x) and float(x).is_integer()


def _reply(cmd: CommandRequest, msg: Any) -> None:
    link = cmd.link
    if isinstance(link, Link):
        link.send(msg)


def _speed_or_none(speed_mps: float, what: str) -> tuple[float | None, str | None]:
    if not math.isfinite(speed_mps) or speed_mps < 0:
        return None, None  # -1 / NaN: keep the default speed
    if speed_mps > MAX_SPEED_MPS:
        return None, f"{what}: speed {speed_mps:g} m/s above {MAX_SPEED_MPS:g} m/s"
    return speed_mps, None


class VehicleCommands:
    """The built-in command handlers of one vehicle."""

    def __init__(self, vehicle: Vehicle, params: ParamStore, clock: Clock, telemetry: Telemetry,
                 system_id: int, servo_map: ServoMap) -> None:
        self.vehicle = vehicle
        self.servo_map = servo_map
        """Which outputs are autopilot-owned (the boat's and the payloads')."""
        self.params = params
        self.clock = clock
        self.telemetry = telemetry
        self.system_id = system_id

    async def arm_disarm(self, cmd: CommandRequest) -> CommandResult:
        vehicle = self.vehicle
        force = int(cmd.param2) == FORCE_MAGIC if math.isfinite(cmd.param2) else False
        if cmd.param1 == 1.0:
            reason = vehicle.arm(force=force)
        elif cmd.param1 == 0.0:
            reason = vehicle.disarm(force=force)
        else:
            return CommandResult.denied(f"ARM_DISARM: param1 must be 0 or 1, got {cmd.param1:g}")
        return CommandResult.accepted() if reason is None else CommandResult.denied(reason)

    def _set_mode(self, number: int) -> CommandResult:
        reason = self.vehicle.set_mode(number)
        if reason is None:
            return CommandResult.accepted()
        return CommandResult.denied(f"Mode change failed: {reason}")

    async def do_set_mode(self, cmd: CommandRequest) -> CommandResult:
        base_mode, custom_mode = cmd.param1, cmd.param2
        if not _is_int(base_mode) or not int(base_mode) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return CommandResult.denied("DO_SET_MODE: only custom modes are supported (param1 bit 1)")
        if not _is_int(custom_mode) or custom_mode < 0:
            return CommandResult.denied(f"DO_SET_MODE: mode {custom_mode:g} is not a mode number")
        return self._set_mode(int(custom_mode))

    async def do_set_standard_mode(self, cmd: CommandRequest) -> CommandResult:
        if not _is_int(cmd.param1):
            return CommandResult.denied("DO_SET_STANDARD_MODE: param1 must be a MAV_STANDARD_MODE")
        mode = self.vehicle.modes.by_standard_mode(int(cmd.param1))
        if mode is None or int(cmd.param1) == 0:
            return CommandResult.denied(f"Standard mode {int(cmd.param1)} is not available on this vehicle")
        return self._set_mode(mode.number)

    async def return_to_launch(self, cmd: CommandRequest) -> CommandResult:
        return self._set_mode(ModeNumber.RTL)

    async def mission_start(self, cmd: CommandRequest) -> CommandResult:
        vehicle = self.vehicle
        if len(vehicle.mission_items()) <= vehicle.first_mission_seq:
            return CommandResult.denied("Mission start failed: no mission")
        first = cmd.param1
        if math.isfinite(first) and first > 0:
            if not first.is_integer():
                return CommandResult.denied(f"MISSION_START: first item {first:g} is not an item number")
            reason = vehicle.set_current(int(first))
            if reason:
                return CommandResult.denied(f"Mission start failed: {reason}")
        vehicle.start_mission()
        if vehicle.modes.current.number != ModeNumber.AUTO:
            return self._set_mode(ModeNumber.AUTO)
        return CommandResult.accepted()

    async def do_set_mission_current(self, cmd: CommandRequest) -> CommandResult:
        if not _is_int(cmd.param1) or cmd.param1 < 0:
            return CommandResult.denied(f"SET_MISSION_CURRENT: {cmd.param1:g} is not an item number")
        reason = self.vehicle.set_current(int(cmd.param1))
        return CommandResult.accepted() if reason is None else CommandResult.denied(reason)

    async def do_reposition(self, cmd: CommandRequest) -> CommandResult:
        vehicle = self.vehicle
        lat_deg, lon_deg = cmd.lat_deg, cmd.lon_deg
        if (bad := lat_lon_problem(lat_deg, lon_deg, zero_is_missing=True)) is not None:
            return CommandResult.denied(f"Reposition refused: {bad.text}")
        if (outside := vehicle.target_problem(lat_deg, lon_deg)) is not None:
            return CommandResult.denied(f"Reposition refused: {outside}")
        speed, problem = _speed_or_none(cmd.param1, "Reposition refused")
        if problem:
            return CommandResult.denied(problem)
        radius = cmd.param3 if math.isfinite(cmd.param3) and cmd.param3 > 0 else None
        change_mode = math.isfinite(cmd.param2) and int(cmd.param2) & mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        previous = vehicle.guided_target
        vehicle.guided_target = GuidedTarget(lat_deg, lon_deg, speed, radius, self.clock.now_s())
        if vehicle.modes.current.number != ModeNumber.GUIDED:
            if not change_mode:
                vehicle.guided_target = previous
                return CommandResult.denied("Reposition refused: not in GUIDED (set param2 bit 1 to switch)")
            result = self._set_mode(ModeNumber.GUIDED)
            if result.result != MAV_RESULT.ACCEPTED:
                vehicle.guided_target = previous
            return result
        return CommandResult.accepted()

    async def do_change_speed(self, cmd: CommandRequest) -> CommandResult:
        speed = cmd.param2
        vehicle = self.vehicle
        if speed in (-1.0, -2.0):
            if speed == -2.0:
                vehicle.speed_override_mps = None
            return CommandResult.accepted()
        if not math.isfinite(speed) or not 0.0 <= speed <= MAX_SPEED_MPS:
            return CommandResult.denied(f"Change speed refused: {speed:g} m/s outside [0, {MAX_SPEED_MPS:g}]")
        vehicle.speed_override_mps = speed
        return CommandResult.accepted()

    async def do_set_home(self, cmd: CommandRequest) -> CommandResult:
        vehicle = self.vehicle
        if cmd.param1 == 1.0:
            nav = vehicle.nav()
            if nav is None or not nav.position_valid:
                return CommandResult.denied("Set home refused: no position estimate")
            reason = vehicle.set_home(nav.lat_deg, nav.lon_deg, nav.alt_m)
        else:
            if (bad := lat_lon_problem(cmd.lat_deg, cmd.lon_deg, zero_is_missing=True)) is not None:
                return CommandResult.denied(f"Set home refused: {bad.text}")
            alt = cmd.param7 if math.isfinite(cmd.param7) else 0.0
            reason = vehicle.set_home(cmd.lat_deg, cmd.lon_deg, alt)
        return CommandResult.accepted() if reason is None else CommandResult.denied(reason)

    async def do_set_servo(self, cmd: CommandRequest) -> CommandResult:
        """DO_SET_SERVO on a free output (see :mod:`companion.actuators.overrides`); 0 us releases it."""
        channel, pwm = cmd.param1, cmd.param2
        if not _is_int(channel) or not 1 <= channel <= SERVO_CHANNELS:
            return CommandResult.denied(f"Set servo refused: channel {channel:g} not in 1..{SERVO_CHANNELS}")
        if not _is_int(pwm) or not (pwm == 0 or SERVO_MIN_US <= pwm <= SERVO_MAX_US):
            return CommandResult.denied(
                f"Set servo refused: {pwm:g} us not in {SERVO_MIN_US}..{SERVO_MAX_US}")
        refusal = override_refusal(self.servo_map.owned_channels(), int(channel), N_CHANNELS)
        if refusal is not None:
            return CommandResult.denied(f"Set servo {int(channel)} refused: {refusal}")
        overrides = self.vehicle.servo_overrides_us
        if pwm == 0:
            overrides.pop(int(channel), None)
        else:
            overrides[int(channel)] = int(pwm)
        return CommandResult.accepted()

    async def do_set_relay(self, cmd: CommandRequest) -> CommandResult:
        """DO_SET_RELAY: relay n drives output USV_RLY{n}_CH with USV_SW_PWM_ON/OFF."""
        instance, setting = cmd.param1, cmd.param2
        if not _is_int(instance) or not 0 <= instance < N_RELAYS:
            return CommandResult.denied(f"Set relay refused: relay {instance:g} not in 0..{N_RELAYS - 1}")
        if setting not in (0.0, 1.0):
            return CommandResult.denied(f"Set relay refused: setting {setting:g} must be 0 or 1")
        relay = int(instance)
        channel = relay_channel(self.params, relay)
        if channel == 0:
            return CommandResult.denied(f"Set relay {relay} refused: USV_RLY{relay}_CH is 0")
        refusal = override_refusal(self.servo_map.owned_channels(), channel, N_CHANNELS)
        if refusal is not None:
            return CommandResult.denied(f"Set relay {relay} refused: ch {channel} {refusal}")
        vehicle = self.vehicle
        on = setting == 1.0
        vehicle.relays[relay] = on
        pulse_us = self.params.get_int("USV_SW_PWM_ON" if on else "USV_SW_PWM_OFF")
        vehicle.servo_overrides_us[channel] = pulse_us
        return CommandResult.accepted()

    def send_message_now(self, cmd: CommandRequest, msg_id: int, param2: float = 0.0) -> CommandResult:
        """Answer REQUEST_MESSAGE-like commands: ACK first, then the message on the requesting link."""
        vehicle = self.vehicle
        system_id = self.system_id
        msgs: list[Any]
        if msg_id == streams.AUTOPILOT_VERSION:
            msgs = [identity.autopilot_version(vehicle, system_id)]
        elif msg_id == streams.AVAILABLE_MODES:
            all_modes = identity.available_modes(vehicle)
            index = int(param2) if _is_int(param2) else 0
            if index > len(all_modes) or index < 0:
                return CommandResult.denied(f"AVAILABLE_MODES: no mode index {index}")
            msgs = all_modes if index == 0 else all_modes[index - 1:index]
        elif not self.telemetry.known(msg_id):
            # Among others PROTOCOL_VERSION (300), which pymavlink's message set lacks (QGC then relies
            # on the MAVLink 2 frames it already sees), and COMPONENT_INFORMATION / COMPONENT_METADATA
            # (395/397), not served: a clean NACK.
            return CommandResult.unsupported()
        else:
            msg = self.telemetry.build(msg_id)
            if msg is None:  # e.g. HOME_POSITION before the first fix: clients ask again
                return CommandResult.failed("")
            msgs = list(msg) if isinstance(msg, tuple) else [msg]

        def send() -> None:
            for m in msgs:
                _reply(cmd, m)

        return CommandResult(MAV_RESULT.ACCEPTED, after_ack=send)

    async def request_message(self, cmd: CommandRequest) -> CommandResult:
        if not _is_int(cmd.param1) or cmd.param1 < 0:
            return CommandResult.denied(f"REQUEST_MESSAGE: {cmd.param1:g} is not a message id")
        return self.send_message_now(cmd, int(cmd.param1), cmd.param2)

    async def get_home_position(self, cmd: CommandRequest) -> CommandResult:
        return self.send_message_now(cmd, streams.HOME_POSITION)

    async def request_autopilot_capabilities(self, cmd: CommandRequest) -> CommandResult:
        return self.send_message_now(cmd, streams.AUTOPILOT_VERSION)

    async def set_message_interval(self, cmd: CommandRequest) -> CommandResult:
        msg_id, interval_us = cmd.param1, cmd.param2
        if not _is_int(msg_id) or msg_id < 0:
            return CommandResult.denied(f"SET_MESSAGE_INTERVAL: {msg_id:g} is not a message id")
        if not math.isfinite(interval_us) or interval_us < -1:
            return CommandResult.denied(f"SET_MESSAGE_INTERVAL: interval {interval_us:g} us is not valid")
        if not self.telemetry.known(int(msg_id)):
            return CommandResult.denied(f"SET_MESSAGE_INTERVAL: message {int(msg_id)} is not available")
        link = cmd.link
        if isinstance(link, Link):
            link.rates.set_interval_us(int(msg_id), interval_us)
        return CommandResult.accepted()

    def register(self, registry: CommandRegistry) -> None:
        """Add the built-in commands to ``registry``."""
        r = registry.register
        r(mav.MAV_CMD_COMPONENT_ARM_DISARM, self.arm_disarm, required_params=(1,), name="ARM_DISARM")
        r(mav.MAV_CMD_DO_SET_MODE, self.do_set_mode, required_params=(1, 2), name="DO_SET_MODE")
        r(mav.MAV_CMD_DO_SET_STANDARD_MODE, self.do_set_standard_mode, required_params=(1,),
          name="DO_SET_STANDARD_MODE")
        r(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, self.return_to_launch, name="RETURN_TO_LAUNCH")
        r(mav.MAV_CMD_MISSION_START, self.mission_start, name="MISSION_START")
        r(mav.MAV_CMD_DO_SET_MISSION_CURRENT, self.do_set_mission_current, required_params=(1,),
          name="SET_MISSION_CURRENT")
        r(mav.MAV_CMD_DO_REPOSITION, self.do_reposition, required_params=(5, 6), name="DO_REPOSITION")
        r(mav.MAV_CMD_DO_CHANGE_SPEED, self.do_change_speed, required_params=(2,), name="DO_CHANGE_SPEED")
        r(mav.MAV_CMD_DO_SET_HOME, self.do_set_home, required_params=(1,), name="DO_SET_HOME")
        r(mav.MAV_CMD_DO_SET_SERVO, self.do_set_servo, required_params=(1, 2), name="DO_SET_SERVO")
        r(mav.MAV_CMD_DO_SET_RELAY, self.do_set_relay, required_params=(1, 2), name="DO_SET_RELAY")
        r(mav.MAV_CMD_REQUEST_MESSAGE, self.request_message, required_params=(1,), name="REQUEST_MESSAGE")
        r(mav.MAV_CMD_SET_MESSAGE_INTERVAL, self.set_message_interval, required_params=(1, 2),
          name="SET_MESSAGE_INTERVAL")
        r(mav.MAV_CMD_GET_HOME_POSITION, self.get_home_position, name="GET_HOME_POSITION")
        r(mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, self.request_autopilot_capabilities,
          name="REQUEST_AUTOPILOT_CAPABILITIES")
