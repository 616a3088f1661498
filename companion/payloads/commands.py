"""MAVLink command handlers of the payloads (dialect ``USV_CMD``, MAV_CMD user range 31010-31014).

:class:`PayloadCommands` holds the handlers of one vehicle's payloads; they are registered on
the vehicle's command registry (:mod:`companion.runtime`).  Every refusal is ``DENIED`` with a
reason the command service turns into a STATUSTEXT; a sample answers ``IN_PROGRESS``
(progress = percent filled) until its final result.
"""

from __future__ import annotations

import math

from companion.clock import Clock
from companion.mavlink.commands import MAV_RESULT, CommandRegistry, CommandRequest, CommandResult
from companion.payloads.registry import Payloads
from companion.payloads.sampler import SampleJob, SampleRequest
from mavlink_dialect import UsvCmd

PROGRESS_PERIOD_S = 1.0


def _opt(x: float) -> float | None:
    """0 or NaN mean "use the default"."""
    return None if not math.isfinite(x) or x == 0 else float(x)


class PayloadCommands:
    """The MAVLink command handlers of one vehicle's launcher and sampler."""

    def __init__(self, payloads: Payloads, clock: Clock) -> None:
        self.payloads = payloads
        self.clock = clock

    async def launcher_arm(self, cmd: CommandRequest) -> CommandResult:
        payloads = self.payloads
        if cmd.param1 == 0:
            payloads.launcher.make_safe("operator")
            return CommandResult.accepted("launcher: safe")
        if cmd.param1 != 1:
            return CommandResult.denied(f"launcher: param1 must be 1 (arm) or 0 (safe), got {cmd.param1:g}")
        reason = payloads.launcher.arm(_opt(cmd.param2))
        if reason is not None:
            return CommandResult.denied(reason)
        return CommandResult.accepted(f"launcher: ARMED for {payloads.launcher.arm_time_left_s():.0f} s")

    async def launcher_fire(self, cmd: CommandRequest) -> CommandResult:
        payloads = self.payloads
        reason = await payloads.launcher.fire()
        if reason is not None:
            return CommandResult.denied(reason)
        last = payloads.launcher.last_launch
        heading = f" hdg {last.heading_deg:.0f}" if last and last.heading_deg is not None else ""
        return CommandResult.accepted(f"launcher: FIRED{heading}")

    async def sample(self, cmd: CommandRequest) -> CommandResult:
        payloads = self.payloads
        bottle = 0 if not math.isfinite(cmd.param1) else cmd.param1
        if bottle != int(bottle):
            return CommandResult.denied(f"sampler: bottle {bottle:g} is not a whole number")
        job = payloads.sampler.start(
            SampleRequest(bottle=int(bottle), fill_s=_opt(cmd.param2), volume_ml=_opt(cmd.param3))
        )
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
        was_running = self.payloads.sampler.stop_pump()
        return CommandResult.accepted("sampler: pump stopped" + (", sample aborted" if was_running else ""))

    async def sampler_reset(self, cmd: CommandRequest) -> CommandResult:
        bottle = 0 if not math.isfinite(cmd.param1) else cmd.param1
        if bottle != int(bottle):
            return CommandResult.denied(f"sampler: bottle {bottle:g} is not a whole number")
        reason = self.payloads.sampler.reset(int(bottle))
        if reason is not None:
            return CommandResult.denied(reason)
        return CommandResult.accepted(
            "sampler: all bottles empty" if bottle == 0 else f"sampler: bottle {bottle:g} empty"
        )

    def register(self, registry: CommandRegistry) -> None:
        """Register the immediate payload commands on ``registry``."""
        r = registry.register
        r(UsvCmd.LAUNCHER_ARM, self.launcher_arm, required_params=(1,), name="USV_LAUNCHER_ARM")
        r(UsvCmd.LAUNCHER_FIRE, self.launcher_fire, name="USV_LAUNCHER_FIRE")
        r(UsvCmd.SAMPLE, self.sample, name="USV_SAMPLE")
        r(UsvCmd.PUMP_STOP, self.pump_stop, name="USV_PUMP_STOP")
        r(UsvCmd.SAMPLER_RESET, self.sampler_reset, name="USV_SAMPLER_RESET")
