"""A bilge pump payload, as a test fixture: proof that a payload is one module.

It declares one parameter (its output channel), one command (``USV_CMD_BILGE_PUMP``, 31020:
param1 1 on / 0 off), one servo channel (``USV_CH_BILGE``, default output 2, the boat's free
auxiliary output), one sentence of the GPS-INS box (``$PUSVB,LEVEL_CM``: the bilge water level)
and the dialect entry of its command as an XML fragment, so neither the shipped dialect nor any
other file of the companion is edited.  It is added to a vehicle with
``SitlHarness(extra_payloads=[PAYLOAD])`` (or ``build_context``/``build_companion``).
"""

from __future__ import annotations

import math

from companion.mavlink.commands import CommandRequest, CommandResult
from companion.params import ParamDef
from companion.payloads.registry import (
    DialectEntries,
    Payload,
    PayloadCommandDecl,
    PayloadDef,
    PayloadEnv,
    ServoChannel,
)

CMD_BILGE_PUMP = 31020

PARAMS = (ParamDef("USV_CH_BILGE", 2, 1, 8, "", "Servo output channel (1-8) of the bilge pump relay.",
                   is_int=True),)

DIALECT_XML = """<mavlink>
  <enums>
    <enum name="USV_CMD">
      <entry value="31020" name="USV_CMD_BILGE_PUMP">
        <description>Immediate: switch the bilge pump on or off.</description>
        <param index="1" label="On" minValue="0" maxValue="1" increment="1">1: pump on, 0: pump off.</param>
      </entry>
    </enum>
  </enums>
</mavlink>"""


class BilgePump:
    """On/off and the last water level reported by the box."""

    def __init__(self) -> None:
        self.on = False
        self.level_cm: float | None = None

    async def command(self, cmd: CommandRequest) -> CommandResult:
        if cmd.param1 not in (0.0, 1.0):
            return CommandResult.denied(f"bilge pump: param1 must be 1 (on) or 0 (off), got {cmd.param1:g}")
        self.on = cmd.param1 == 1.0
        return CommandResult.accepted("bilge pump: " + ("on" if self.on else "off"))

    def level_sentence(self, fields: list[str]) -> None:
        level = float(fields[1])
        if not math.isfinite(level):
            raise ValueError("bilge level")
        self.level_cm = level


def build(env: PayloadEnv) -> Payload:
    pump = BilgePump()
    params = env.ctx.params

    def pulse_us() -> int:
        return params.get_int("USV_SW_PWM_ON" if pump.on else "USV_SW_PWM_OFF")

    async def stop() -> None:
        pump.on = False

    return Payload(
        name="bilge_pump", device=pump,
        commands=(PayloadCommandDecl(CMD_BILGE_PUMP, pump.command, "USV_BILGE_PUMP", (1,)),),
        servo_channels=(ServoChannel("USV_CH_BILGE", 2, "bilge pump", pulse_us),),
        sentences={"PUSVB": pump.level_sentence},
        dialect=DialectEntries(commands={CMD_BILGE_PUMP: "USV_CMD_BILGE_PUMP"}, xml=DIALECT_XML),
        stop=stop)


PAYLOAD = PayloadDef("bilge_pump", PARAMS, build)
