"""The vehicle's state as the JSON documents of the MQTT state topics.

:class:`StateSnapshot` reads, when a topic is due, what the MAVLink telemetry reads: the
latest values on the bus (``nav``, ``engine``, ``water_current``, ``payload_sensors``), the
vehicle (mode, arming, failsafe), the links (ground-station heartbeat age) and the payload
devices (launcher, sampler).  It keeps nothing itself, so a broker that is away for an hour
costs no memory: the next publication is simply the latest state.  ``document`` returns
``None`` when a topic has nothing to say yet (no GPS-INS sample, no current estimate).
"""

from __future__ import annotations

import math
from typing import Any

from companion.app import Context
from companion.link.manager import LinkManager
from companion.messages import ENGINE_TOPIC, NAV_TOPIC, WATER_CURRENT_TOPIC, ModeNumber
from companion.mqtt.topics import StateTopic
from companion.payloads.launcher.device import RopeLauncher
from companion.payloads.sampler.device import BottleState, WaterSampler
from companion.vehicle import Vehicle


def _deg(angle_rad: float) -> float:
    """Radians -> degrees in [0, 360)."""
    return round(math.degrees(angle_rad) % 360.0, 2)


def mode_name(number: int) -> str:
    """ArduPilot Rover's name of custom mode ``number`` (``MODE<n>`` for an unknown one)."""
    try:
        return ModeNumber(number).name
    except ValueError:
        return f"MODE{number}"


class StateSnapshot:
    """Builds the document of each :class:`StateTopic` from the live vehicle."""

    def __init__(self, ctx: Context, vehicle: Vehicle, links: LinkManager,
                 launcher: RopeLauncher | None, sampler: WaterSampler | None) -> None:
        self.ctx = ctx
        self.vehicle = vehicle
        self.links = links
        self.launcher = launcher
        self.sampler = sampler
        self._nav = ctx.bus.topic(NAV_TOPIC)
        self._engine = ctx.bus.topic(ENGINE_TOPIC)
        self._current = ctx.bus.topic(WATER_CURRENT_TOPIC)

    def _stamp(self) -> dict[str, Any]:
        clock = self.ctx.clock
        return {"t_s": round(clock.now_s(), 3), "t_unix_s": round(clock.unix_time_s(), 3)}

    def document(self, which: StateTopic) -> dict[str, Any] | None:
        builder = {
            StateTopic.POSITION: self.position, StateTopic.STATUS: self.status, StateTopic.LINK: self.link,
            StateTopic.ENGINE: self.engine, StateTopic.CURRENT: self.current,
            StateTopic.LAUNCHER: self.launcher_state, StateTopic.SAMPLER: self.sampler_state,
        }[which]
        return builder()

    def position(self) -> dict[str, Any] | None:
        nav = self._nav.latest()
        if nav is None:
            return None
        course_rad = nav.course_over_ground_rad
        return {**self._stamp(), "lat_deg": round(nav.lat_deg, 7), "lon_deg": round(nav.lon_deg, 7),
                "heading_deg": _deg(nav.heading_rad), "sog_mps": round(nav.speed_over_ground_mps, 3),
                "cog_deg": _deg(course_rad), "fix_type": int(nav.fix_type),
                "position_valid": bool(nav.position_valid)}

    def status(self) -> dict[str, Any]:
        number = int(self.vehicle.modes.current.number)
        return {**self._stamp(), "mode": mode_name(number), "mode_number": number,
                "armed": bool(self.vehicle.armed), "mission_complete": bool(self.vehicle.mission.complete)}

    def status_key(self) -> tuple[int, bool]:
        """What makes a new ``status`` publication due at once when it changes."""
        return int(self.vehicle.modes.current.number), bool(self.vehicle.armed)

    def link(self) -> dict[str, Any]:
        age_s = self.links.gcs_heartbeat_age_s()
        lost = self.links.gcs_lost(self.ctx.params.get("FS_GCS_TIMEOUT"))
        return {**self._stamp(), "gcs_heard": age_s is not None,
                "gcs_heartbeat_age_s": None if age_s is None else round(age_s, 2), "gcs_lost": lost,
                "failsafe": self.vehicle.failsafe_reason, "links": len(self.links.links)}

    def engine(self) -> dict[str, Any] | None:
        engine = self._engine.latest()
        if engine is None:
            return None
        return {**self._stamp(), "rpm": round(max(0.0, engine.rpm), 1), "running": bool(engine.running)}

    def current(self) -> dict[str, Any] | None:
        est = self._current.latest()
        if est is None:
            return None
        return {**self._stamp(), "north_mps": round(est.north_mps, 3), "east_mps": round(est.east_mps, 3),
                "speed_mps": round(est.speed_mps, 3), "toward_deg": _deg(est.toward_rad),
                "confidence": round(min(1.0, max(0.0, est.confidence)), 3)}

    def launcher_state(self) -> dict[str, Any] | None:
        launcher = self.launcher
        if launcher is None:
            return None
        pressure = launcher.pressure_mpa()
        return {**self._stamp(), "state": launcher.state().name, "armed": launcher.arm_time_left_s() > 0,
                "pressure_mpa": None if pressure is None else round(pressure, 2),
                "shots_left": max(0, int(launcher.shots_left))}

    def sampler_state(self) -> dict[str, Any] | None:
        sampler = self.sampler
        if sampler is None:
            return None
        levels = zip(sampler.bottle_state, sampler.bottle_volume_ml, strict=True)
        bottles = [{"bottle": i + 1, "state": BottleState(s).name, "volume_ml": round(max(0.0, v), 1)}
                   for i, (s, v) in enumerate(levels)]
        return {**self._stamp(), "pump_on": bool(sampler.pump_on()), "bottles": bottles}
