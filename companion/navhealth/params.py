"""Navigation-fault parameters (the degraded action of :mod:`companion.navhealth.stage`)."""

from __future__ import annotations

import enum

from companion.params import ParamDef


class NavFaultAction(enum.IntEnum):
    """USV_FS_NAV_ACT values."""

    REPORT_ONLY = 0
    HOLD = 1
    ENGINE_STOP = 2


PARAMS: tuple[ParamDef, ...] = (
    ParamDef("USV_FS_DR_S", 30.0, 0.0, 600.0, "s",
             "GPS lost while the INS still works: navigate on the INS dead reckoning for this long, then "
             "USV_FS_NAV_ACT (0: act at once)."),
    ParamDef("USV_FS_NAV_ACT", int(NavFaultAction.HOLD), 0, 2, "",
             "Navigation fault action (armed only): 0 report only, 1 HOLD (engine idle, nozzle centred), "
             "2 engine stop (disarm). Taken after USV_FS_DR_S of GPS loss, at once for an INS fault (frozen "
             "solution, stale IMU, no or invalid GPS-INS data).", is_int=True,
             choices=((0, "Report only"), (1, "Hold"), (2, "Engine stop"))),
)
