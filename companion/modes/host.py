"""What a mode may read and request: the :class:`ModeHost` protocol.

Modes never see the vehicle's internals or the MAVLink side; they get a host that offers the
navigation solution, the operator's targets (home, guided point, speed override), the mission
cursor and the payloads' mission actions (AUTO), pilot input (MANUAL, CRUISE), the control
system that turns targets into an actuator command, and a few requests (change mode, set home,
announce).
:class:`companion.vehicle.Vehicle` implements it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol

from companion.control.manual_input import PilotInput
from companion.control.system import ControlSystem
from companion.messages import CurrentEstimate, GuidedTarget, Home, NavState, Severity
from companion.mission.cursor import MissionCursor
from companion.params import ParamStore

if TYPE_CHECKING:
    from companion.modes.auto_items import MissionAction
    from companion.modes.station_trials import StationTrials


class ModeHost(Protocol):
    """The vehicle as a mode sees it."""

    @property
    def params(self) -> ParamStore:
        """The parameter table (read only by convention)."""
        ...

    @property
    def control(self) -> ControlSystem:
        """Controller families + actuator mapping: a target in, an actuator command out."""
        ...

    @property
    def mission(self) -> MissionCursor:
        """The stored mission and the current item (AUTO)."""
        ...

    @property
    def mission_actions(self) -> Mapping[int, MissionAction]:
        """The payloads' mission commands for AUTO (sample here, launch at ...)."""
        ...

    @property
    def armed(self) -> bool: ...

    @property
    def home(self) -> Home | None: ...

    @property
    def guided_target(self) -> GuidedTarget | None:
        """Where GUIDED goes (set by DO_REPOSITION / SET_POSITION_TARGET_GLOBAL_INT)."""
        ...

    @property
    def speed_override_mps(self) -> float | None:
        """DO_CHANGE_SPEED from the ground station (``None``: none)."""
        ...

    @property
    def water_current(self) -> CurrentEstimate | None:
        """The estimator's water current (earth frame: ``north_mps``/``east_mps``, ``speed_mps``,
        ``toward_rad`` clockwise from north, ``confidence`` 0..1), ``None`` when there is none or
        it is stale (the chapter filter estimates no current).  Guidance uses it to pick how to
        hold a point (bow into the current, or orbit) and to brake on arrival."""
        ...

    @property
    def station_trials(self) -> StationTrials:
        """Where keeping station bow into the current failed (the creep was seen): LOITER, GUIDED
        and RTL orbit at once in that current for a while."""
        ...

    def nav(self) -> NavState | None:
        """The latest navigation solution, ``None`` if there is none or it is stale."""
        ...

    def now_s(self) -> float:
        """Clock time (s)."""
        ...

    def pilot_input(self) -> PilotInput | None:
        """Fresh pilot sticks (ground-station MANUAL_CONTROL first, else RC), or ``None``."""
        ...

    def status(self, text: str, severity: Severity = Severity.INFO) -> None:
        """Tell the operator (a STATUSTEXT)."""
        ...

    def set_mode(self, number: int) -> str | None:
        """Request another mode; ``None`` or the reason it was refused."""
        ...

    def set_home(self, lat_deg: float, lon_deg: float, alt_m: float = 0.0, *,
                 announce: bool = True) -> str | None:
        """Move home (DO_SET_HOME in a mission); ``None`` or the reason it was refused."""
        ...

    def mission_complete(self) -> None:
        """AUTO finished the last item."""
        ...

    def set_servo_override(self, channel: int, pulse_us: int) -> None:
        """Drive free output ``channel`` (1-based) at ``pulse_us`` (DO_SET_SERVO in a mission)."""
        ...

    def set_relay_state(self, relay: int, on: bool) -> None:
        """Record relay ``relay`` as on/off (DO_SET_RELAY in a mission)."""
        ...
