"""Parameters of the rope launcher (``USV_LNCH_*``)."""

from __future__ import annotations

from companion.params import ParamDef

PARAMS: tuple[ParamDef, ...] = (
    ParamDef(
        "USV_LNCH_ARM_S",
        30.0,
        2.0,
        600.0,
        "s",
        "Rope launcher arming window: FIRE is accepted only this long after ARM (two-step arm-then-fire).",
    ),
    ParamDef(
        "USV_LNCH_MIN_MPA",
        20.0,
        0.0,
        35.0,
        "MPa",
        "Minimum cylinder pressure to arm or fire (the cylinder is filled to 30 MPa, chapter 4.1).",
    ),
    ParamDef(
        "USV_LNCH_PWM_US", 1900, 800, 2200, "us", "Trigger servo pulse width while firing.", is_int=True
    ),
    ParamDef("USV_LNCH_SAFE_US", 1100, 800, 2200, "us", "Trigger servo pulse width when safe.", is_int=True),
    ParamDef("USV_LNCH_PULSE_S", 0.5, 0.05, 5.0, "s", "How long the trigger servo holds the firing pulse."),
    ParamDef(
        "USV_LNCH_SHOTS",
        1,
        0,
        4,
        "",
        "Shots loaded in the launcher; setting it (after reloading) resets the shot counter.",
        is_int=True,
    ),
    ParamDef(
        "USV_LNCH_HOLD_S",
        3.0,
        0.0,
        60.0,
        "s",
        "Mission fire-at-point: time to hold still on the launch bearing before firing.",
    ),
    ParamDef(
        "USV_LNCH_HDG_DEG",
        10.0,
        1.0,
        45.0,
        "deg",
        "Mission fire-at-point: heading tolerance around the launch bearing for firing.",
    ),
)
