"""Parameters of the MAVLink links: the bounds of the telemetry logs (``USV_TLOG_*``)."""

from __future__ import annotations

from companion.params import ParamDef

PARAMS: tuple[ParamDef, ...] = (
    ParamDef("USV_TLOG_MAX_MB", 500.0, 1.0, 100_000.0, "MB",
             "Total size of the .tlog files kept in state_dir/logs; the oldest closed logs are deleted "
             "beyond it (with links.tlog_max_files, what bounds a connection flood)."),
    ParamDef("USV_TLOG_FILE_MB", 50.0, 0.1, 10_000.0, "MB",
             "A link's .tlog is continued in a new part file once it reaches this size."),
)
