"""The vehicle: arming state with pre-arm checks, home position, modes and mission progress.

One :class:`Vehicle` lives in ``ctx.extras["vehicle"]`` (see :func:`vehicle_of`).  The
MAVLink services turn operator requests into calls here (``arm``, ``set_mode``,
``set_home``, ``set_current``); modes read from it (``nav()``, ``home``, the mission and
the guided target) and report progress back (``report_reached``, ``mission_complete``).
Every refusal is a sentence for the operator, never an exception.
"""

from __future__ import annotations

import enum
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

from companion.app import Context
from companion.messages import FixType, NavState, StatusText, VehicleStatus
from companion.mission.items import MissionItem, MissionType
from companion.mission.store import MissionStore
from companion.modes.manager import ModeManager

log = logging.getLogger(__name__)

NAV_STALE_S = 1.0
"""A navigation solution older than this does not count as a position estimate."""

FORCE_MAGIC = 21196
"""param2 of MAV_CMD_COMPONENT_ARM_DISARM that forces arming/disarming (ArduPilot, PX4)."""

# MAV_SEVERITY
SEVERITY_EMERGENCY = 0
SEVERITY_CRITICAL = 2
SEVERITY_ERROR = 3
SEVERITY_WARNING = 4
SEVERITY_NOTICE = 5
SEVERITY_INFO = 6


class MissionState(enum.IntEnum):
    """MISSION_STATE as reported in MISSION_CURRENT (MAVSDK waits for COMPLETE)."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


@dataclass(frozen=True, slots=True)
class Home:
    """Home position (return point of RTL)."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0


@dataclass(frozen=True, slots=True)
class GuidedTarget:
    """Where GUIDED goes (DO_REPOSITION / SET_POSITION_TARGET_GLOBAL_INT)."""

    lat_deg: float
    lon_deg: float
    speed_mps: float | None = None
    radius_m: float | None = None
    t_s: float = 0.0


PrearmCheck = Callable[["Vehicle"], str | None]


class Vehicle:
    """Arming, home, modes and mission progress of one boat."""

    def __init__(self, ctx: Context, missions: MissionStore | None = None) -> None:
        self.ctx = ctx
        self.profile: str = str(ctx.config["vehicle.profile"]) if "vehicle.profile" in ctx.config.values \
            else "ardurover"
        self.missions = missions if missions is not None else MissionStore()
        self.armed = False
        self.home: Home | None = None
        self.guided_target: GuidedTarget | None = None
        self.speed_override_mps: float | None = None
        self.failsafe_reason: str | None = None
        self.servo_overrides_us: dict[int, int] = {}
        """DO_SET_SERVO / DO_SET_RELAY: free output channel (1-based) -> pulse width; the servo
        map writes these into every frame (see :mod:`companion.actuators.overrides`)."""
        self.relays: dict[int, bool] = {}
        """DO_SET_RELAY: relay instance -> on (its channel is in ``servo_overrides_us``)."""
        self.boot_s = ctx.clock.now_s()
        self._prearm_checks: list[tuple[str, PrearmCheck]] = [
            ("position", _check_position), ("attitude", _check_attitude),
        ]
        self._current_seq = self.first_mission_seq
        self._mission_started = False
        self._mission_complete = False
        self.reached_listeners: list[Callable[[int], None]] = []
        self.home_listeners: list[Callable[[Home], None]] = []
        self.status_listeners: list[Callable[[], None]] = []
        self.missions.add_listener(self._on_plan_changed)
        self.modes = ModeManager(self)
        self.modes.add_listener(self._on_mode_changed)
        ctx.bus.topic("nav", NavState).add_listener(self._on_nav)
        ctx.extras["vehicle"] = self

    @property
    def in_failsafe(self) -> bool:
        """A failsafe is active (heartbeat system_status CRITICAL); :attr:`failsafe_reason` says which."""
        return self.failsafe_reason is not None

    # -- navigation ---------------------------------------------------------------------
    def nav(self) -> NavState | None:
        """The latest navigation solution, or ``None`` if there is none or it is stale."""
        nav = self.ctx.bus.topic("nav", NavState).latest()
        if nav is None or self.ctx.clock.now_s() - nav.t_s > NAV_STALE_S:
            return None
        return nav

    def _on_nav(self, nav: NavState) -> None:
        if self.home is None and nav.position_valid and nav.fix_type >= FixType.FIX_3D:
            self.set_home(nav.lat_deg, nav.lon_deg, nav.alt_m, announce=True)

    # -- status ---------------------------------------------------------------------------
    def status(self, text: str, severity: int = SEVERITY_INFO) -> None:
        """Tell the operator something (becomes a MAVLink STATUSTEXT on every link)."""
        log.info("status: %s", text)
        self.ctx.bus.topic("status_text", StatusText).publish(
            StatusText(t_s=self.ctx.clock.now_s(), severity=int(severity), text=text)
        )

    def publish_status(self) -> None:
        """Publish arming state and mode on topic ``vehicle_status``."""
        flags = ("mission_complete",) if self._mission_complete else ()
        self.ctx.bus.topic("vehicle_status", VehicleStatus).publish(
            VehicleStatus(t_s=self.ctx.clock.now_s(), armed=self.armed, mode=self.modes.current.number,
                          flags=flags)
        )
        for listener in tuple(self.status_listeners):
            listener()

    # -- arming ---------------------------------------------------------------------------
    def add_prearm_check(self, name: str, check: PrearmCheck) -> None:
        """Add a pre-arm check; ``check(vehicle)`` returns a refusal reason or ``None``."""
        self._prearm_checks = [(n, c) for n, c in self._prearm_checks if n != name]
        self._prearm_checks.append((name, check))

    def prearm_failures(self) -> list[str]:
        """Every reason that currently prevents arming (empty: ready to arm)."""
        reasons: list[str] = []
        for name, check in self._prearm_checks:
            try:
                reason = check(self)
            except Exception as exc:
                log.exception("pre-arm check %s failed", name)
                reason = f"{name} check failed ({exc})"
            if reason:
                reasons.append(reason)
        return reasons

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
        self.status("Armed" + (" (forced)" if force else ""), SEVERITY_INFO)
        self.publish_status()
        return None

    def disarm(self, *, force: bool = False, reason: str = "") -> str | None:
        """Disarm (always allowed on a boat: the engine stops, it floats)."""
        if not self.armed:
            return None
        self.armed = False
        self.status("Disarmed" + (f": {reason}" if reason else ""), SEVERITY_INFO)
        self.publish_status()
        return None

    # -- modes ----------------------------------------------------------------------------
    def set_mode(self, number: int) -> str | None:
        """Switch mode; ``None`` or the reason (see :meth:`ModeManager.set_mode`)."""
        return self.modes.set_mode(number)

    def _on_mode_changed(self, old: object, new: object) -> None:
        self.status(f"Mode {self.modes.current.name}", SEVERITY_INFO)
        self.publish_status()

    # -- home -----------------------------------------------------------------------------
    def set_home(self, lat_deg: float, lon_deg: float, alt_m: float = 0.0, *,
                 announce: bool = True) -> str | None:
        """Set home; refuses positions that are not on the globe."""
        if not (math.isfinite(lat_deg) and -90 <= lat_deg <= 90 and math.isfinite(lon_deg)
                and -180 <= lon_deg <= 180):
            return f"home {lat_deg}, {lon_deg} is not a valid position"
        self.home = Home(lat_deg, lon_deg, alt_m if math.isfinite(alt_m) else 0.0)
        if announce:
            self.status(f"Home set to {lat_deg:.7f}, {lon_deg:.7f}", SEVERITY_INFO)
        for listener in tuple(self.home_listeners):
            listener(self.home)
        return None

    # -- mission progress (used by AUTO) --------------------------------------------------
    @property
    def first_mission_seq(self) -> int:
        """1 when item 0 is ArduPilot's home placeholder (``ardurover`` and an upload in that
        convention, :mod:`companion.mission.convention`), else 0."""
        home_item = self.missions.has_home_item(MissionType.MISSION)
        return 1 if self.profile == "ardurover" and home_item else 0

    def mission_items(self) -> list[MissionItem]:
        """The stored mission (MAV_MISSION_TYPE_MISSION) with wire sequence numbers.

        Item 0 is never executed when it is the home placeholder (:attr:`first_mission_seq`).
        """
        return self.missions.items(MissionType.MISSION)

    @property
    def current_seq(self) -> int:
        """Sequence number of the current mission item (MISSION_CURRENT.seq)."""
        return self._current_seq

    def set_current(self, seq: int) -> str | None:
        """Make ``seq`` the current item (MISSION_SET_CURRENT, MAV_CMD_DO_SET_MISSION_CURRENT)."""
        count = self.missions.count(MissionType.MISSION)
        seq = max(int(seq), self.first_mission_seq)
        if seq >= count:
            return f"mission item {seq} does not exist ({count} items)"
        self._current_seq = seq
        self._mission_complete = False
        for listener in tuple(self.status_listeners):
            listener()
        return None

    def start_mission(self) -> None:
        """Mark the mission as running (MISSION_START / entering AUTO); restarts a finished one."""
        if self._mission_complete:
            self._current_seq = self.first_mission_seq
        self._mission_complete = False
        self._mission_started = True

    def report_reached(self, seq: int) -> None:
        """AUTO reached item ``seq`` (sends MISSION_ITEM_REACHED)."""
        for listener in tuple(self.reached_listeners):
            listener(int(seq))

    def mission_complete(self) -> None:
        """AUTO finished the last item; MISSION_CURRENT reports COMPLETE."""
        if not self._mission_complete:
            self._mission_complete = True
            self.status("Mission complete", SEVERITY_INFO)
            self.publish_status()

    @property
    def mission_state(self) -> MissionState:
        count = self.missions.count(MissionType.MISSION)
        if count <= self.first_mission_seq:
            return MissionState.NO_MISSION
        if self._mission_complete:
            return MissionState.COMPLETE
        if self.modes.current.number == 10:  # AUTO
            return MissionState.ACTIVE
        return MissionState.PAUSED if self._mission_started else MissionState.NOT_STARTED

    @property
    def mission_total(self) -> int:
        """MISSION_CURRENT.total: mission items without the home item (MAVLink's definition)."""
        return max(0, self.missions.count(MissionType.MISSION) - self.first_mission_seq)

    def _on_plan_changed(self, mtype: MissionType) -> None:
        if mtype == MissionType.MISSION:
            self._current_seq = self.first_mission_seq
            self._mission_started = False
            self._mission_complete = False


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


def vehicle_of(ctx: Context) -> Vehicle:
    """The vehicle of this context (created by the MAVLink service at start-up)."""
    vehicle = ctx.extras.get("vehicle")
    if not isinstance(vehicle, Vehicle):
        raise LookupError("no Vehicle in ctx.extras['vehicle']; is the MAVLink service built?")
    return vehicle
