"""Persistent storage of the mission, fence and rally plans.

Each plan is a JSON file in ``<state_dir>/missions/`` replaced atomically (temporary file,
fsync, rename) after every accepted upload or clear, so a power cut leaves either the old
or the new plan, never half of one.  A damaged file is reported and treated as empty.

Each plan remembers whether its item 0 is ArduPilot's home placeholder (the convention the
upload used, :mod:`companion.mission.convention`), so a download gives every client back the
shape it uploaded.  Plans saved before that flag existed are classified from their items.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path

from companion.mission.convention import Convention, classify
from companion.mission.items import MissionItem, MissionType
from companion.params import atomic_write_text, remove_stale_temp_files

log = logging.getLogger(__name__)

_FILE_NAMES = {MissionType.MISSION: "mission.json", MissionType.FENCE: "fence.json",
               MissionType.RALLY: "rally.json"}

ChangeListener = Callable[[MissionType], None]


class MissionStore:
    """The three plans of one vehicle, optionally persisted in ``directory``."""

    def __init__(self, directory: Path | None = None) -> None:
        self.directory = directory
        self._plans: dict[MissionType, list[MissionItem]] = {t: [] for t in MissionType}
        self._versions: dict[MissionType, int] = {t: 0 for t in MissionType}
        self._home_item: dict[MissionType, bool] = {t: False for t in MissionType}
        self._listeners: list[ChangeListener] = []
        self.load_warnings: list[str] = []
        if directory is not None:
            for mtype in MissionType:
                self._load(mtype)

    def items(self, mission_type: int = MissionType.MISSION) -> list[MissionItem]:
        """A copy of the plan of ``mission_type``."""
        return list(self._plans[MissionType(mission_type)])

    def count(self, mission_type: int = MissionType.MISSION) -> int:
        return len(self._plans[MissionType(mission_type)])

    def version(self, mission_type: int = MissionType.MISSION) -> int:
        """Increases on every change (MISSION_ACK/MISSION_COUNT opaque id material)."""
        return self._versions[MissionType(mission_type)]

    def has_home_item(self, mission_type: int = MissionType.MISSION) -> bool:
        """Item 0 of the plan is ArduPilot's home placeholder (never executed)."""
        return self._home_item[MissionType(mission_type)]

    def add_listener(self, listener: ChangeListener) -> None:
        self._listeners.append(listener)

    def replace(self, mission_type: int, plan: list[MissionItem], *, home_item: bool | None = None) -> None:
        """Install a complete, already validated plan and persist it.

        ``home_item``: item 0 is ArduPilot's home placeholder; ``None`` decides it from the items
        alone (:func:`~companion.mission.convention.classify` without a vehicle home).
        """
        mtype = MissionType(mission_type)
        self._plans[mtype] = [item.with_seq(i) for i, item in enumerate(plan)]
        if home_item is None:
            home_item = _home_item(mtype, plan)
        self._home_item[mtype] = home_item and bool(plan)
        self._versions[mtype] += 1
        self._save(mtype)
        for listener in tuple(self._listeners):
            listener(mtype)

    def clear(self, mission_type: int) -> None:
        """Remove a plan (MAV_MISSION_TYPE_ALL = 255 clears all three)."""
        if mission_type == 255:
            for mtype in MissionType:
                self.replace(mtype, [])
        else:
            self.replace(mission_type, [])

    def _path(self, mtype: MissionType) -> Path | None:
        return None if self.directory is None else self.directory / _FILE_NAMES[mtype]

    def _save(self, mtype: MissionType) -> None:
        path = self._path(mtype)
        if path is None:
            return
        data = {"mission_type": int(mtype), "home_item": self._home_item[mtype],
                "items": [item.to_dict() for item in self._plans[mtype]]}
        atomic_write_text(path, json.dumps(data, indent=1, allow_nan=True) + "\n")

    def _load(self, mtype: MissionType) -> None:
        path = self._path(mtype)
        if path is None:
            return
        remove_stale_temp_files(path)
        if not path.exists():
            return
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            plan = [MissionItem.from_dict(d) for d in data["items"]]
            home_item = bool(data["home_item"]) if "home_item" in data else _home_item(mtype, plan)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            warning = f"{path}: cannot read saved {mtype.name.lower()} plan ({exc}); starting empty"
            log.warning("%s", warning)
            self.load_warnings.append(warning)
            return
        self._plans[mtype] = [item.with_seq(i) for i, item in enumerate(plan)]
        self._home_item[mtype] = home_item and bool(plan)


def _home_item(mtype: MissionType, plan: list[MissionItem]) -> bool:
    """Whether item 0 of a plan given without its convention is a home placeholder (items only)."""
    return mtype == MissionType.MISSION and classify(plan, None).convention is Convention.HOME_PLACEHOLDER
