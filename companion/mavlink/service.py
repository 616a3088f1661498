"""The companion as a MAVLink vehicle: wires links, vehicle, commands, params, missions, telemetry.

:func:`build_mavlink_services` returns the two services ``usv sitl`` and ``usv companion``
run: the :class:`~companion.link.manager.LinkManager` (sockets and radios) and
:class:`MavlinkService` (everything the vehicle says and answers).  The service streams
telemetry on each link at that link's rates, relays STATUSTEXT, runs the ground-station
failsafe (FS_GCS_ENABLE/FS_GCS_TIMEOUT/FS_ACTION and the chapter's USV_FS_ENG_STOP engine
stop) and, unless the control loop does it, calls the active mode on every navigation sample.
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Any

from companion.app import BaseService, Context, Service
from companion.clock import periodic
from companion.link import streams
from companion.link.dialect import mav
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.mavlink import identity, telemetry
from companion.mavlink.command_service import CommandService
from companion.mavlink.commands import registry_of
from companion.mavlink.ftp import FtpService
from companion.mavlink.manual_control import register_manual_control
from companion.mavlink.mission_service import MissionService
from companion.mavlink.param_service import ParamService
from companion.mavlink.vehicle_commands import MODE_AUTO, MODE_GUIDED, MODE_RTL, register_vehicle_commands
from companion.messages import NavState, StatusText
from companion.mission.store import MissionStore
from companion.vehicle import SEVERITY_CRITICAL, SEVERITY_INFO, SEVERITY_WARNING, GuidedTarget, Vehicle

log = logging.getLogger(__name__)

TICK_S = 1.0 / streams.MAX_RATE_HZ
"""Shortest stream scheduler period (vehicle clock)."""
STREAM_IDLE_S = 0.1
"""Longest the telemetry scheduler sleeps: a new link or a rate request waits at most this."""
STATUSTEXT_MAX = 50
MODE_HOLD = 4
"""Rover HOLD, FS_ACTION 2."""


class MavlinkService(BaseService):
    """Everything the vehicle says on and answers from its MAVLink links."""

    name = "mavlink"

    def __init__(self, ctx: Context, links: LinkManager) -> None:
        self.ctx = ctx
        self.links = links
        existing = ctx.extras.get("vehicle")
        if isinstance(existing, Vehicle):
            self.vehicle = existing
        else:
            store = MissionStore(ctx.config.state_dir() / "missions")
            self.vehicle = Vehicle(ctx, store)
        control_loop = ctx.extras.get("control_loop")
        self.drive_modes_from_nav = control_loop is None
        """Without a control loop (tests, tools), the active mode runs on each nav sample."""
        if control_loop is not None:
            # The active mode is the guidance+control stage of the loop: after the estimator,
            # before the servo frame is written.
            control_loop.add_stage("modes", self.vehicle.modes.update)  # type: ignore[attr-defined]
            # DO_SET_SERVO / DO_SET_RELAY reach the servo frame (free outputs only, see
            # companion.actuators.overrides): the servo map reads the vehicle's override table.
            control_loop.servo_map.overrides_us = self.vehicle.servo_overrides_us  # type: ignore[attr-defined]
        register_vehicle_commands(registry_of(ctx))
        self.commands = CommandService(ctx, links, self.vehicle)
        self.params = ParamService(ctx, links, self.vehicle)
        self.missions = MissionService(ctx, links, self.vehicle)
        self.ftp = FtpService(links)
        d = links.dispatcher
        d.on("REQUEST_DATA_STREAM", self._on_request_data_stream)
        d.on("SET_MODE", self._on_set_mode)
        d.on("SET_POSITION_TARGET_GLOBAL_INT", self._on_position_target)
        register_manual_control(ctx, links)
        self._failsafe_gcs = False
        self._failsafe_engine = False
        ctx.extras["mavlink"] = self

    async def start(self) -> None:
        ctx, vehicle = self.ctx, self.vehicle
        ctx.bus.topic("status_text", StatusText).add_listener(self._on_status_text)
        ctx.bus.topic("nav", NavState).add_listener(self._on_nav)
        vehicle.modes.start()
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
                        cache[msg_id] = telemetry.build(self.ctx, self.vehicle, msg_id)
                    except Exception:
                        log.exception("building message %d failed", msg_id)
                        cache[msg_id] = None
                msg = cache[msg_id]
                if msg is not None:
                    link.send(msg)

    def _on_status_text(self, status: StatusText) -> None:
        text = status.text.encode("ascii", "replace")
        chunks = [text[i:i + STATUSTEXT_MAX] for i in range(0, max(len(text), 1), STATUSTEXT_MAX)][:4]
        msg_id = (hash((status.t_s, status.text)) & 0xFFFF) if len(chunks) > 1 else 0
        for index, chunk in enumerate(chunks):
            self.links.broadcast(mav.MAVLink_statustext_message(max(0, min(7, status.severity)), chunk,
                                                                msg_id, index))

    def _on_nav(self, nav: NavState) -> None:
        if self.drive_modes_from_nav:
            self.vehicle.modes.update(nav)

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
        self.commands.send_ack(link, 11, result, src)
        if reason:
            self.vehicle.status(f"Mode change failed: {reason}", SEVERITY_WARNING)

    def _on_position_target(self, link: Link, msg: Any) -> None:
        """SET_POSITION_TARGET_GLOBAL_INT: a new GUIDED target (ignored outside GUIDED)."""
        if self.vehicle.modes.current.number != MODE_GUIDED:
            return
        if msg.type_mask & mav.POSITION_TARGET_TYPEMASK_X_IGNORE:
            return  # velocity-only targets are not supported on this boat
        lat_deg, lon_deg = msg.lat_int / 1e7, msg.lon_int / 1e7
        if not (-90 <= lat_deg <= 90 and -180 <= lon_deg <= 180) or (lat_deg == 0 and lon_deg == 0):
            self.vehicle.status("Position target refused: invalid position", SEVERITY_WARNING)
            return
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
        if lost and enable and vehicle.armed and not self._failsafe_gcs and mode not in (MODE_RTL, MODE_HOLD):
            self._failsafe_gcs = True
            vehicle.failsafe_reason = "gcs"
            continue_auto = enable == 2 and mode == MODE_AUTO
            vehicle.status(f"GCS failsafe: no heartbeat for {age_s:.0f} s", SEVERITY_CRITICAL)
            action = params.get_int("FS_ACTION")
            if not continue_auto and action in (1, 2):
                target = MODE_RTL if action == 1 else MODE_HOLD
                reason = vehicle.set_mode(target)
                if reason and target == MODE_RTL:
                    vehicle.set_mode(MODE_HOLD)
        elif not lost and self._failsafe_gcs:
            self._failsafe_gcs = False
            vehicle.failsafe_reason = None
            vehicle.status("GCS failsafe cleared", SEVERITY_INFO)
        stop_s = params.get("USV_FS_ENG_STOP")
        engine_lost = stop_s > 0 and links.gcs_lost(stop_s)
        if engine_lost and vehicle.armed and not self._failsafe_engine:
            self._failsafe_engine = True
            vehicle.disarm(reason=f"engine stop, no ground station for {stop_s:.0f} s")
        elif not engine_lost:
            self._failsafe_engine = False

def build_mavlink_services(ctx: Context) -> list[Service]:
    """The link service and the MAVLink vehicle service, in start-up order."""
    links = LinkManager(ctx)
    return [links, MavlinkService(ctx, links)]
