"""The geofence stage: checks the boat against the FENCE plan and acts on a predicted breach.

:class:`FenceGuard` is the pipeline's ``fence`` stage (:mod:`companion.pipeline`, between the
estimator and the modes, so a fence action changes the mode before the mode computes this
sample's command).  It checks at :data:`CHECK_PERIOD_S` (10 Hz, ArduPilot's rate) on the
navigation solution, with the breach logic of :mod:`.monitor`, and publishes a
:class:`~companion.messages.FenceState` (SYS_STATUS geofence bits, FENCE_STATUS).

With FENCE_ENABLE = 1 it also

* acts at the start of a breach episode while armed (FENCE_ACTION: report only, RTL or HOLD,
  HOLD, engine stop), with a CRITICAL STATUSTEXT naming the zone and the distances;
* refuses destinations (GUIDED targets, mission items) closer than FENCE_MARGIN to a boundary
  (:meth:`destination_problem`, a vehicle destination check), and straight legs to them that leave
  an inclusion zone, cross an exclusion zone or pass within FENCE_MARGIN (:meth:`leg_problem`);
* refuses arming outside the fence (pre-arm check "outside the fence").
"""

from __future__ import annotations

import math

from companion.bus import Bus
from companion.clock import Clock
from companion.fence import legs
from companion.fence.monitor import FenceCheck, FenceMonitor, check_fence
from companion.fence.params import FenceAction
from companion.fence.zones import Zone, ZoneKind, fence_from_plan
from companion.messages import FENCE_TOPIC, FenceState, ModeNumber, NavState, Severity
from companion.mission.items import MissionType
from companion.mission.route import LatLon, Legs
from companion.mission.store import MissionStore
from companion.params import ParamStore
from companion.vehicle import Vehicle

CHECK_PERIOD_S = 0.1
"""Fence checks per sample are thinned to 10 Hz."""


def _zone_text(zone: Zone | None) -> str:
    return "fence" if zone is None else zone.describe()


def _beyond(zone: Zone | None) -> str:
    """Where a point the zone forbids is: "outside the inclusion polygon", "inside the exclusion circle"."""
    side = "inside" if zone is not None and zone.kind is ZoneKind.EXCLUSION else "outside"
    return f"{side} the {_zone_text(zone)}"


class FenceGuard:
    """Enforces the stored FENCE plan on one vehicle (module doc)."""

    def __init__(self, params: ParamStore, clock: Clock, bus: Bus, vehicle: Vehicle,
                 store: MissionStore) -> None:
        self.params = params
        self.clock = clock
        self.vehicle = vehicle
        self.store = store
        self.monitor = FenceMonitor()
        self._topic = bus.topic(FENCE_TOPIC)
        self._next_check_s = -math.inf
        self._reload(MissionType.FENCE)
        store.add_listener(self._reload)
        vehicle.add_prearm_check("fence", self._prearm)
        vehicle.add_destination_check("fence", self.destination_problem)
        vehicle.add_leg_check("fence", self.legs_problem)
        vehicle.add_mode_check("fence", self._mode_check)
        vehicle.home_listeners.append(self._on_home)

    @property
    def enabled(self) -> bool:
        return self.params.get_int("FENCE_ENABLE") == 1

    def _reload(self, mission_type: MissionType) -> None:
        if mission_type == MissionType.FENCE:
            self.monitor.set_fence(fence_from_plan(self.store.items(MissionType.FENCE)))
            self._next_check_s = -math.inf
            self._publish(self.clock.now_s())
            self._on_home(self.vehicle.home)

    # -- checks of places ---------------------------------------------------------------
    def destination_problem(self, lat_deg: float, lon_deg: float) -> str | None:
        """Why the boat may not be sent to (``lat_deg``, ``lon_deg``): closer than FENCE_MARGIN to a
        boundary or beyond it; ``None`` when the fence is off or empty."""
        fence = self.monitor.fence
        if not self.enabled or fence.empty:
            return None
        clearance_m, zone = fence.clearance_at_m(lat_deg, lon_deg)
        margin_m = self.params.get("FENCE_MARGIN")
        if clearance_m >= margin_m:
            return None
        where = _beyond(zone) if clearance_m < 0 else f"within FENCE_MARGIN of the {_zone_text(zone)}"
        return f"{where} ({clearance_m:.0f} m)"

    def legs_problem(self, legs_lat_lon: Legs, *, keep_margin: bool = True) -> tuple[int, str] | None:
        """The first (start, end) leg (lat, lon) that would leave an inclusion zone, cross an exclusion
        zone or pass within FENCE_MARGIN of a boundary, and why (:func:`.legs.legs_problem`, all legs
        at once); ``None`` when the fence is off or empty."""
        fence = self.monitor.fence
        if not self.enabled or fence.empty:
            return None
        legs_ne = [(fence.to_ne(*start), fence.to_ne(*end)) for start, end in legs_lat_lon]
        return legs.legs_problem(fence, legs_ne, self.params.get("FENCE_MARGIN"), keep_margin=keep_margin)

    def leg_problem(self, start: LatLon, end: LatLon, *, keep_margin: bool = True) -> str | None:
        """Why the boat may not drive straight from ``start`` to ``end`` (:meth:`legs_problem`)."""
        found = self.legs_problem([(start, end)], keep_margin=keep_margin)
        return None if found is None else found[1]

    def home_problem(self, vehicle: Vehicle) -> str | None:
        """Why RTL would take the boat out of the fence: home outside it, or the straight way home from
        the boat leaving an inclusion zone or crossing an exclusion zone (FENCE_MARGIN is not asked
        of the way home: it is the fence's own escape); ``None`` when the fence is off or empty or
        there is no home."""
        fence, home = self.monitor.fence, vehicle.home
        if not self.enabled or fence.empty or home is None:
            return None
        clearance_m, zone = fence.clearance_at_m(home.lat_deg, home.lon_deg)
        if clearance_m < 0:
            return f"home {_beyond(zone)} ({clearance_m:.0f} m)"
        nav = vehicle.nav()
        if nav is None:
            return None
        reason = self.leg_problem((nav.lat_deg, nav.lon_deg), (home.lat_deg, home.lon_deg), keep_margin=False)
        return None if reason is None else f"the way home {reason}"

    def _on_home(self, home: object) -> None:
        """A home outside the enforced fence is accepted (ArduPilot does) and told: RTL is refused and
        the fence action RTL becomes HOLD while it stays there."""
        fence, home_pos = self.monitor.fence, self.vehicle.home
        if not self.enabled or fence.empty or home_pos is None:
            return
        clearance_m, zone = fence.clearance_at_m(home_pos.lat_deg, home_pos.lon_deg)
        if clearance_m < 0:
            self.vehicle.status(f"Fence: home {_beyond(zone)}: no RTL", Severity.WARNING)

    def _mode_check(self, vehicle: Vehicle, number: int) -> str | None:
        """RTL is refused while it would take the boat out of the fence (:meth:`home_problem`)."""
        return self.home_problem(vehicle) if number == ModeNumber.RTL else None

    def _prearm(self, vehicle: Vehicle) -> str | None:
        nav = vehicle.nav()
        if nav is None or not self.enabled or self.monitor.fence.empty:
            return None
        clearance_m, zone = self.monitor.fence.clearance_at_m(nav.lat_deg, nav.lon_deg)
        return f"vehicle {_beyond(zone)}" if clearance_m < 0 else None

    # -- the pipeline stage -------------------------------------------------------------
    def step(self, nav: NavState) -> None:
        """Check the sample's position (10 Hz) and act on a new breach episode."""
        if nav.t_s < self._next_check_s:
            return
        self._next_check_s = nav.t_s + CHECK_PERIOD_S
        fence = self.monitor.fence
        if fence.empty or not (math.isfinite(nav.lat_deg) and math.isfinite(nav.lon_deg)):
            self._publish(nav.t_s)
            return
        params = self.params
        check = check_fence(fence, nav.lat_deg, nav.lon_deg, nav.vel_north_mps, nav.vel_east_mps,
                            params.get("USV_FENCE_REACT"), math.radians(params.get("USV_FENCE_YAWR")))
        was_breached = self.monitor.breached
        new_breach = self.monitor.update(check, params.get("FENCE_MARGIN"), nav.t_s)
        if new_breach and self.enabled:
            self._act(check)
        elif was_breached and not self.monitor.breached and self.enabled:
            self.vehicle.status(f"Fence breach cleared ({check.worst_m:.0f} m)")
        self._publish(nav.t_s)

    def _act(self, check: FenceCheck) -> None:
        """FENCE_ACTION, told in one STATUSTEXT chunk: "Fence breach predicted (1.8 m): RTL".  RTL falls
        back to HOLD when RTL cannot start or would leave the fence (no home, home outside the
        fence, the way home crossing it; :meth:`home_problem`), also when already in RTL, and a
        second STATUSTEXT says why ("Fence: no RTL: home outside the inclusion polygon (-40 m)")."""
        vehicle = self.vehicle
        action = self.params.get_int("FENCE_ACTION")
        head = f"Fence {'breached' if check.outside else 'breach predicted'} ({check.worst_m:.1f} m)"
        if not vehicle.armed or action == FenceAction.REPORT_ONLY:
            vehicle.status(head, Severity.CRITICAL)
            return
        if action == FenceAction.ENGINE_STOP:
            vehicle.status(f"{head}: engine stop", Severity.CRITICAL)
            vehicle.disarm(reason="fence")
            return
        no_rtl = None
        if action == FenceAction.RTL:
            if vehicle.modes.current.number != ModeNumber.RTL:
                no_rtl = vehicle.set_mode(ModeNumber.RTL)
            elif (problem := self.home_problem(vehicle)) is not None:
                no_rtl = f"RTL: {problem}"
        if action == FenceAction.HOLD or no_rtl is not None:
            in_hold = vehicle.modes.current.number == ModeNumber.HOLD
            refused = None if in_hold else vehicle.set_mode(ModeNumber.HOLD)
            vehicle.status(f"{head}: HOLD" + ("" if refused is None else " refused"), Severity.CRITICAL)
        else:
            vehicle.status(f"{head}: RTL", Severity.CRITICAL)
        if no_rtl is not None:
            vehicle.status(f"Fence: no {no_rtl}", Severity.WARNING)

    def _publish(self, now_s: float) -> None:
        m = self.monitor
        last = m.last
        self._topic.publish(FenceState(
            t_s=now_s, present=not m.fence.empty, enabled=self.enabled, breached=m.breached,
            breach_count=m.breach_count, breach_time_s=m.breach_time_s,
            clearance_m=math.inf if last is None else last.clearance_m))
