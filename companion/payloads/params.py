"""Parameters of the rope launcher (``USV_LNCH_*``) and the water sampler (``USV_SMPL_*``)."""

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
    ParamDef("USV_SMPL_FILL_S", 20.0, 1.0, 600.0, "s", "Default pump time of one water sample."),
    ParamDef(
        "USV_SMPL_FLOW",
        25.0,
        1.0,
        1000.0,
        "mL/s",
        "Pump flow used to estimate the volume when no bottle level sensor reports it.",
    ),
    ParamDef("USV_SMPL_BTL_ML", 500.0, 10.0, 5000.0, "mL", "Capacity of one sampling bottle."),
    ParamDef(
        "USV_SMPL_TMO_S",
        60.0,
        5.0,
        1800.0,
        "s",
        "A sample that has not reached its volume/time after this long is stopped and marked failed.",
    ),
    ParamDef(
        "USV_SMPL_CIRC_M",
        1.5,
        0.5,
        50.0,
        "m",
        "Mission sample-here: default circle radius around the sampling point.",
    ),
    ParamDef(
        "USV_SMPL_ACC_M",
        2.5,
        0.5,
        50.0,
        "m",
        "Mission sample-here: the sample is taken only inside this radius (chapter 4.2: 2.5 m).",
    ),
)
