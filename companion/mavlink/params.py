"""ArduPilot Rover parameters that ground-control software reads, each wired to behaviour.

QGroundControl and MAVSDK read a handful of ArduPilot parameters from a vehicle that says
it is ArduPilot; these keep ArduPilot's names and units so those tools work, and each one
changes what the boat does:

* ``WP_RADIUS``, ``WP_SPEED``, ``CRUISE_SPEED``, ``LOIT_RADIUS``: read by the guidance
  and modes (AUTO, GUIDED, LOITER) of the guidance/control issue.
* ``FS_GCS_ENABLE``, ``FS_GCS_TIMEOUT``, ``FS_ACTION``: the ground-station failsafe in
  :meth:`companion.mavlink.service.MavlinkService.check_failsafe` (vehicle clock; when the
  simulation runs faster than real time, also the wall clock: :mod:`companion.link.gcs_presence`).
* ``MIS_DONE_BEHAVE``: what AUTO does after the last item (ArduRover's 0 Hold, 1 Loiter);
  read by AUTO.

The boat's own parameters use the ``USV_`` prefix (``USV_FS_ENG_STOP``: the chapter's
engine stop after 120 s without ground-station data).
"""

from __future__ import annotations

from companion.params import ParamDef

PARAMS: tuple[ParamDef, ...] = (
    ParamDef("WP_RADIUS", 2.0, 0.1, 100.0, "m",
             "Waypoint radius: a waypoint counts as reached within this distance (AUTO)."),
    ParamDef("WP_SPEED", 5.0, 0.0, 10.0, "m/s",
             "Speed in AUTO and GUIDED (0: use CRUISE_SPEED)."),
    ParamDef("CRUISE_SPEED", 5.0, 0.0, 10.0, "m/s",
             "Default cruise speed (used when WP_SPEED is 0, and by CRUISE/RTL)."),
    ParamDef("LOIT_RADIUS", 2.0, 0.5, 50.0, "m",
             "Loiter radius: LOITER and the end of GUIDED go-tos keep the boat within this distance."),
    ParamDef("FS_GCS_ENABLE", 1, 0, 2, "",
             "Ground-station failsafe: 0 disabled, 1 enabled (FS_ACTION after FS_GCS_TIMEOUT without "
             "heartbeats), 2 enabled but AUTO continues its mission.", is_int=True,
             choices=((0, "Disabled"), (1, "Enabled"), (2, "Enabled, continue mission in AUTO"))),
    ParamDef("FS_GCS_TIMEOUT", 5.0, 2.0, 120.0, "s",
             "Seconds without a ground-station heartbeat before the GCS failsafe acts (vehicle clock; in "
             "SITL faster than real time also 3 missed wall-clock heartbeats)."),
    ParamDef("FS_ACTION", 2, 0, 2, "",
             "Failsafe action: 0 nothing, 1 RTL, 2 HOLD.", is_int=True,
             choices=((0, "Nothing"), (1, "RTL"), (2, "Hold"))),
    ParamDef("MIS_DONE_BEHAVE", 0, 0, 1, "",
             "What AUTO does after the last mission item: 0 HOLD, 1 LOITER.", is_int=True,
             choices=((0, "Hold"), (1, "Loiter"))),
    ParamDef("USV_FS_ENG_STOP", 120.0, 0.0, 3600.0, "s",
             "Stop the engine (disarm) after this long without ground-station data, whatever the mode "
             "(chapter: 120 s); 0 disables."),
)
