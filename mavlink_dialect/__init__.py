"""The boat's MAVLink dialect (usv.xml, includes common.xml) and its generated pymavlink module.

One XML file, ``mavlink_dialect/usv.xml``, is the source for everybody:

* Python (companion, tests, pymavlink clients)::

      from mavlink_dialect import usv           # the generated pymavlink module (MAVLink 2)
      mav = usv.MAVLink(None, srcSystem=1, srcComponent=1)
      msg = usv.MAVLink_usv_launcher_status_message(...)

  ``load()`` returns the same module; ``use_with_mavutil()`` makes ``pymavlink.mavutil``
  connections decode the boat's messages too.
* MAVSDK-Python 4: ``await mavlink_direct.load_custom_xml(mavlink_dialect.mavsdk_xml())``.
* Command ids: :class:`UsvCmd` (MAV_CMD user range, see the XML header for the choice).

Regenerate the module after editing the XML with ``python -m mavlink_dialect.generate``;
``tests/dialect`` fails while the committed module is stale.
"""

from __future__ import annotations

import enum
import sys
from functools import cache
from pathlib import Path
from types import ModuleType

from mavlink_dialect.generated import usv

XML_PATH = Path(__file__).resolve().parent / "usv.xml"

__all__ = ["XML_PATH", "UsvCmd", "load", "mavsdk_xml", "use_with_mavutil", "usv", "xml_text"]


class UsvCmd(enum.IntEnum):
    """The boat's command ids (same values as ``usv.USV_CMD_*``; MAV_CMD user range)."""

    NAV_LAUNCH_AT = 31000  # MAV_CMD_WAYPOINT_USER_1, mission item
    NAV_SAMPLE_HERE = 31001  # MAV_CMD_WAYPOINT_USER_2, mission item
    LAUNCHER_ARM = 31010  # MAV_CMD_USER_1
    LAUNCHER_FIRE = 31011  # MAV_CMD_USER_2
    SAMPLE = 31012  # MAV_CMD_USER_3
    PUMP_STOP = 31013  # MAV_CMD_USER_4
    SAMPLER_RESET = 31014  # MAV_CMD_USER_5


def load() -> ModuleType:
    """Return the generated pymavlink module for usv.xml (MAVLink 2)."""
    return usv


@cache
def xml_text() -> str:
    """The dialect XML exactly as stored (with its ``<include>common.xml</include>``)."""
    return XML_PATH.read_text(encoding="utf-8")


def mavsdk_xml() -> str:
    """The dialect XML for MAVSDK's ``mavlink_direct.load_custom_xml``: the very same file.

    MAVSDK 4.1 ships common.xml itself and accepts the ``<include>`` line (verified by
    ``tests/dialect/test_mavsdk_dialect.py``), so nothing is stripped or flattened.
    """
    return xml_text()


def use_with_mavutil() -> ModuleType:
    """Make ``pymavlink.mavutil`` use this dialect for connections opened afterwards.

    Registers the generated module as ``pymavlink.dialects.v20.usv`` and selects it with
    ``mavutil.set_dialect("usv")`` (which also switches mavutil to MAVLink 2).
    """
    import os

    import pymavlink.dialects.v20 as v20
    from pymavlink import mavutil

    os.environ["MAVLINK20"] = "1"
    sys.modules.setdefault("pymavlink.dialects.v20.usv", usv)
    setattr(v20, "usv", usv)  # noqa: B010 (module attribute for mavutil.set_dialect)
    mavutil.set_dialect("usv")
    return usv


# Silence "imported but unused" for readers that only use the documented attribute access.
assert usv.DIALECT == "usv"
