"""The companion as a MAVLink vehicle: commands, params, missions and telemetry on every link.

:class:`MavlinkService` is everything the vehicle says and answers on the links of the
:class:`~companion.link.manager.LinkManager` (sockets and radios; both built by
:mod:`companion.runtime`).  It streams telemetry on each link at that link's rates, relays
STATUSTEXT and runs the ground-station failsafe (FS_GCS_ENABLE/FS_GCS_TIMEOUT/FS_ACTION and the
chapter's USV_FS_ENG_STOP engine stop).
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Any

from companion.actuators.servo import ServoMap
from companion.app import BaseService, Context
from companion.clock import periodic
from companion.guidance.geo import lat_lon_problem
from companion.link import streams
from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.mavlink import identity
from companion.mavlink.command_service import CommandService
from companion.mavlink.commands import CommandRegistry
from companion.mavlink.ftp import FtpService
from companion.mavlink.manual_control import register_manual_control
from companion.mavlink.mission_service import MissionService
from companion.mavlink.param_service import ParamService
from companion.mavlink.ping import register_ping
from companion.mavlink.telemetry import Telemetry
from companion.mavlink.vehicle_commands import VehicleCommands
from companion.messages import STATUS_TEXT_TOPIC, GuidedTarget, ModeNumber, Severity, StatusText
from companion.mission.validate import MissionValidator
from companion.vehicle import Vehicle

log = logging.getLogger(__name__)

TICK_S = 1.0 / streams.MAX_RATE_HZ
"""Shortest stream scheduler period (vehicle clock)."""
STREAM_IDLE_S = 0.1
"""Longest the telemetry scheduler sleeps: a new link or a rate request waits at most this."""
STATUSTEXT_MAX = 50

FS_GCS_CONTINUE_AUTO = 2
"""FS_GCS_ENABLE value: the GCS failsafe lets a running mission continue."""
FS_ACTION_RTL, FS_ACTION_HOLD = 1, 2
"""FS_ACTION values (see :mod:`companion.mavlink.params`)."""


class MavlinkService(BaseService):
    """Everything the vehicle says on and answers from its MAVLink links."""

    name = "mavlink"

    def __init__(self, ctx: Context, links: LinkManager, vehicle: Vehicle, commands: CommandRegistry,
                 telemetry: Telemetry, validator: MissionValidator, servo_map: ServoMap) -> None:
        self.ctx = ctx
        self.links = links
        self.vehicle = vehicle
        self.telemetry = telemetry
        handlers = VehicleCommands(vehicle, ctx.params, ctx.clock, telemetry, links.system_id, servo_map)
        handlers.register(commands)
        self.commands = CommandService(ctx, links, self.vehicle, commands)
        self.params = ParamService(ctx, links, self.vehicle)
        self.missions = MissionService(ctx, links, self.vehicle, validator=validator)
        self.ftp = FtpService(links)
        d = links.dispatcher
        d.on("REQUEST_DATA_STREAM", self._on_request_data_stream)
        d.on("SET_MODE", self._on_set_mode)
        d.on("SET_POSITION_TARGET_GLOBAL_INT", self._on_position_target)
        register_manual_control(ctx, links)
        register_ping(links)
        self._failsafe_gcs = False
        self._failsafe_engine = False

    async def start(self) -> None:
        ctx, vehicle = self.ctx, self.vehicle
        ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(self._on_status_text)
        vehicle.start_modes()
        vehicle.status(identity.boot_banner())
        profile = "ArduRover-compatible modes" if vehicle.profile == "ardurover" else "generic autopilot"
        vehicle.status(f"MAVLink profile {vehicle.profile}: {profile}")
        vehicle.publish_status()

    async def run(self) -> None:
        async with asyncio.TaskGroup() as tg:
            tg.create_task(self._stream_loop(), name="mavlink-streams")
            tg.create_task(self.missions.run(), name="mavlink-missions")
            tg.create_task(self._failsafe_loop(), name="mavlink-failsafe")

    async def stop(self) -> None:
        await self.commands.stop()
        await self.params.stop()
        await self.missions.stop()

    # -- telemetry ------------------------------------------------------------------------
    async def _stream_loop(self) -> None:
        """Wake when the next stream message of any link is due (at most every TICK_S, at least
        every STREAM_IDLE_S so new links and rate changes are served promptly), not on a fixed
        50 Hz tick: at the default rates that is a few wake-ups per second instead of 50, which
        is most of the telemetry's cost in lockstep SITL."""
        clock = self.ctx.clock
        while True:
            now_s = clock.now_s()
            self.stream_once(now_s)
            await clock.sleep(self._stream_sleep_s(now_s))

    def _stream_sleep_s(self, now_s: float) -> float:
        dues = (link.rates.next_due_s(now_s) for link in tuple(self.links.links))
        wake_s = min((t for t in dues if t is not None), default=now_s + STREAM_IDLE_S)
        return min(STREAM_IDLE_S, max(TICK_S, wake_s - now_s))

    def stream_once(self, now_s: float) -> None:
        """Send every message that is due on every link (each built once per tick)."""
        cache: dict[int, Any] = {}
        for link in tuple(self.links.links):
            for msg_id in link.rates.due(now_s):
                if msg_id not in cache:
                    try:
                        cache[msg_id] = self.telemetry.build(msg_id)
                    except Exception:
                        log.exception("building message %d failed", msg_id)
                        cache[msg_id] = None
                msg = cache[msg_id]
                for one in msg if isinstance(msg, tuple) else () if msg is None else (msg,):
                    link.send(one)

    def _on_status_text(self, status: StatusText) -> None:
        text = status.text.encode("ascii", "replace")
        chunks = [text[i:i + STATUSTEXT_MAX] for i in range(0, max(len(text), 1), STATUSTEXT_MAX)][:4]
        msg_id = (hash((status.t_s, status.text)) & 0xFFFF) if len(chunks) > 1 else 0
        for index, chunk in enumerate(chunks):
            self.links.broadcast(mav.MAVLink_statustext_message(max(0, min(7, status.severity)), chunk,
                                                                msg_id, index))

    # -- messages besides commands ----------------------------------------------------------
    def _on_request_data_stream(self, link: Link, msg: Any) -> None:
        rate = float(msg.req_message_rate)
        link.rates.request_data_stream(int(msg.req_stream_id), rate, bool(msg.start_stop) and rate > 0)

    def _on_set_mode(self, link: Link, msg: Any) -> None:
        """The legacy SET_MODE message (answered with COMMAND_ACK for command 11, as ArduPilot)."""
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        reason: str | None
        if not int(msg.base_mode) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            result, reason = mav.MAV_RESULT_DENIED, "SET_MODE: only custom modes are supported"
        else:
            reason = self.vehicle.set_mode(int(msg.custom_mode))
            result = mav.MAV_RESULT_ACCEPTED if reason is None else mav.MAV_RESULT_DENIED
        self.commands.send_ack(link, mav.MAVLINK_MSG_ID_SET_MODE, result, src)
        if reason:
            self.vehicle.status(f"Mode change failed: {reason}", Severity.WARNING)

    def _on_position_target(self, link: Link, msg: Any) -> None:
        """SET_POSITION_TARGET_GLOBAL_INT: a new GUIDED target (ignored outside GUIDED)."""
        if self.vehicle.modes.current.number != ModeNumber.GUIDED:
            return
        if msg.type_mask & mav.POSITION_TARGET_TYPEMASK_X_IGNORE:
            return  # velocity-only targets are not supported on this boat
        lat_deg, lon_deg = msg.lat_int / 1e7, msg.lon_int / 1e7
        if lat_lon_problem(lat_deg, lon_deg, zero_is_missing=True) is not None:
            self.vehicle.status("Position target refused: invalid position", Severity.WARNING)
            return
        if (outside := self.vehicle.target_problem(lat_deg, lon_deg)) is not None:
            self.vehicle.status(f"Position target refused: {outside}", Severity.WARNING)
            return  # no answer in this protocol: the STATUSTEXT is the refusal
        speed = None
        if not msg.type_mask & mav.POSITION_TARGET_TYPEMASK_VX_IGNORE:
            speed_mps = math.hypot(msg.vx, msg.vy)
            speed = speed_mps if math.isfinite(speed_mps) and speed_mps > 0 else None
        self.vehicle.guided_target = GuidedTarget(lat_deg, lon_deg, speed, None, self.ctx.clock.now_s())

    # -- ground-station failsafe -------------------------------------------------------------
    async def _failsafe_loop(self) -> None:
        async for _ in periodic(self.ctx.clock, 0.2):
            self.check_failsafe()

    def check_failsafe(self) -> None:
        """FS_GCS_* and USV_FS_ENG_STOP against the silence of the ground stations.

        A ground station is lost by :mod:`companion.link.gcs_presence`'s rule: silent for the
        timeout on the vehicle clock (simulated seconds in SITL) and, when it paces its 1 Hz
        heartbeats by the wall clock while the vehicle clock runs faster (``--speedup``), for
        three of its heartbeat periods of wall time too.  Armed and lost for FS_GCS_TIMEOUT:
        STATUSTEXT and FS_ACTION's mode (RTL falls back to HOLD) -- unless the boat is already
        in RTL or HOLD, which ArduPilot Rover also leaves alone, so RTL stays RTL until home.
        Lost for USV_FS_ENG_STOP: disarm, which turns the ignition off (the boat coasts),
        whatever the mode.  A returning ground station only clears the failsafe flag
        (STATUSTEXT "GCS failsafe cleared"): the mode stays as the failsafe left it and a
        stopped engine stays stopped until the operator re-arms and picks a mode.
        """
        params, vehicle, links = self.ctx.params, self.vehicle, self.links
        age_s = links.gcs_heartbeat_age_s()
        if age_s is None:
            return  # no ground station heard yet: nothing to lose
        enable = params.get_int("FS_GCS_ENABLE")
        lost = links.gcs_lost(params.get("FS_GCS_TIMEOUT"))
        mode = vehicle.modes.current.number
        in_safe_mode = mode in (ModeNumber.RTL, ModeNumber.HOLD)  # already what a failsafe would do
        if lost and enable and vehicle.armed and not self._failsafe_gcs and not in_safe_mode:
            self._failsafe_gcs = True
            vehicle.failsafe_reason = "gcs"
            continue_auto = enable == FS_GCS_CONTINUE_AUTO and mode == ModeNumber.AUTO
            vehicle.status(f"GCS failsafe: no heartbeat for {age_s:.0f} s", Severity.CRITICAL)
            action = params.get_int("FS_ACTION")
            if not continue_auto and action in (FS_ACTION_RTL, FS_ACTION_HOLD):
                target = ModeNumber.RTL if action == FS_ACTION_RTL else ModeNumber.HOLD
                reason = vehicle.set_mode(target)
                if reason and target == ModeNumber.RTL:
                    vehicle.set_mode(ModeNumber.HOLD)
        elif not lost and self._failsafe_gcs:
            self._failsafe_gcs = False
            vehicle.failsafe_reason = None
            vehicle.status("GCS failsafe cleared", Severity.INFO)
        stop_s = params.get("USV_FS_ENG_STOP")
        engine_lost = stop_s > 0 and links.gcs_lost(stop_s)
        if engine_lost and vehicle.armed and not self._failsafe_engine:
            self._failsafe_engine = True
            vehicle.disarm(reason=f"engine stop, no ground station for {stop_s:.0f} s")
        elif not engine_lost:
            self._failsafe_engine = False
