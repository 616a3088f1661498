"""AUTO (Rover 10): run the uploaded mission item by item.

What each command does is in the AUTO table (:mod:`companion.modes.auto_items`): NAV_WAYPOINT,
NAV_LOITER_UNLIM/_TIME/_TURNS, NAV_DELAY, NAV_RETURN_TO_LAUNCH, CONDITION_DELAY,
DO_CHANGE_SPEED, DO_JUMP, DO_SET_HOME, DO_SET_SERVO, DO_SET_RELAY, plus the payloads' items
(sample here, launch at; the host's ``mission_actions``).  This module is the sequencing:
immediate items run at once and the next one starts in the same sample (at most
:data:`MAX_IMMEDIATE` in a row, so a DO_JUMP loop cannot hang the loop), navigation items are
stepped every sample until done, MISSION_SET_CURRENT from the operator restarts at that item.
Items are validated at upload (:mod:`companion.mission.validate`), so a bad coordinate never
reaches this mode.  After the last item the mission is COMPLETE and the boat goes to HOLD or
LOITER according to MIS_DONE_BEHAVE.  Entered on the hold orbit of RTL, LOITER or GUIDED (handed
over by the mode manager), AUTO keeps that orbit until the bow points along the first leg
(``USV_WP_JOIN``, :mod:`companion.modes.orbit_join`); from rest or a straight run it goes at once.
"""

from __future__ import annotations

from companion.messages import ModeNumber, NavState, Severity
from companion.mission.items import MissionItem
from companion.modes.auto_items import BUILT_IN_ACTIONS, UNSUPPORTED, AutoRun, ItemTask, MissionAction, Phase
from companion.modes.base import ModeOutput, StandardMode
from companion.modes.holding import OrbitTask
from companion.modes.host import ModeHost
from companion.modes.navigation import NavMode, param

MAX_IMMEDIATE = 64
"""Immediate items run in one sample before AUTO gives up (a DO_JUMP loop without navigation)."""
MIS_DONE_LOITER = 1
"""MIS_DONE_BEHAVE value: LOITER after the last item (0: HOLD)."""


class AutoMode(NavMode):
    number = ModeNumber.AUTO
    name = "AUTO"
    standard_mode = StandardMode.MISSION
    description = "Auto: run the uploaded mission (waypoints, loiters, delays, speed, RTL, sampling, launch)."

    def __init__(self) -> None:
        super().__init__()
        self.seq = -1
        self.run: AutoRun | None = None
        self.item_task: ItemTask | None = None

    @staticmethod
    def actions(host: ModeHost) -> dict[int, MissionAction]:
        """The AUTO table of this vehicle: MAVLink's commands and its payloads'."""
        return {**BUILT_IN_ACTIONS, **host.mission_actions}

    @property
    def phase(self) -> Phase:
        return Phase.START if self.run is None else self.run.phase

    # -- mode interface ------------------------------------------------------------------
    def requirements(self, host: ModeHost) -> str | None:
        items = [i for i in host.mission.items() if i.seq >= host.mission.first_seq]
        if not items:
            return "no mission uploaded"
        actions = self.actions(host)
        if not any(a.navigates for a in (actions.get(i.command) for i in items) if a is not None):
            return "mission has no navigation item"
        return super().requirements(host)

    def enter(self, host: ModeHost) -> None:
        super().enter(host)
        host.mission.start()
        nav = host.nav()
        assert nav is not None
        # no crab estimate carried in from an earlier AUTO run
        orbit = self.handed_over if isinstance(self.handed_over, OrbitTask) else None
        self.run = AutoRun(host, self.actions(host), speed_override_mps=host.speed_override_mps,
                           last_point=(nav.lat_deg, nav.lon_deg), drift=self.drift, hold_orbit=orbit)
        self._start(self.run, nav, host.mission.current_seq)

    def exit(self, host: ModeHost) -> None:
        super().exit(host)
        if self.item_task is not None:
            self.item_task.cancel()
        self.seq = -1

    def update(self, host: ModeHost, nav: NavState) -> ModeOutput:
        run = self.run
        assert run is not None
        if host.mission.current_seq != self.seq:  # the operator jumped (MISSION_SET_CURRENT)
            self._start(run, nav, host.mission.current_seq)
        if self.seq < 0:
            return None
        item = host.mission.item(self.seq)
        if item is None or self.item_task is None:
            self._finish(host)
            return None
        if self.item_task.step(nav):
            action = run.actions.get(item.command)
            if action is not None and action.navigates:
                host.mission.report_reached(item.seq)
                if action.positional:
                    run.last_point = (item.lat_deg, item.lon_deg)
            self._advance(run, nav, self.seq + 1)
        elif run.task is not None:
            return self.run_task(host, nav, run.task)
        return None

    # -- item sequencing -----------------------------------------------------------------
    def _advance(self, run: AutoRun, nav: NavState, seq: int) -> None:
        if run.host.mission.item(seq) is None:
            self._finish(run.host)
            return
        run.host.mission.set_current(seq)
        self._start(run, nav, seq)

    def _finish(self, host: ModeHost) -> None:
        self.seq = -1
        host.mission_complete()
        behave = int(param(host.params, "MIS_DONE_BEHAVE"))
        reason = host.set_mode(ModeNumber.LOITER if behave == MIS_DONE_LOITER else ModeNumber.HOLD)
        if reason:
            host.status(f"AUTO: mission done, {reason}", Severity.WARNING)

    def _start(self, run: AutoRun, nav: NavState, seq: int) -> None:
        """Begin item ``seq``: immediate items run at once and the next one starts."""
        host = run.host
        for _ in range(MAX_IMMEDIATE):
            self.seq = seq
            item = host.mission.item(seq)
            if item is None:
                self._finish(host)
                return
            self.item_task = self._task(run, item)
            run.phase, run.since_s = Phase.START, nav.t_s
            nxt = self.item_task.start(nav)
            if nxt is None:  # it takes time: stepped by update()
                return
            if host.mission.item(nxt) is None:
                self._finish(host)
                return
            host.mission.set_current(nxt)
            seq = nxt
        host.status("AUTO: too many jumps without a navigation item; stopping", Severity.ERROR)
        self._finish(host)

    @staticmethod
    def _task(run: AutoRun, item: MissionItem) -> ItemTask:
        return run.actions.get(item.command, UNSUPPORTED).task(run, item)
