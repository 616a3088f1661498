"""The pneumatic rope launcher as a payload (chapter section 4.1).

Declares its parameters (``USV_LNCH_*``) and, in :func:`build`, its commands (arm, fire), its
mission item (fire at a point), its servo output (the trigger, ``USV_CH_LAUNCHER``), its status
message (USV_LAUNCHER_STATUS) and their dialect entries.  The device and its interlocks are in
:mod:`.device`, the mission item in :mod:`.mission`, the MAVLink side in :mod:`.mavlink`
(imported when a vehicle is built: reading the parameter table stays light).
"""

from __future__ import annotations

from companion.payloads.launcher.device import Interlock, LauncherState, RopeLauncher
from companion.payloads.launcher.params import PARAMS
from companion.payloads.registry import Payload, PayloadDef, PayloadEnv

__all__ = ["PARAMS", "PAYLOAD", "Interlock", "LauncherState", "RopeLauncher", "build"]


def build(env: PayloadEnv) -> Payload:
    """The launcher of one vehicle and everything it declares."""
    from functools import partial

    from companion.mission.items import MissionItem
    from companion.modes.auto_items import AutoRun, MissionAction
    from companion.payloads.launcher.mavlink import LauncherCommands, launcher_status_message
    from companion.payloads.launcher.mission import LaunchAtItem, check_launch_at
    from companion.payloads.registry import (
        DialectEntries,
        PayloadCommandDecl,
        ServoChannel,
        StatusMessage,
    )
    from mavlink_dialect import UsvCmd, usv

    status_msg_id = usv.MAVLINK_MSG_ID_USV_LAUNCHER_STATUS

    dialect = DialectEntries(
        commands={UsvCmd.NAV_LAUNCH_AT: "USV_CMD_NAV_LAUNCH_AT", UsvCmd.LAUNCHER_ARM: "USV_CMD_LAUNCHER_ARM",
                  UsvCmd.LAUNCHER_FIRE: "USV_CMD_LAUNCHER_FIRE"},
        messages={status_msg_id: "USV_LAUNCHER_STATUS"})
    launcher = RopeLauncher(env.ctx, env.outputs, env.samplelog)
    params, outputs = env.ctx.params, env.outputs
    commands = LauncherCommands(launcher)

    def trigger_pulse_us() -> int:
        wish = outputs.current
        return wish.trigger_pulse_us if wish.launcher_trigger else launcher.safe_pulse_us()

    def launch_at(run: AutoRun, item: MissionItem) -> LaunchAtItem:
        return LaunchAtItem(run, item, launcher, env)

    async def stop() -> None:
        launcher.make_safe("companion stopping")
        outputs.set(launcher_trigger=False)

    return Payload(
        name="launcher", device=launcher,
        commands=(PayloadCommandDecl(UsvCmd.LAUNCHER_ARM, commands.arm, "USV_LAUNCHER_ARM", (1,)),
                  PayloadCommandDecl(UsvCmd.LAUNCHER_FIRE, commands.fire, "USV_LAUNCHER_FIRE")),
        mission_actions=(MissionAction(UsvCmd.NAV_LAUNCH_AT, launch_at, check=check_launch_at),),
        servo_channels=(ServoChannel("USV_CH_LAUNCHER", 7, "launcher trigger", trigger_pulse_us),),
        status=(StatusMessage(status_msg_id, partial(launcher_status_message, launcher, params)),),
        dialect=dialect, stop=stop)


PAYLOAD = PayloadDef("launcher", PARAMS, build)
