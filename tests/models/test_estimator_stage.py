"""The estimator stage returns the ModelError of a NavState given the ActuatorCommand applied."""

from __future__ import annotations

import math
from pathlib import Path

from companion.config import default_config
from companion.estimation.service import EstimatorStage, load_companion_model, load_companion_ukf_settings
from companion.messages import ActuatorCommand, NavState


def _nav(t: float, u: float) -> NavState:
    return NavState(t, 41.0, 123.0, 0.0, 0.0, 0.0, 0.0, u, 0.0, u, 0.0, 0.0)


def test_stage_returns_the_model_error(tmp_path: Path) -> None:
    cfg = default_config().with_overrides({"vehicle.state_dir": str(tmp_path)})
    stage = EstimatorStage(load_companion_model(cfg), load_companion_ukf_settings(cfg))
    applied = ActuatorCommand(0.0, 0.0, 0.0)
    estimates = [stage.step(_nav(0.01 * k, 1.0), applied) for k in range(300)]
    # boat drifting at constant 1 m/s with zero thrust: the model must decelerate
    assert stage.step(_nav(float("nan"), 1.0), applied) is None  # ignored, not raised
    err = estimates[-1]
    assert err is not None and all(e is not None for e in estimates)
    assert err.delta_nu[0] > 0.05  # the UKF explains the missing deceleration as model error
    assert all(math.isfinite(x) for x in err.delta_nu_var)
