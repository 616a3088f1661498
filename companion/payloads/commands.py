"""MAVLink command handlers of the payloads (dialect ``USV_CMD``, MAV_CMD user range 31010-31014).

Registered per vehicle by :class:`~companion.payloads.service.PayloadService` through
:func:`companion.mavlink.commands.register_command`.  Every refusal is ``DENIED`` with a
reason the command service turns into a STATUSTEXT; a sample answers ``IN_PROGRESS``
(progress = percent filled) until its final result.
"""

from __future__ import annotations

import math

from companion.app import Context
from companion.mavlink.commands import MAV_RESULT, CommandRequest, CommandResult, register_command
from companion.payloads.registry import payloads_of
from companion.payloads.sampler import SampleJob, SampleRequest
from mavlink_dialect import UsvCmd

PROGRESS_PERIOD_S = 1.0


def _opt(x: float) -> float | None:
    """0 or NaN mean "use the default"."""
    return None if not math.isfinite(x) or x == 0 else float(x)


async def launcher_arm(ctx: Context, cmd: CommandRequest) -> CommandResult:
    payloads = payloads_of(ctx)
    if cmd.param1 == 0:
        payloads.launcher.make_safe("operator")
        return CommandResult.accepted("launcher: safe")
    if cmd.param1 != 1:
        return CommandResult.denied(f"launcher: param1 must be 1 (arm) or 0 (safe), got {cmd.param1:g}")
    reason = payloads.launcher.arm(_opt(cmd.param2))
    if reason is not None:
        return CommandResult.denied(reason)
    return CommandResult.accepted(f"launcher: ARMED for {payloads.launcher.arm_time_left_s():.0f} s")


async def launcher_fire(ctx: Context, cmd: CommandRequest) -> CommandResult:
    payloads = payloads_of(ctx)
    reason = await payloads.launcher.fire()
    if reason is not None:
        return CommandResult.denied(reason)
    last = payloads.launcher.last_launch
    heading = f" hdg {last.heading_deg:.0f}" if last and last.heading_deg is not None else ""
    return CommandResult.accepted(f"launcher: FIRED{heading}")


async def sample(ctx: Context, cmd: CommandRequest) -> CommandResult:
    payloads = payloads_of(ctx)
    bottle = 0 if not math.isfinite(cmd.param1) else cmd.param1
    if bottle != int(bottle):
        return CommandResult.denied(f"sampler: bottle {bottle:g} is not a whole number")
    job = payloads.sampler.start(
        SampleRequest(bottle=int(bottle), fill_s=_opt(cmd.param2), volume_ml=_opt(cmd.param3))
    )
    if isinstance(job, str):
        return CommandResult.denied(job)
    return await _follow(ctx, cmd, job)


async def _follow(ctx: Context, cmd: CommandRequest, job: SampleJob) -> CommandResult:
    last = -1
    while not job.done.done():
        if job.progress_pct != last:
            last = job.progress_pct
            cmd.progress(last)
        await ctx.clock.sleep(PROGRESS_PERIOD_S)
    record = job.done.result()
    if job.status == "complete":
        volume = f" {record.volume_ml:.0f} mL" if record is not None else ""
        return CommandResult.accepted(f"sampler: bottle {job.bottle} full{volume}")
    if job.status == "aborted":
        return CommandResult(MAV_RESULT.CANCELLED, job.reason or "sampler: aborted")
    return CommandResult.failed(job.reason or f"sampler: bottle {job.bottle} {job.status}")


async def pump_stop(ctx: Context, cmd: CommandRequest) -> CommandResult:
    was_running = payloads_of(ctx).sampler.stop_pump()
    return CommandResult.accepted("sampler: pump stopped" + (", sample aborted" if was_running else ""))


async def sampler_reset(ctx: Context, cmd: CommandRequest) -> CommandResult:
    bottle = 0 if not math.isfinite(cmd.param1) else cmd.param1
    if bottle != int(bottle):
        return CommandResult.denied(f"sampler: bottle {bottle:g} is not a whole number")
    reason = payloads_of(ctx).sampler.reset(int(bottle))
    if reason is not None:
        return CommandResult.denied(reason)
    return CommandResult.accepted(
        "sampler: all bottles empty" if bottle == 0 else f"sampler: bottle {bottle:g} empty"
    )


def register_payload_commands(ctx: Context) -> None:
    """Register the immediate payload commands on this vehicle's command registry."""
    register_command(
        UsvCmd.LAUNCHER_ARM, launcher_arm, required_params=(1,), name="USV_LAUNCHER_ARM", ctx=ctx
    )
    register_command(UsvCmd.LAUNCHER_FIRE, launcher_fire, name="USV_LAUNCHER_FIRE", ctx=ctx)
    register_command(UsvCmd.SAMPLE, sample, name="USV_SAMPLE", ctx=ctx)
    register_command(UsvCmd.PUMP_STOP, pump_stop, name="USV_PUMP_STOP", ctx=ctx)
    register_command(UsvCmd.SAMPLER_RESET, sampler_reset, name="USV_SAMPLER_RESET", ctx=ctx)
