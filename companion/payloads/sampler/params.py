"""Parameters of the water sampler (``USV_SMPL_*``)."""

from __future__ import annotations

from companion.params import ParamDef

PARAMS: tuple[ParamDef, ...] = (
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
