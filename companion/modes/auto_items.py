"""The AUTO table: what AUTO does for each mission command, one small task class per command.

A :class:`MissionAction` says how AUTO runs one MAV_CMD: the :class:`ItemTask` class (or
factory) that executes the item, whether it is a *navigation* item (reported with
MISSION_ITEM_REACHED; a mission needs at least one) and whether its position is where the next
leg starts.  :data:`BUILT_IN_ACTIONS` holds MAVLink's commands; payloads add theirs through the
payload registry (:mod:`companion.payloads.registry`), so AUTO never names a payload.

An item task gets the :class:`AutoRun` (the state one AUTO run shares between items: the
steering task, the phase, the speed override, where the last leg ended, DO_JUMP counters) and
its :class:`~companion.mission.items.MissionItem`:

* :meth:`ItemTask.start` begins the item: an immediate item (DO_*) does its job and returns the
  next sequence number; anything that takes time returns ``None`` and is then stepped;
* :meth:`ItemTask.step` runs once per navigation sample and returns True when the item is done.

Navigation items (:class:`NavItem`) first go to their point along a leg (ILOS/ALOS,
:class:`~companion.modes.navigation.GotoTask`, phase GOTO), then do what they do there.  The
first leg of a run entered on a hold orbit may wait on that orbit first (phase JOIN,
:class:`~companion.modes.orbit_join.OrbitJoin`) and then starts where the boat leaves it.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from companion.guidance.current import CurrentObserver
from companion.messages import NavState, Severity
from companion.mission import items as mi
from companion.mission.items import MissionItem
from companion.mission.validate import ItemCheck
from companion.modes.circle_item import CircleTask
from companion.modes.holding import OrbitTask
from companion.modes.host import ModeHost
from companion.modes.navigation import (
    GotoTask,
    StationTask,
    Task,
    estimator_current,
    settled_current,
    wp_speed_mps,
)
from companion.modes.orbit_join import LEAVING_ORBIT_TEXT, OrbitJoin

LEG_RESTART_M = 50.0
"""Knocked farther than this off the old leg's end, the next leg starts where the boat is."""
CIRCLE_TAKEOVER_M = 15.0
"""Items that circle their point stop approaching this far out (the circle law approaches), and
the approach is down to the corner speed (``USV_WP_TURN_SPD``) there: the hold on the circle
(:class:`~companion.modes.stem_hold.StemHold`) may start with a sharp turn, and a jet that came
in braking toward the centre (3.4 m/s at the hand-over) coasted on straight while the sharp turn
cut its throttle, through the sampling circle (``docs/tuning.md``)."""
MINUTE_PER_TURN_S = 60.0
"""LOITER_TURNS without a radius keeps station this long per turn."""


class Phase(enum.Enum):
    """Where the current item is."""

    START = "start"
    JOIN = "join"
    """Still on the hold orbit AUTO was entered on, until the bow points along the first leg."""
    GOTO = "goto"
    """Following the leg to the item's point."""
    LOITER = "loiter"
    """At the point: keeping station or circling (hold time, loiter time, turns)."""
    DELAY = "delay"
    """Waiting a time (NAV_DELAY keeps station, CONDITION_DELAY keeps doing what it did)."""
    ACTION = "action"
    """At the point, a payload does its job (sample, launch)."""
    HOLD = "hold"
    """Nothing to wait for: the item is done at the next sample."""


@dataclass
class AutoRun:
    """The state one AUTO run shares between its items."""

    host: ModeHost
    actions: Mapping[int, MissionAction]
    speed_override_mps: float | None = None
    """DO_CHANGE_SPEED (or the ground station's speed when AUTO was entered)."""
    task: Task | None = None
    """What the boat steers now (kept across items: CONDITION_DELAY carries on with it)."""
    phase: Phase = Phase.START
    since_s: float = 0.0
    """When the current item (or its hold/delay/action) began."""
    last_point: tuple[float, float] | None = None
    """Where the last positional item was (start of the next leg)."""
    jumps_done: dict[int, int] = field(default_factory=dict)
    drift: CurrentObserver | None = None
    """The vehicle's current observer (crab feed-forward of legs and circles)."""
    hold_orbit: OrbitTask | None = None
    """The hold orbit AUTO was entered on (RTL/LOITER/GUIDED in a weak current), until the first leg
    starts: the first leg is joined from it (:mod:`companion.modes.orbit_join`)."""

    def navigates(self, command: int) -> bool:
        action = self.actions.get(command)
        return action is not None and action.navigates

    def next_waypoint(self, seq: int) -> tuple[float, float] | None:
        """The point of the next navigation item after ``seq`` if it is a waypoint (corner planning)."""
        nxt = self.host.mission.item(seq + 1)
        while nxt is not None and not self.navigates(nxt.command):
            nxt = self.host.mission.item(nxt.seq + 1)
        if nxt is None or nxt.command != mi.CMD_NAV_WAYPOINT:
            return None
        return (nxt.lat_deg, nxt.lon_deg)


class ItemTask:
    """One mission item being executed (see the module docstring)."""

    def __init__(self, run: AutoRun, item: MissionItem) -> None:
        self.run = run
        self.item = item

    def start(self, nav: NavState) -> int | None:
        """Begin the item; the next sequence number (immediate items) or ``None`` to step it."""
        return self.item.seq + 1

    def step(self, nav: NavState) -> bool:
        """One navigation sample of the item; True when it is done."""
        return True

    def cancel(self) -> None:
        """AUTO was left in the middle of this item."""
        return None


TaskFactory = Callable[[AutoRun, MissionItem], ItemTask]


@dataclass(frozen=True)
class MissionAction:
    """How AUTO runs one mission command (and how an upload checks it, for payload commands)."""

    command: int
    task: TaskFactory
    navigates: bool = True
    """A navigation item: reported reached; a mission needs at least one to run."""
    positional: bool = True
    """The item's point is where the next leg starts."""
    check: ItemCheck | None = None
    """Upload-time validation beyond the built-in checks (payload items)."""
    needs_position: bool = True
    """The item must carry a valid latitude/longitude (upload check)."""


# -- navigation items -------------------------------------------------------------------------
class NavItem(ItemTask):
    """Go to the item's point along a leg, then :meth:`arrive` and :meth:`hold` there."""

    circles = False
    """Approached by the circle law: taken over :data:`CIRCLE_TAKEOVER_M` out."""

    def __init__(self, run: AutoRun, item: MissionItem) -> None:
        super().__init__(run, item)
        self._leg: tuple[tuple[float, float], float | None, tuple[float, float] | None] | None = None
        """The leg waiting for the join from the hold orbit (target, acceptance radius, next point)."""

    def start(self, nav: NavState) -> int | None:
        self.goto(nav, (self.item.lat_deg, self.item.lon_deg))
        return None

    def goto(self, nav: NavState, target: tuple[float, float], accept_radius_m: float | None = None,
             next_point: tuple[float, float] | None = None) -> None:
        """Follow the leg from where the last item ended (or from here) to ``target``; AUTO's first
        leg entered on a hold orbit far off the leg's bearing first joins it from the orbit."""
        run = self.run
        params = run.host.params
        orbit, run.hold_orbit = run.hold_orbit, None
        tolerance_rad = math.radians(params.get_or("USV_WP_JOIN", 0.0))
        if orbit is not None and tolerance_rad > 0.0:
            join = OrbitJoin(orbit, target, tolerance_rad)
            if join.worth_waiting(nav) and not join.aligned(nav):
                off_deg = math.degrees(abs(join.to_go_rad(nav)))
                run.host.status(f"AUTO: orbiting until the bow points along the first leg "
                                f"({off_deg:.0f} deg off)")
                run.task, run.phase, self._leg = join, Phase.JOIN, (target, accept_radius_m, next_point)
                return
        here = (nav.lat_deg, nav.lon_deg)
        speed = wp_speed_mps(params, run.speed_override_mps)
        start = run.last_point or here
        if math.dist(start, here) * 111_000 > LEG_RESTART_M:  # knocked far off the old leg
            start = here
        carried = run.task.follower if isinstance(run.task, GotoTask) else None  # last leg's crab estimate
        run.task = GotoTask(params, start, target, speed, accept_radius_m, next_point, follower=carried,
                            drift=run.drift, water_current=estimator_current(run.host),
                            arrive_short_m=CIRCLE_TAKEOVER_M if self.circles else 0.0,
                            settled=settled_current(run.host))
        run.phase = Phase.GOTO

    def step(self, nav: NavState) -> bool:
        run = self.run
        if run.phase is Phase.JOIN:
            assert isinstance(run.task, OrbitJoin) and self._leg is not None
            if not run.task.aligned(nav):
                return False
            run.host.status(f"{LEAVING_ORBIT_TEXT} after {nav.t_s - run.since_s:.0f} s")
            run.last_point = None  # the first leg starts where the boat leaves the orbit
            self.goto(nav, *self._leg)
            self._leg = None
        if run.phase is Phase.GOTO:
            assert isinstance(run.task, GotoTask)
            arrived = run.task.distance_m <= CIRCLE_TAKEOVER_M if self.circles else run.task.reached
            if not arrived:
                return False
            run.since_s = nav.t_s
            return self.arrive(nav)
        return self.hold(nav)

    def arrive(self, nav: NavState) -> bool:
        """At the point: True if the item is done, else set up what comes next (phase, task)."""
        return True

    def hold(self, nav: NavState) -> bool:
        """After arriving: True when the item is done."""
        return True

    @property
    def point(self) -> tuple[float, float]:
        return (self.item.lat_deg, self.item.lon_deg)


class WaypointItem(NavItem):
    """NAV_WAYPOINT: param1 hold time (s, keeping station), param2 acceptance radius (m)."""

    def start(self, nav: NavState) -> int | None:
        item = self.item
        accept = item.param2 if item.param2 > 0 else None
        nxt = self.run.next_waypoint(item.seq) if item.param1 <= 0 else None
        self.goto(nav, self.point, accept, nxt)
        return None

    def arrive(self, nav: NavState) -> bool:
        if self.item.param1 > 0:
            self.run.task = StationTask(self.run.host.params, self.point, nav.heading_rad)
            self.run.phase = Phase.LOITER
            return False
        return True

    def hold(self, nav: NavState) -> bool:
        return nav.t_s - self.run.since_s >= self.item.param1


class LoiterItem(NavItem):
    """NAV_LOITER_UNLIM / _TIME (param1 s) / _TURNS (param1 turns); param3 the radius: 0 keep
    station bow into the current, > 0 circle clockwise, < 0 anticlockwise."""

    def __init__(self, run: AutoRun, item: MissionItem) -> None:
        super().__init__(run, item)
        self.circles = abs(item.param3) > 0

    def arrive(self, nav: NavState) -> bool:
        params, p3 = self.run.host.params, self.item.param3
        if abs(p3) > 0:
            self.run.task = CircleTask(params, self.point, abs(p3), clockwise=p3 > 0, drift=self.run.drift,
                                       water_current=estimator_current(self.run.host),
                                       trials=self.run.host.station_trials,
                                       idling=self.run.host.control.mapper.idling)
        else:
            self.run.task = StationTask(params, self.point, nav.heading_rad)
        self.run.phase = Phase.LOITER
        return False

    def hold(self, nav: NavState) -> bool:
        c, elapsed_s = self.item.command, nav.t_s - self.run.since_s
        if c == mi.CMD_NAV_LOITER_UNLIM:
            return False
        if c == mi.CMD_NAV_LOITER_TURNS:
            task = self.run.task
            if isinstance(task, CircleTask):
                return task.turns >= self.item.param1
            return elapsed_s >= MINUTE_PER_TURN_S * self.item.param1
        return elapsed_s >= self.item.param1


class ReturnItem(NavItem):
    """NAV_RETURN_TO_LAUNCH: go home (without a home: keep station where it is, and go on)."""

    def start(self, nav: NavState) -> int | None:
        host = self.run.host
        if host.home is None:
            host.status("AUTO: no home for RETURN_TO_LAUNCH; keeping station", Severity.WARNING)
            self.run.task = StationTask(host.params, (nav.lat_deg, nav.lon_deg), nav.heading_rad)
            self.run.phase = Phase.HOLD
            return None
        self.goto(nav, (host.home.lat_deg, host.home.lon_deg))
        return None


class ConditionDelayItem(ItemTask):
    """CONDITION_DELAY: wait param1 s, steering as before."""

    def start(self, nav: NavState) -> int | None:
        self.run.phase = Phase.DELAY
        return None

    def step(self, nav: NavState) -> bool:
        return nav.t_s - self.run.since_s >= max(0.0, self.item.param1)


class NavDelayItem(ConditionDelayItem):
    """NAV_DELAY: keep station where the boat is for param1 s."""

    def start(self, nav: NavState) -> int | None:
        self.run.task = StationTask(self.run.host.params, (nav.lat_deg, nav.lon_deg), nav.heading_rad)
        return super().start(nav)


# -- immediate items --------------------------------------------------------------------------


class ChangeSpeedItem(ItemTask):
    """DO_CHANGE_SPEED: param2 m/s for the following legs (<= 0: unchanged)."""

    def start(self, nav: NavState) -> int | None:
        if self.item.param2 > 0:
            self.run.speed_override_mps = self.item.param2
        return self.item.seq + 1


class JumpItem(ItemTask):
    """DO_JUMP: go to item param1, param2 times (< 0: for ever), then carry on."""

    def start(self, nav: NavState) -> int | None:
        item, jumps = self.item, self.run.jumps_done
        done = jumps.get(item.seq, 0)
        repeat = int(item.param2)
        if repeat < 0 or done < repeat:
            jumps[item.seq] = done + 1
            return int(item.param1)
        return item.seq + 1


class SetHomeItem(ItemTask):
    """DO_SET_HOME: param1 1 = here, else the item's position."""

    def start(self, nav: NavState) -> int | None:
        host, item = self.run.host, self.item
        here = host.nav()
        if item.param1 == 1 and here is not None:
            host.set_home(here.lat_deg, here.lon_deg)
        elif item.is_global:
            host.set_home(item.lat_deg, item.lon_deg)
        return item.seq + 1


class SetServoItem(ItemTask):
    """DO_SET_SERVO: output param1 at param2 us."""

    def start(self, nav: NavState) -> int | None:
        self.run.host.set_servo_override(int(self.item.param1), int(self.item.param2))
        return self.item.seq + 1


class SetRelayItem(ItemTask):
    """DO_SET_RELAY: relay param1 on (param2 1) or off."""

    def start(self, nav: NavState) -> int | None:
        self.run.host.set_relay_state(int(self.item.param1), bool(self.item.param2))
        return self.item.seq + 1


class UnsupportedItem(ItemTask):
    """A command AUTO cannot run: say so and skip it."""

    def start(self, nav: NavState) -> int | None:
        item = self.item
        self.run.host.status(f"AUTO: item {item.seq} command {item.command} not supported; skipped",
                             Severity.WARNING)
        return item.seq + 1


def _immediate(command: int, task: TaskFactory) -> MissionAction:
    return MissionAction(command, task, navigates=False, positional=False, needs_position=False)


BUILT_IN_ACTIONS: dict[int, MissionAction] = {a.command: a for a in (
    MissionAction(mi.CMD_NAV_WAYPOINT, WaypointItem),
    MissionAction(mi.CMD_NAV_LOITER_UNLIM, LoiterItem),
    MissionAction(mi.CMD_NAV_LOITER_TIME, LoiterItem),
    MissionAction(mi.CMD_NAV_LOITER_TURNS, LoiterItem),
    MissionAction(mi.CMD_NAV_RETURN_TO_LAUNCH, ReturnItem, positional=False, needs_position=False),
    MissionAction(mi.CMD_NAV_DELAY, NavDelayItem, positional=False, needs_position=False),
    _immediate(mi.CMD_CONDITION_DELAY, ConditionDelayItem),
    _immediate(mi.CMD_DO_CHANGE_SPEED, ChangeSpeedItem),
    _immediate(mi.CMD_DO_JUMP, JumpItem),
    _immediate(mi.CMD_DO_SET_HOME, SetHomeItem),
    _immediate(mi.CMD_DO_SET_SERVO, SetServoItem),
    _immediate(mi.CMD_DO_SET_RELAY, SetRelayItem),
)}
"""MAVLink's mission commands (payload commands come from the payload registry)."""

UNSUPPORTED = _immediate(-1, UnsupportedItem)
