"""The stored mission and rally points against the fence in force, after the fact.

A mission is checked against the fence when it is uploaded (:mod:`companion.mavlink.mission_service`
with :func:`companion.mission.route.route_problem`), but the fence can change afterwards: a new
FENCE plan, FENCE_ENABLE set to 1, a larger FENCE_MARGIN, a new home.  The choice made here: the
**new fence is always accepted** (refusing a safety boundary because of an older mission would
leave the boat with the old one, or none), and the stored mission is **flagged**:

* when a FENCE plan is stored or FENCE_ENABLE becomes 1, the stored mission and rally points are
  re-checked and a conflict is told at once (WARNING STATUSTEXT
  ``Fence: mission conflicts: leg 2-3: leaves the inclusion polygon; AUTO refused``,
  ``Fence: rally point 1: outside the inclusion polygon (-30 m)``);
* entering AUTO is refused while the mission conflicts with the fence (checked again at that
  moment, so a fixed mission, a fixed fence or FENCE_ENABLE = 0 lifts it), and also when the
  straight way from the boat to the mission's next positional item does
  (``Mode change failed: AUTO: fence conflict: leg 2-3: ...``);
* a boat already in AUTO carries on: the breach prediction (:mod:`.guard`) stops it before the edge.

Rally points are not used for RTL on this boat (RTL goes home, as Rover without rally): a rally
point outside is only reported.
"""

from __future__ import annotations

from collections.abc import Callable

from companion.messages import ModeNumber, Severity
from companion.mission.items import MissionItem, MissionType
from companion.mission.route import route_problem
from companion.mission.store import MissionStore
from companion.params import ParamStore
from companion.vehicle import Vehicle


class FencePlanCheck:
    """Re-checks the stored mission and rally points when the fence changes; refuses AUTO on conflict."""

    def __init__(self, params: ParamStore, vehicle: Vehicle, store: MissionStore,
                 needs_position: Callable[[MissionItem], bool]) -> None:
        self.params = params
        self.vehicle = vehicle
        self.store = store
        self.needs_position = needs_position
        store.add_listener(self._on_plan_changed)
        params.add_listener(self._on_param_changed)
        vehicle.add_mode_check("fence plan", self._mode_check)

    def _enforced(self) -> bool:
        return self.params.get_int("FENCE_ENABLE") == 1 and bool(self.store.items(MissionType.FENCE))

    def mission_problem(self) -> str | None:
        """Why the stored mission conflicts with the fence in force (the first item or leg), or ``None``."""
        if not self._enforced():
            return None
        vehicle = self.vehicle
        items = [i for i in vehicle.mission_items() if i.seq >= vehicle.first_mission_seq]
        home = None if vehicle.home is None else (vehicle.home.lat_deg, vehicle.home.lon_deg)
        problem = route_problem(items, home, self.needs_position, vehicle.destination_problem,
                                vehicle.legs_problem)
        return None if problem is None else problem.reason

    def rally_problems(self) -> list[str]:
        """Every stored rally point the fence in force refuses."""
        if not self._enforced():
            return []
        vehicle = self.vehicle
        return [f"rally point {item.seq}: {reason}" for item in self.store.items(MissionType.RALLY)
                if (reason := vehicle.destination_problem(item.lat_deg, item.lon_deg)) is not None]

    def announce(self) -> None:
        """Tell the operator what the fence in force refuses of the stored plans."""
        if (problem := self.mission_problem()) is not None:
            self.vehicle.status(f"Fence: mission conflicts: {problem}; AUTO refused", Severity.WARNING)
        for problem in self.rally_problems():
            self.vehicle.status(f"Fence: {problem}", Severity.WARNING)

    def _on_plan_changed(self, mission_type: MissionType) -> None:
        if mission_type == MissionType.FENCE:
            self.announce()

    def _on_param_changed(self, name: str, value: float) -> None:
        if name == "FENCE_ENABLE" and int(value) == 1:
            self.announce()

    def _mode_check(self, vehicle: Vehicle, number: int) -> str | None:
        if number != ModeNumber.AUTO or not self._enforced():
            return None
        if (problem := self.mission_problem()) is not None:
            return f"fence conflict: {problem}"
        nav = vehicle.nav()
        current = vehicle.mission.current_seq
        nxt = next((i for i in vehicle.mission_items() if i.seq >= current and self.needs_position(i)), None)
        if nav is None or nxt is None:
            return None
        reason = vehicle.leg_problem((nav.lat_deg, nav.lon_deg), (nxt.lat_deg, nxt.lon_deg))
        return None if reason is None else f"the way to item {nxt.seq} {reason}"
