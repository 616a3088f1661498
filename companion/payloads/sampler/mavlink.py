"""The water sampler on MAVLink: USV_CMD_SAMPLE / _PUMP_STOP / _SAMPLER_RESET and USV_SAMPLER_STATUS.

Every refusal is ``DENIED`` with the sampler's reason; a sample answers ``IN_PROGRESS``
(progress = percent filled) until its final result (ACCEPTED, FAILED or CANCELLED).
"""

from __future__ import annotations

import math
from typing import Any

from companion.clock import Clock
from companion.mavlink.commands import MAV_RESULT, CommandRequest, CommandResult
from companion.payloads.sampler.device import SampleJob, SampleRequest, WaterSampler

PROGRESS_PERIOD_S = 1.0


def _opt(x: float) -> float | None:
    """0 or NaN mean "use the default"."""
    return None if not math.isfinite(x) or x == 0 else float(x)


def _deg_e7(x: float | None) -> int:
    return 0 if x is None or not math.isfinite(x) else round(x * 1e7)


class SamplerCommands:
    """Command handlers bound to one sampler."""

    def __init__(self, sampler: WaterSampler, clock: Clock) -> None:
        self.sampler = sampler
        self.clock = clock

    async def sample(self, cmd: CommandRequest) -> CommandResult:
        """param1 bottle (0: next empty), param2 fill time s, param3 volume mL (0: defaults)."""
        bottle = 0 if not math.isfinite(cmd.param1) else cmd.param1
        if bottle != int(bottle):
            return CommandResult.denied(f"sampler: bottle {bottle:g} is not a whole number")
        job = self.sampler.start(SampleRequest(bottle=int(bottle), fill_s=_opt(cmd.param2),
                                               volume_ml=_opt(cmd.param3)))
        if isinstance(job, str):
            return CommandResult.denied(job)
        return await self._follow(cmd, job)

    async def _follow(self, cmd: CommandRequest, job: SampleJob) -> CommandResult:
        last = -1
        while not job.done.done():
            if job.progress_pct != last:
                last = job.progress_pct
                cmd.progress(last)
            await self.clock.sleep(PROGRESS_PERIOD_S)
        record = job.done.result()
        if job.status == "complete":
            volume = f" {record.volume_ml:.0f} mL" if record is not None else ""
            return CommandResult.accepted(f"sampler: bottle {job.bottle} full{volume}")
        if job.status == "aborted":
            return CommandResult(MAV_RESULT.CANCELLED, job.reason or "sampler: aborted")
        return CommandResult.failed(job.reason or f"sampler: bottle {job.bottle} {job.status}")

    async def pump_stop(self, cmd: CommandRequest) -> CommandResult:
        was_running = self.sampler.stop_pump()
        return CommandResult.accepted("sampler: pump stopped" + (", sample aborted" if was_running else ""))

    async def reset(self, cmd: CommandRequest) -> CommandResult:
        """param1 bottle emptied by the crew (0: all)."""
        bottle = 0 if not math.isfinite(cmd.param1) else cmd.param1
        if bottle != int(bottle):
            return CommandResult.denied(f"sampler: bottle {bottle:g} is not a whole number")
        reason = self.sampler.reset(int(bottle))
        if reason is not None:
            return CommandResult.denied(reason)
        return CommandResult.accepted(
            "sampler: all bottles empty" if bottle == 0 else f"sampler: bottle {bottle:g} empty"
        )


def sampler_status_message(sampler: WaterSampler, time_boot_ms: int) -> Any:
    """USV_SAMPLER_STATUS (dialect id 43001)."""
    from mavlink_dialect import usv

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
