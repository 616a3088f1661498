"""Parameters of the servo outputs: channel map, pulse limits and the nozzle limit."""

from __future__ import annotations

from companion.params import ParamDef


def _ch(name: str, default: int, what: str) -> ParamDef:
    return ParamDef(name, default, 1, 8, "", f"Servo output channel (1-8) of the {what}.", is_int=True)


PARAMS: tuple[ParamDef, ...] = (
    _ch("USV_CH_NOZZLE", 1, "nozzle (steering) servo"),
    _ch("USV_CH_THROTTLE", 3, "engine throttle servo"),
    _ch("USV_CH_VALVE", 4, "sampler bottle valve (1000 us closed, 1200/1400/1600/1800 us = bottle 1-4)"),
    _ch("USV_CH_IGNITION", 5, "ignition/flame servo"),
    _ch("USV_CH_SELECTOR", 6, "RC/GCS selector switch servo"),
    _ch("USV_CH_LAUNCHER", 7, "rope launcher trigger servo"),
    _ch("USV_CH_PUMP", 8, "sampler pump relay"),
    ParamDef("USV_NOZ_PWM_MIN", 1100, 800, 2200, "us", "Nozzle pulse at full port deflection.", is_int=True),
    ParamDef("USV_NOZ_PWM_MAX", 1900, 800, 2200, "us", "Nozzle pulse at full starboard deflection.",
             is_int=True),
    ParamDef("USV_NOZ_PWM_TRIM", 1500, 800, 2200, "us", "Nozzle pulse for the centred nozzle.", is_int=True),
    ParamDef("USV_NOZ_MAX_DEG", 60, 5, 90, "deg",
             "Nozzle deflection at USV_NOZ_PWM_MIN/MAX; commands beyond it saturate (chapter: pi/3)."),
    ParamDef("USV_NOZ_REV", 0, 0, 1, "", "Reverse the nozzle servo direction.", is_int=True,
             choices=((0, "Normal"), (1, "Reversed"))),
    ParamDef("USV_THR_PWM_MIN", 1100, 800, 2200, "us", "Throttle pulse at idle (throttle 0).", is_int=True),
    ParamDef("USV_THR_PWM_MAX", 1900, 800, 2200, "us", "Throttle pulse at full throttle.", is_int=True),
    ParamDef("USV_SW_PWM_OFF", 1100, 800, 2200, "us",
             "Pulse of on/off servos when off (ignition off, selector on RC, pump off).", is_int=True),
    ParamDef("USV_SW_PWM_ON", 1900, 800, 2200, "us",
             "Pulse of on/off servos when on (ignition on, selector on companion, pump on).", is_int=True),
    ParamDef("USV_NAV_TMO_S", 0.5, 0.05, 10.0, "s",
             "Without a GPS-INS sample for this long, the servo frame is still refreshed at 10 Hz."),
    *(ParamDef(f"USV_RLY{n}_CH", 2 if n == 0 else 0, 0, 8, "",
               f"Output channel (1-8) driven by relay {n} (MAV_CMD_DO_SET_RELAY; USV_SW_PWM_ON/OFF); "
               "0 = not wired. Autopilot-owned channels are refused.", is_int=True) for n in range(4)),
)
