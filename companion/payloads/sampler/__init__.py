"""The four-bottle water sampler as a payload (chapter section 4.2).

Declares its parameters (``USV_SMPL_*``) and, in :func:`build`, its commands (sample, pump stop,
reset), its mission item (sample here), its servo outputs (the pump ``USV_CH_PUMP`` and the
bottle valve ``USV_CH_VALVE``), its status message (USV_SAMPLER_STATUS) and their dialect
entries.  The device is in :mod:`.device`, the mission item in :mod:`.mission`, the MAVLink side
in :mod:`.mavlink` (imported when a vehicle is built: reading the parameter table stays light).
"""

from __future__ import annotations

from companion.messages import BOTTLE_COUNT
from companion.payloads.registry import Payload, PayloadDef, PayloadEnv
from companion.payloads.sampler.device import BottleState, SampleJob, SampleRequest, WaterSampler
from companion.payloads.sampler.params import PARAMS

__all__ = ["PARAMS", "PAYLOAD", "BottleState", "SampleJob", "SampleRequest", "WaterSampler", "build"]

VALVE_CLOSED_US, VALVE_STEP_US = 1000, 200
"""Valve servo: 1000 us all closed, 1200/1400/1600/1800 us = bottle 1-4."""


def build(env: PayloadEnv) -> Payload:
    """The sampler of one vehicle and everything it declares."""
    import contextlib
    from functools import partial

    from companion.mission.items import MissionItem
    from companion.modes.auto_items import AutoRun, MissionAction
    from companion.payloads.registry import DialectEntries, PayloadCommandDecl, ServoChannel, StatusMessage
    from companion.payloads.sampler.mavlink import SamplerCommands, sampler_status_message
    from companion.payloads.sampler.mission import SampleHereItem, check_sample_here
    from mavlink_dialect import UsvCmd, usv

    status_msg_id = usv.MAVLINK_MSG_ID_USV_SAMPLER_STATUS

    dialect = DialectEntries(
        commands={UsvCmd.NAV_SAMPLE_HERE: "USV_CMD_NAV_SAMPLE_HERE", UsvCmd.SAMPLE: "USV_CMD_SAMPLE",
                  UsvCmd.PUMP_STOP: "USV_CMD_PUMP_STOP", UsvCmd.SAMPLER_RESET: "USV_CMD_SAMPLER_RESET"},
        messages={status_msg_id: "USV_SAMPLER_STATUS"})
    sampler = WaterSampler(env.ctx, env.outputs, env.samplelog)
    params, outputs = env.ctx.params, env.outputs
    commands = SamplerCommands(sampler, env.ctx.clock)

    def pump_pulse_us() -> int:
        return round(params.get_or("USV_SW_PWM_ON" if outputs.current.pump_on else "USV_SW_PWM_OFF", 1500))

    def valve_pulse_us() -> int:
        wish = outputs.current
        bottle = max(0, min(BOTTLE_COUNT, wish.valve_bottle)) if wish.pump_on else 0
        return VALVE_CLOSED_US + VALVE_STEP_US * bottle

    def sample_here(run: AutoRun, item: MissionItem) -> SampleHereItem:
        return SampleHereItem(run, item, sampler, env)

    async def stop() -> None:
        job = sampler.active
        sampler.stop_pump("companion stopping")
        if job is not None and job.task is not None:
            with contextlib.suppress(BaseException):
                await job.task
        outputs.set(pump_on=False, valve_bottle=0)

    return Payload(
        name="sampler", device=sampler,
        commands=(PayloadCommandDecl(UsvCmd.SAMPLE, commands.sample, "USV_SAMPLE"),
                  PayloadCommandDecl(UsvCmd.PUMP_STOP, commands.pump_stop, "USV_PUMP_STOP"),
                  PayloadCommandDecl(UsvCmd.SAMPLER_RESET, commands.reset, "USV_SAMPLER_RESET")),
        mission_actions=(MissionAction(UsvCmd.NAV_SAMPLE_HERE, sample_here, check=check_sample_here),),
        servo_channels=(ServoChannel("USV_CH_PUMP", 8, "sampler pump", pump_pulse_us),
                        ServoChannel("USV_CH_VALVE", 4, "sampler valve", valve_pulse_us)),
        status=(StatusMessage(status_msg_id, partial(sampler_status_message, sampler)),),
        dialect=dialect, stop=stop)


PAYLOAD = PayloadDef("sampler", PARAMS, build)
