"""Where the vehicle is in its stored mission: the current item, started, complete.

:class:`MissionCursor` is what AUTO reads and moves (item by item, DO_JUMP, the operator's
MISSION_SET_CURRENT) and what MISSION_CURRENT reports.  Under the ``ardurover`` profile, when
the stored plan was uploaded in ArduPilot's convention (:mod:`companion.mission.convention`),
item 0 is the home position and is never executed (``first_seq`` 1); a new plan puts the
cursor back on the first item.
"""

from __future__ import annotations

import enum
from collections.abc import Callable

from companion.mission.items import MissionItem, MissionType
from companion.mission.store import MissionStore


class MissionState(enum.IntEnum):
    """MISSION_STATE as reported in MISSION_CURRENT (MAVSDK waits for COMPLETE)."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


class MissionCursor:
    """The current item of the mission in ``store`` and the mission's progress."""

    def __init__(self, store: MissionStore, home_placeholder_profile: bool) -> None:
        self.store = store
        self.home_placeholder_profile = home_placeholder_profile
        """The profile keeps ArduPilot's item-0-is-home convention (``ardurover``)."""
        self._current_seq = self.first_seq
        self._started = False
        self._complete = False
        self.changed_listeners: list[Callable[[], None]] = []
        """Run when the current item is set (MISSION_SET_CURRENT, AUTO advancing)."""
        self.reached_listeners: list[Callable[[int], None]] = []
        """Run with the sequence number of every item AUTO reaches (MISSION_ITEM_REACHED)."""
        store.add_listener(self._on_plan_changed)

    # -- the plan -------------------------------------------------------------------------
    @property
    def first_seq(self) -> int:
        """Sequence number of the first executable item: 1 when item 0 is the home placeholder."""
        home_item = self.store.has_home_item(MissionType.MISSION)
        return 1 if self.home_placeholder_profile and home_item else 0

    def items(self) -> list[MissionItem]:
        """The stored mission (MAV_MISSION_TYPE_MISSION) with wire sequence numbers."""
        return self.store.items(MissionType.MISSION)

    def item(self, seq: int) -> MissionItem | None:
        """Item ``seq`` of the mission, or ``None`` past its end."""
        return next((i for i in self.items() if i.seq == seq), None)

    @property
    def count(self) -> int:
        """Items in the mission, the home item included."""
        return self.store.count(MissionType.MISSION)

    @property
    def total(self) -> int:
        """MISSION_CURRENT.total: mission items without the home item (MAVLink's definition)."""
        return max(0, self.count - self.first_seq)

    # -- progress -------------------------------------------------------------------------
    @property
    def current_seq(self) -> int:
        """Sequence number of the current mission item (MISSION_CURRENT.seq)."""
        return self._current_seq

    @property
    def complete(self) -> bool:
        return self._complete

    def set_current(self, seq: int) -> str | None:
        """Make ``seq`` the current item; ``None`` or the reason it cannot be."""
        count = self.count
        seq = max(int(seq), self.first_seq)
        if seq >= count:
            return f"mission item {seq} does not exist ({count} items)"
        self._current_seq = seq
        self._complete = False
        for listener in tuple(self.changed_listeners):
            listener()
        return None

    def start(self) -> None:
        """Mark the mission as running (MISSION_START / entering AUTO); restarts a finished one."""
        if self._complete:
            self._current_seq = self.first_seq
        self._complete = False
        self._started = True

    def report_reached(self, seq: int) -> None:
        """AUTO reached item ``seq``."""
        for listener in tuple(self.reached_listeners):
            listener(int(seq))

    def mark_complete(self) -> bool:
        """AUTO finished the last item; True if the mission was not complete before."""
        if self._complete:
            return False
        self._complete = True
        return True

    def state(self, running: bool) -> MissionState:
        """MISSION_STATE; ``running``: AUTO is the active mode."""
        if self.count <= self.first_seq:
            return MissionState.NO_MISSION
        if self._complete:
            return MissionState.COMPLETE
        if running:
            return MissionState.ACTIVE
        return MissionState.PAUSED if self._started else MissionState.NOT_STARTED

    def _on_plan_changed(self, mtype: MissionType) -> None:
        if mtype == MissionType.MISSION:
            self._current_seq = self.first_seq
            self._started = False
            self._complete = False
