"""The rope launcher on MAVLink: USV_CMD_LAUNCHER_ARM / _FIRE and USV_LAUNCHER_STATUS.

Every refusal is ``DENIED`` with the launcher's reason, which the command service turns into a
STATUSTEXT (the interlocks are in :mod:`companion.payloads.launcher.device`).
"""

from __future__ import annotations

import math
from typing import Any

from companion.mavlink.commands import CommandRequest, CommandResult
from companion.params import ParamStore
from companion.payloads.launcher.device import RopeLauncher


def _opt(x: float) -> float | None:
    """0 or NaN mean "use the default"."""
    return None if not math.isfinite(x) or x == 0 else float(x)


def _deg_e7(x: float | None) -> int:
    return 0 if x is None or not math.isfinite(x) else round(x * 1e7)


class LauncherCommands:
    """Command handlers bound to one launcher."""

    def __init__(self, launcher: RopeLauncher) -> None:
        self.launcher = launcher

    async def arm(self, cmd: CommandRequest) -> CommandResult:
        """param1 1 arm (param2 window s, 0: USV_LNCH_ARM_S), 0 make safe."""
        launcher = self.launcher
        if cmd.param1 == 0:
            launcher.make_safe("operator")
            return CommandResult.accepted("launcher: safe")
        if cmd.param1 != 1:
            return CommandResult.denied(f"launcher: param1 must be 1 (arm) or 0 (safe), got {cmd.param1:g}")
        reason = launcher.arm(_opt(cmd.param2))
        if reason is not None:
            return CommandResult.denied(reason)
        return CommandResult.accepted(f"launcher: ARMED for {launcher.arm_time_left_s():.0f} s")

    async def fire(self, cmd: CommandRequest) -> CommandResult:
        reason = await self.launcher.fire()
        if reason is not None:
            return CommandResult.denied(reason)
        last = self.launcher.last_launch
        heading = f" hdg {last.heading_deg:.0f}" if last and last.heading_deg is not None else ""
        return CommandResult.accepted(f"launcher: FIRED{heading}")


def launcher_status_message(launcher: RopeLauncher, params: ParamStore, time_boot_ms: int) -> Any:
    """USV_LAUNCHER_STATUS (dialect id 43000)."""
    from mavlink_dialect import usv

    last = launcher.last_launch
    pressure = launcher.pressure_mpa()
    return usv.MAVLink_usv_launcher_status_message(
        time_boot_ms,
        math.nan if pressure is None else pressure,
        params.get("USV_LNCH_MIN_MPA"),
        launcher.arm_time_left_s(),
        int(last.t_unix_s * 1e6) if last else 0,
        _deg_e7(last.lat_deg if last else None),
        _deg_e7(last.lon_deg if last else None),
        round((last.heading_deg or 0.0) * 100) % 36000 if last else 0,
        int(launcher.state()),
        int(launcher.interlocks()),
        max(0, min(255, launcher.shots_left)),
    )
