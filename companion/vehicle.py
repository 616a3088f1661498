"""The vehicle: arming with pre-arm checks, home, the operator's targets, modes, mission progress.

One :class:`Vehicle` per companion, built by :mod:`companion.runtime` from its collaborators
(the :class:`~companion.modes.manager.ModeManager`, the mission cursor, the control system,
the payloads' mission actions).
The MAVLink services turn operator requests into calls here (``arm``, ``set_mode``,
``set_home``, ``set_current``); the vehicle is also the :class:`~companion.modes.host.ModeHost`
its modes run against (``update_mode`` is the pipeline's modes stage).  Every refusal is a
sentence for the operator, never an exception.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, Generic, TypeVar

from companion.app import Context
from companion.control.manual_input import PilotInput, pilot_input
from companion.control.system import ControlSystem
from companion.guidance.geo import lat_lon_problem
from companion.messages import (
    NAV_TOPIC,
    STATUS_TEXT_TOPIC,
    VEHICLE_STATUS_TOPIC,
    CurrentEstimate,
    FixType,
    GuidedTarget,
    Home,
    ModeNumber,
    NavState,
    Severity,
    StatusText,
    VehicleStatus,
)
from companion.mission.cursor import MissionCursor, MissionState
from companion.mission.items import MissionItem
from companion.mission.route import LatLon, Legs, LegsCheck
from companion.mission.store import MissionStore
from companion.modes.auto_items import MissionAction
from companion.modes.base import ModeOutput
from companion.modes.manager import ModeManager
from companion.modes.station_trials import StationTrials
from companion.params import ParamStore

__all__ = ["FORCE_MAGIC", "NAV_STALE_S", "DestinationCheck", "MissionState", "ModeCheck", "PrearmCheck",
           "Vehicle", "home_placeholder_profile"]

log = logging.getLogger(__name__)

NAV_STALE_S = 1.0
"""A navigation solution older than this does not count as a position estimate."""

FORCE_MAGIC = 21196
"""param2 of MAV_CMD_COMPONENT_ARM_DISARM that forces arming/disarming (ArduPilot, PX4)."""

PrearmCheck = Callable[["Vehicle"], str | None]
DestinationCheck = Callable[[float, float], str | None]
"""``check(lat_deg, lon_deg)``: why the boat may not be sent there (e.g. the geofence), or ``None``."""
ModeCheck = Callable[["Vehicle", int], str | None]
"""``check(vehicle, mode_number)``: why the vehicle may not enter that mode now, or ``None``."""


def home_placeholder_profile(profile: str) -> bool:
    """Whether ``profile`` keeps ArduPilot's convention that mission item 0 is home (``ardurover``)."""
    return profile == "ardurover"



R = TypeVar("R")


class NamedChecks(Generic[R]):
    """Checks kept by name, in the order added; adding one under a known name replaces it.

    Each check answers an ``R`` (a reason, or ``None``/empty when all is well).  A check that
    raises is logged and answers ``failed(name, exc)`` instead: a broken check refuses, it never
    takes the vehicle down."""

    def __init__(self, kind: str, checks: Sequence[tuple[str, Callable[..., R]]] = ()) -> None:
        self.kind = kind
        self._checks: list[tuple[str, Callable[..., R]]] = list(checks)

    def add(self, name: str, check: Callable[..., R]) -> None:
        self._checks = [(n, c) for n, c in self._checks if n != name]
        self._checks.append((name, check))

    def answers(self, *args: Any, failed: Callable[[str, Exception], R]) -> Iterator[R]:
        """Every check's answer to ``check(*args)``, in order."""
        for name, check in self._checks:
            try:
                yield check(*args)
            except Exception as exc:
                log.exception("%s check %s failed", self.kind, name)
                yield failed(name, exc)


def _failed_reason(name: str, exc: Exception) -> str:
    return f"{name} check failed ({exc})"


class Vehicle:
    """Arming, home, targets, modes and mission progress of one boat."""

    def __init__(self, ctx: Context, mission: MissionCursor, modes: ModeManager, control: ControlSystem,
                 mission_actions: Mapping[int, MissionAction] | None = None) -> None:
        self.ctx = ctx
        self.profile: str = str(ctx.config["vehicle.profile"]) if "vehicle.profile" in ctx.config.values \
            else "ardurover"
        self.mission = mission
        self.modes = modes
        self.control = control
        self.mission_actions: Mapping[int, MissionAction] = dict(mission_actions or {})
        """The payloads' mission commands (AUTO runs them; upload checks them)."""
        self.armed = False
        self.home: Home | None = None
        self.guided_target: GuidedTarget | None = None
        self.speed_override_mps: float | None = None
        self.failsafe_reason: str | None = None
        self.ins_fault: str | None = None
        """Set by NavHealth while the GPS-INS cannot steer the boat (frozen, stale IMU, no data):
        :meth:`nav` is then ``None``, so navigating modes and position commands are refused."""
        self.servo_overrides_us: dict[int, int] = {}
        """DO_SET_SERVO / DO_SET_RELAY: free output channel (1-based) -> pulse width; the servo
        map writes these into every frame (see :mod:`companion.actuators.overrides`)."""
        self.relays: dict[int, bool] = {}
        """DO_SET_RELAY: relay instance -> on (its channel is in ``servo_overrides_us``)."""
        self.station_trials = StationTrials()
        """Where keeping station bow into the current failed (LOITER, GUIDED, RTL: ModeHost)."""
        self.boot_s = ctx.clock.now_s()
        self._prearm_checks: NamedChecks[str | None] = NamedChecks(
            "pre-arm", [("position", _check_position), ("attitude", _check_attitude)])
        self._destination_checks: NamedChecks[str | None] = NamedChecks("destination")
        self._leg_checks: NamedChecks[tuple[int, str] | None] = NamedChecks("leg")
        self._mode_checks: NamedChecks[str | None] = NamedChecks("mode")
        self.home_listeners: list[Callable[[Home], None]] = []
        self.status_listeners: list[Callable[[], None]] = []
        self._nav = ctx.bus.topic(NAV_TOPIC)
        self._status_text = ctx.bus.topic(STATUS_TEXT_TOPIC)
        self._vehicle_status = ctx.bus.topic(VEHICLE_STATUS_TOPIC)
        mission.changed_listeners.append(self._notify_status_listeners)
        modes.add_listener(self._on_mode_changed)
        self._nav.add_listener(self._on_nav)

    @property
    def params(self) -> ParamStore:
        return self.ctx.params

    @property
    def in_failsafe(self) -> bool:
        """A failsafe is active (heartbeat system_status CRITICAL); :attr:`failsafe_reason` says which."""
        return self.failsafe_reason is not None

    # -- navigation ---------------------------------------------------------------------
    @property
    def water_current(self) -> CurrentEstimate | None:
        """The control system's fresh water-current estimate (:attr:`ControlSystem.water_current`)."""
        return self.control.water_current

    def now_s(self) -> float:
        return self.ctx.clock.now_s()

    def nav(self) -> NavState | None:
        """The latest navigation solution, or ``None`` if there is none or it is stale."""
        nav = self._nav.latest()
        if nav is None or self.ins_fault is not None or self.ctx.clock.now_s() - nav.t_s > NAV_STALE_S:
            return None
        return nav

    def _on_nav(self, nav: NavState) -> None:
        if self.home is None and nav.position_valid and nav.fix_type >= FixType.FIX_3D:
            self.set_home(nav.lat_deg, nav.lon_deg, nav.alt_m, announce=True)

    def pilot_input(self) -> PilotInput | None:
        """The pilot's sticks: fresh MANUAL_CONTROL first, else a fresh RC receiver (USV_MAN_TIMEOUT)."""
        return pilot_input(self.ctx.bus, self.ctx.clock.now_s(), self.ctx.params.get("USV_MAN_TIMEOUT"))

    # -- status ---------------------------------------------------------------------------
    def status(self, text: str, severity: Severity = Severity.INFO) -> None:
        """Tell the operator something (becomes a MAVLink STATUSTEXT on every link)."""
        log.info("status: %s", text)
        self._status_text.publish(StatusText(self.ctx.clock.now_s(), Severity(severity), text))

    def publish_status(self) -> None:
        """Publish arming state and mode on topic ``vehicle_status``."""
        flags = ("mission_complete",) if self.mission.complete else ()
        self._vehicle_status.publish(
            VehicleStatus(t_s=self.ctx.clock.now_s(), armed=self.armed, mode=self.modes.current.number,
                          flags=flags)
        )
        self._notify_status_listeners()

    def _notify_status_listeners(self) -> None:
        for listener in tuple(self.status_listeners):
            listener()

    # -- arming ---------------------------------------------------------------------------
    def add_prearm_check(self, name: str, check: PrearmCheck) -> None:
        """Add a pre-arm check; ``check(vehicle)`` returns a refusal reason or ``None``."""
        self._prearm_checks.add(name, check)

    def prearm_failures(self) -> list[str]:
        """Every reason that currently prevents arming (empty: ready to arm)."""
        return [r for r in self._prearm_checks.answers(self, failed=_failed_reason) if r]

    def add_destination_check(self, name: str, check: DestinationCheck) -> None:
        """Add a check of every place the boat is sent to (GUIDED targets, mission items)."""
        self._destination_checks.add(name, check)

    def destination_problem(self, lat_deg: float, lon_deg: float) -> str | None:
        """Why the boat may not be sent to (``lat_deg``, ``lon_deg``), or ``None``."""
        answers = self._destination_checks.answers(lat_deg, lon_deg, failed=_failed_reason)
        return next((r for r in answers if r), None)

    def add_leg_check(self, name: str, check: LegsCheck) -> None:
        """Add a check of the straight legs the boat is sent along (mission legs, the way to a GUIDED
        target): ``check(legs)`` returns the first refused leg's index and why."""
        self._leg_checks.add(name, check)

    def legs_problem(self, legs: Legs) -> tuple[int, str] | None:
        """The first of the (start, end) legs (lat, lon) the boat may not drive straight, and why."""
        def failed(name: str, exc: Exception) -> tuple[int, str] | None:
            return (0, _failed_reason(name, exc)) if legs else None

        found = [f for f in self._leg_checks.answers(legs, failed=failed) if f is not None]
        return min(found, key=lambda f: f[0], default=None)

    def leg_problem(self, start: LatLon, end: LatLon) -> str | None:
        """Why the boat may not drive straight from ``start`` to ``end`` (lat, lon), or ``None``."""
        found = self.legs_problem([(start, end)])
        return None if found is None else found[1]

    def target_problem(self, lat_deg: float, lon_deg: float) -> str | None:
        """Why the boat may not be sent to (``lat_deg``, ``lon_deg``) now: the place itself, then the
        straight way there from the boat (ArduPilot Rover does not plan around obstacles)."""
        if (reason := self.destination_problem(lat_deg, lon_deg)) is not None:
            return reason
        nav = self.nav()
        if nav is None:
            return None
        reason = self.leg_problem((nav.lat_deg, nav.lon_deg), (lat_deg, lon_deg))
        return None if reason is None else f"the way there {reason}"

    def add_mode_check(self, name: str, check: ModeCheck) -> None:
        """Add a check run before entering a mode (beyond the mode's own requirements)."""
        self._mode_checks.add(name, check)

    def mode_problem(self, number: int) -> str | None:
        """Why the added mode checks refuse mode ``number`` now, or ``None``."""
        return next((r for r in self._mode_checks.answers(self, number, failed=_failed_reason) if r), None)

    def arm(self, *, force: bool = False) -> str | None:
        """Arm after the pre-arm checks; returns ``None`` or the reason for refusal."""
        if self.armed:
            return None
        if not force:
            failures = self.prearm_failures()
            if failures:
                return "PreArm: " + failures[0]
        self.armed = True
        nav = self.nav()
        if nav is not None and nav.position_valid:
            self.set_home(nav.lat_deg, nav.lon_deg, nav.alt_m, announce=False)
        self.status("Armed" + (" (forced)" if force else ""), Severity.INFO)
        self.publish_status()
        return None

    def disarm(self, *, force: bool = False, reason: str = "") -> str | None:
        """Disarm (always allowed on a boat: the engine stops, it floats)."""
        if not self.armed:
            return None
        self.armed = False
        self.status("Disarmed" + (f": {reason}" if reason else ""), Severity.INFO)
        self.publish_status()
        return None

    # -- modes ----------------------------------------------------------------------------
    def set_mode(self, number: int) -> str | None:
        """Switch mode; ``None`` or the reason (the added mode checks, then
        :meth:`ModeManager.set_mode`)."""
        mode = self.modes.get(int(number)) if math.isfinite(number) and float(number).is_integer() else None
        if mode is not None and mode is not self.modes.current:
            reason = self.mode_problem(mode.number)
            if reason is not None:
                return f"{mode.name}: {reason}"
        return self.modes.set_mode(number, self)

    def start_modes(self) -> None:
        """Enter the initial mode (HOLD) once everything is wired."""
        self.modes.start(self)

    def update_mode(self, nav: NavState) -> ModeOutput:
        """The pipeline's modes stage: what the active mode asks of the controller for ``nav``."""
        return self.modes.update(self, nav)

    def mode_failed(self, exc: Exception) -> None:
        """The controller could not fly the active mode's request: fall back to HOLD."""
        self.modes.fall_back(self, exc)

    def _on_mode_changed(self, old: object, new: object) -> None:
        self.status(f"Mode {self.modes.current.name}", Severity.INFO)
        self.publish_status()

    # -- home and outputs -----------------------------------------------------------------
    def set_home(self, lat_deg: float, lon_deg: float, alt_m: float = 0.0, *,
                 announce: bool = True) -> str | None:
        """Set home; refuses positions that are not on the globe."""
        if (problem := lat_lon_problem(lat_deg, lon_deg)) is not None:
            return f"home refused: {problem.text}"
        self.home = Home(lat_deg, lon_deg, alt_m if math.isfinite(alt_m) else 0.0)
        if announce:
            self.status(f"Home set to {lat_deg:.7f}, {lon_deg:.7f}", Severity.INFO)
        for listener in tuple(self.home_listeners):
            listener(self.home)
        return None

    def set_servo_override(self, channel: int, pulse_us: int) -> None:
        self.servo_overrides_us[channel] = pulse_us

    def set_relay_state(self, relay: int, on: bool) -> None:
        self.relays[relay] = on

    # -- mission progress (the MAVLink side; AUTO moves :attr:`mission`) -------------------
    @property
    def missions(self) -> MissionStore:
        """The stored mission, fence and rally plans."""
        return self.mission.store

    @property
    def first_mission_seq(self) -> int:
        return self.mission.first_seq

    def mission_items(self) -> list[MissionItem]:
        """The stored mission with wire sequence numbers (item 0 may be the home placeholder)."""
        return self.mission.items()

    @property
    def current_seq(self) -> int:
        """Sequence number of the current mission item (MISSION_CURRENT.seq)."""
        return self.mission.current_seq

    def set_current(self, seq: int) -> str | None:
        """Make ``seq`` the current item (MISSION_SET_CURRENT, MAV_CMD_DO_SET_MISSION_CURRENT)."""
        return self.mission.set_current(seq)

    def start_mission(self) -> None:
        """Mark the mission as running (MISSION_START / entering AUTO); restarts a finished one."""
        self.mission.start()

    @property
    def reached_listeners(self) -> list[Callable[[int], None]]:
        """``listener(seq)`` for every item AUTO reaches (MISSION_ITEM_REACHED)."""
        return self.mission.reached_listeners

    def report_reached(self, seq: int) -> None:
        """AUTO reached item ``seq`` (sends MISSION_ITEM_REACHED)."""
        self.mission.report_reached(seq)

    def mission_complete(self) -> None:
        """AUTO finished the last item; MISSION_CURRENT reports COMPLETE."""
        if self.mission.mark_complete():
            self.status("Mission complete", Severity.INFO)
            self.publish_status()

    @property
    def mission_state(self) -> MissionState:
        return self.mission.state(running=self.modes.current.number == ModeNumber.AUTO)

    @property
    def mission_total(self) -> int:
        """MISSION_CURRENT.total: mission items without the home item (MAVLink's definition)."""
        return self.mission.total


def _check_position(vehicle: Vehicle) -> str | None:
    nav = vehicle.nav()
    if nav is None:
        return "no navigation data"
    if not nav.position_valid or nav.fix_type < FixType.FIX_3D:
        return "no 3D GPS fix"
    return None


def _check_attitude(vehicle: Vehicle) -> str | None:
    nav = vehicle.nav()
    if nav is not None and not nav.attitude_valid:
        return "attitude not valid"
    return None
