"""PayloadService: creates the launcher, sampler and sample log, registers their MAVLink
commands, provides their status messages, and keeps the outputs safe on shutdown."""

from __future__ import annotations

import contextlib
import logging
import math
from typing import Any

from companion.app import BaseService, Context
from companion.mavlink.commands import CommandRegistry
from companion.mavlink.telemetry import StatusBuilder
from companion.payloads.commands import PayloadCommands
from companion.payloads.launcher import RopeLauncher
from companion.payloads.mission_checks import register_mission_checks
from companion.payloads.registry import Payloads
from companion.payloads.samplelog import SAMPLE_LOG_NAME, SampleLog
from companion.payloads.sampler import WaterSampler
from companion.payloads.topics import PayloadOutputs

log = logging.getLogger(__name__)

STATUS_RATE_HZ = 1.0


def _deg_e7(x: float | None) -> int:
    return 0 if x is None or not math.isfinite(x) else round(x * 1e7)


def launcher_status_message(payloads: Payloads, time_boot_ms: int) -> Any:
    """USV_LAUNCHER_STATUS (dialect id 43000)."""
    from mavlink_dialect import usv

    launcher = payloads.launcher
    last = launcher.last_launch
    pressure = launcher.pressure_mpa()
    return usv.MAVLink_usv_launcher_status_message(
        time_boot_ms,
        math.nan if pressure is None else pressure,
        payloads.ctx.params.get("USV_LNCH_MIN_MPA"),
        launcher.arm_time_left_s(),
        int(last.t_unix_s * 1e6) if last else 0,
        _deg_e7(last.lat_deg if last else None),
        _deg_e7(last.lon_deg if last else None),
        round((last.heading_deg or 0.0) * 100) % 36000 if last else 0,
        int(launcher.state()),
        int(launcher.interlocks()),
        max(0, min(255, launcher.shots_left)),
    )


def sampler_status_message(payloads: Payloads, time_boot_ms: int) -> Any:
    """USV_SAMPLER_STATUS (dialect id 43001)."""
    from mavlink_dialect import usv

    sampler = payloads.sampler
    last = sampler.last_sample
    active = sampler.active
    return usv.MAVLink_usv_sampler_status_message(
        time_boot_ms,
        [float(v) for v in sampler.bottle_volume_ml],
        int(last.t_unix_s * 1e6) if last else 0,
        _deg_e7(last.lat_deg if last else None),
        _deg_e7(last.lon_deg if last else None),
        math.nan if last is None or last.distance_m is None else last.distance_m,
        [int(s) for s in sampler.bottle_state],
        1 if sampler.pump_on() else 0,
        active.bottle if active else 0,
        last.bottle if last else 0,
    )


class PayloadService(BaseService):
    """Owns the payloads of one vehicle."""

    name = "payloads"

    def __init__(self, ctx: Context, commands: CommandRegistry) -> None:
        self.ctx = ctx
        outputs = PayloadOutputs(ctx.bus, ctx.clock)
        samplelog = SampleLog(ctx.config.state_dir() / SAMPLE_LOG_NAME)
        self.payloads = Payloads(
            ctx=ctx,
            outputs=outputs,
            samplelog=samplelog,
            launcher=RopeLauncher(ctx, outputs, samplelog),
            sampler=WaterSampler(ctx, outputs, samplelog),
        )
        PayloadCommands(self.payloads, ctx.clock).register(commands)
        register_mission_checks()

    def status_builders(self) -> dict[int, StatusBuilder]:
        """The payloads' status messages (USV_LAUNCHER_STATUS, USV_SAMPLER_STATUS) by message id."""
        from mavlink_dialect import usv

        payloads = self.payloads
        return {usv.MAVLINK_MSG_ID_USV_LAUNCHER_STATUS: lambda ms: launcher_status_message(payloads, ms),
                usv.MAVLINK_MSG_ID_USV_SAMPLER_STATUS: lambda ms: sampler_status_message(payloads, ms)}

    async def stop(self) -> None:
        job = self.payloads.sampler.active
        self.payloads.sampler.stop_pump("companion stopping")
        if job is not None and job.task is not None:
            with contextlib.suppress(BaseException):
                await job.task
        self.payloads.launcher.make_safe("companion stopping")
        self.payloads.outputs.set(launcher_trigger=False, pump_on=False, valve_bottle=0)
        self.payloads.samplelog.close()
