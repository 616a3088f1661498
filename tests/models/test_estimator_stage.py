"""The estimator stage publishes ModelError (and with the current filter, CurrentEstimate) on
the bus from NavState + ActuatorCommand."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

import pytest

from companion.app import Context
from companion.bus import Bus
from companion.clock import SimClock
from companion.config import default_config
from companion.estimation.service import make_estimator_stage
from companion.messages import ActuatorCommand, CurrentEstimate, ModelError, NavState
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


def _stage_ctx(tmp_path: Path, **settings: str) -> Context:
    cfg = default_config().with_overrides({"vehicle.state_dir": str(tmp_path), **settings})
    return Context(cfg, SimClock(), Bus(), ParamStore(all_param_defs()))


def test_filterpy_backend_publishes_what_the_native_one_does(tmp_path: Path) -> None:
    outs = []
    for backend in ("native", "filterpy"):
        ctx = _stage_ctx(tmp_path, **{"models.ukf": "current", "models.ukf_backend": backend})
        stage = make_estimator_stage(ctx)
        ctx.bus.topic("actuator_cmd", ActuatorCommand).publish(ActuatorCommand(0.0, 0.2, 0.4))
        for k in range(200):
            nav = _nav(0.01 * k, 1.5 + 0.1 * math.sin(0.1 * k))
            stage(NavState(nav.t_s, 41.0, 123.0, 0.0, 0.02 * k, 0.0, 0.0, 1.5, 0.0, nav.u_mps, 0.05, 0.02))
        err = ctx.bus.topic("model_error", ModelError).latest()
        cur = ctx.bus.topic("water_current", CurrentEstimate).latest()
        assert err is not None and cur is not None
        outs.append((err.delta_nu, (cur.north_mps, cur.east_mps)))
    for a, b in zip(outs[0], outs[1], strict=True):
        assert a == pytest.approx(b, abs=1e-9)


def test_chapter_filter_publishes_no_current(tmp_path: Path) -> None:
    ctx = _stage_ctx(tmp_path)
    stage = make_estimator_stage(ctx)
    for k in range(10):
        stage(_nav(0.01 * k, 1.0))
    assert ctx.bus.topic("model_error", ModelError).latest() is not None
    assert ctx.bus.topic("water_current", CurrentEstimate).latest() is None


def _estimate_in_sitl(current: str, seconds: float = 150.0) -> CurrentEstimate:
    """The shipped default model and the current filter, in lockstep SITL (simulated GPS-INS and
    its parser), the boat driven open loop: 60 % throttle, nozzle sine +-0.4 rad, 20 s period."""
    from sim_bridge.sitl import SitlHarness

    async def run() -> CurrentEstimate:
        cfg = default_config().with_overrides({"models.ukf": "current"})
        async with SitlHarness(seed=3, current=current, config=cfg) as h:
            cmd = h.ctx.bus.topic("actuator_cmd", ActuatorCommand)
            h.loop.add_stage("open-loop", lambda nav: cmd.publish(ActuatorCommand(
                nav.t_s, nozzle_rad=0.4 * math.sin(2 * math.pi * nav.t_s / 20.0), throttle=0.6,
                ignition_on=True)))
            h.loop.add_stage("estimator", make_estimator_stage(h.ctx))
            await h.run_for(seconds)
            est = h.ctx.bus.topic("water_current", CurrentEstimate).latest()
            assert est is not None
            return est

    return asyncio.run(run())


@pytest.mark.slow
def test_current_filter_finds_the_simulated_flood_current() -> None:
    est = _estimate_in_sitl("0.8,120")
    assert est.speed_mps == pytest.approx(0.8, abs=0.1)
    assert abs(math.degrees(est.toward_rad) - 120.0) < 10.0
    assert est.confidence > 0.9 and max(est.north_var_m2ps2, est.east_var_m2ps2) < 0.05**2


@pytest.mark.slow
def test_current_filter_reports_slack_water_as_slack() -> None:
    est = _estimate_in_sitl("0,0")
    assert est.speed_mps < 0.1
