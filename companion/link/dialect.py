"""The MAVLink message set the vehicle speaks: pymavlink's ``all`` dialect plus the boat's own.

pymavlink's ``all`` dialect carries common.xml, development.xml (AVAILABLE_MODES,
CURRENT_MODE, the standard-modes protocol) and ardupilotmega.xml.  The boat's dialect
(:mod:`mavlink_dialect`, usv.xml) adds its status messages; their classes are added to the
decoder map here so one parser understands everything.  (Only ids the ``all`` map lacks are
added; a collision test lives in ``tests/dialect``.)
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from pymavlink.dialects.v20 import all as _all

mav: ModuleType = _all
"""The message module: constants (``mav.MAV_CMD_...``) and message classes."""


def _merge_boat_dialect() -> list[int]:
    added: list[int] = []
    try:
        from mavlink_dialect import usv
    except ImportError:  # the dialect package is optional for the link layer
        return added
    for msg_id, cls in usv.mavlink_map.items():
        if msg_id not in _all.mavlink_map:
            _all.mavlink_map[msg_id] = cls
            added.append(msg_id)
    return added


BOAT_MESSAGE_IDS: list[int] = _merge_boat_dialect()
"""Ids of the boat dialect's messages known to the decoder."""


def new_codec(system_id: int = 1, component_id: int = 1) -> Any:
    """A MAVLink 2 encoder/decoder with its own sequence counter (one per link)."""
    codec = _all.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
    codec.robust_parsing = True
    return codec


def boat_module() -> ModuleType | None:
    """The generated boat dialect module (message classes), or ``None`` if absent."""
    try:
        from mavlink_dialect import usv
    except ImportError:
        return None
    return usv
