"""The estimator stage publishes ModelError on the bus from NavState + ActuatorCommand."""

from __future__ import annotations

import math
from pathlib import Path

from companion.app import Context
from companion.bus import Bus
from companion.clock import SimClock
from companion.config import default_config
from companion.estimation.service import make_estimator_stage
from companion.messages import ActuatorCommand, ModelError, NavState
from companion.param_table import all_param_defs
from companion.params import ParamStore


def _nav(t: float, u: float) -> NavState:
    return NavState(t, 41.0, 123.0, 0.0, 0.0, 0.0, 0.0, u, 0.0, u, 0.0, 0.0)


def test_stage_publishes_model_error(tmp_path: Path) -> None:
    cfg = default_config().with_overrides({"vehicle.state_dir": str(tmp_path)})
    ctx = Context(cfg, SimClock(), Bus(), ParamStore(all_param_defs()))
    stage = make_estimator_stage(ctx)
    ctx.bus.topic("actuator_cmd", ActuatorCommand).publish(ActuatorCommand(0.0, 0.0, 0.0))
    out = ctx.bus.topic("model_error", ModelError)
    for k in range(300):  # boat drifting at constant 1 m/s with zero thrust: the model must decelerate
        stage(_nav(0.01 * k, 1.0))
    stage(_nav(float("nan"), 1.0))  # ignored, not raised
    err = out.latest()
    assert err is not None and out.seq == 300
    assert err.delta_nu[0] > 0.05  # the UKF explains the missing deceleration as model error
    assert all(math.isfinite(x) for x in err.delta_nu_var)
