"""The active-model speed row (companion.control.am_speed): unit behaviour and closed loop on the plant.

Closed-loop tests use the real simulated plant, UKF and actuator mapping through the control rig
of ``usv bench control``; the speed figures in waves are in ``usv bench control``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from benchmarks.control_ident import shipped_model
from benchmarks.control_rig import Environment, Rig
from benchmarks.control_scenarios import speed_wave_floor
from companion.control.am_speed import AmSpeedConfig, AmSpeedLaw, SecondOrderLowPass
from companion.control.params import CTRL_ACTIVE_MODEL, CTRL_PID
from companion.control.target import ControlTarget
from companion.messages import NavState
from tests.control.test_control_blocks import toy_model

DT_S = 0.01


def nav_at(t_s: float, u_mps: float) -> NavState:
    return NavState(t_s=t_s, lat_deg=0.0, lon_deg=0.0, alt_m=0.0, heading_rad=0.0, roll_rad=0.0,
                    pitch_rad=0.0, vel_north_mps=u_mps, vel_east_mps=0.0, u_mps=u_mps, v_mps=0.0, r_radps=0.0)


def sine_gain(f: SecondOrderLowPass, w_radps: float) -> float:
    out = [f.step(math.sin(w_radps * k * DT_S), DT_S) for k in range(int(40.0 / DT_S))]
    return max(abs(x) for x in out[len(out) // 2:])


def test_delta_nu_filter_passes_gusts_and_blocks_the_wave_encounter_band() -> None:
    """Wave filtering of delta_nu_u: a gust-like 0.3 rad/s change passes, the 1.2 Hz wave
    encounter motion (7.5 rad/s) is more than halved and the 1.6 Hz end of the band (10 rad/s) cut
    to a quarter, a step settles without a lasting offset."""
    cut = AmSpeedConfig().dnu_cutoff_radps
    assert sine_gain(SecondOrderLowPass(cut), 0.3) > 0.98
    assert sine_gain(SecondOrderLowPass(cut), 7.5) < 0.45
    assert sine_gain(SecondOrderLowPass(cut), 10.0) < 0.26
    step = SecondOrderLowPass(cut)
    for _ in range(int(10.0 / DT_S)):
        step.step(1.0, DT_S)
    assert step.value == pytest.approx(1.0, abs=1e-3)


def test_speed_law_inverts_the_surge_row() -> None:
    """Plant == model, no model error: the thrust demand gives exactly u_dot = k_u (u_d - u)."""
    model = toy_model()
    law = AmSpeedLaw(model)
    nu = np.array([3.0, 0.0, 0.0])
    w = law.thrust_demand(nav_at(0.0, 3.0), 4.0, 0.0, DT_S)
    u_dot = float(model.a_of_nu(nu)[0] @ nu) + float(model.b_matrix()[0, 1]) * w
    assert u_dot == pytest.approx(law.cfg.k_per_s * 1.0, rel=1e-9)


def test_speed_law_cancels_a_steady_model_error() -> None:
    """A steady surge disturbance of -0.3 m/s^2 (a head wind the model does not know) is met with
    exactly the extra thrust that cancels it once the filter has settled."""
    model = toy_model()
    plain, compensated = AmSpeedLaw(model), AmSpeedLaw(model)
    b_u = float(model.b_matrix()[0, 1])
    for k in range(int(5.0 / DT_S)):
        w0 = plain.thrust_demand(nav_at(k * DT_S, 3.0), 3.0, 0.0, DT_S)
        w1 = compensated.thrust_demand(nav_at(k * DT_S, 3.0), 3.0, -0.3, DT_S)
    assert w1 - w0 == pytest.approx(0.3 / b_u, rel=1e-3)


def test_speed_law_survives_bad_numbers() -> None:
    """NaN speed command or NaN model error: a finite demand, no exception, estimate kept."""
    law = AmSpeedLaw(toy_model())
    for k in range(100):
        law.thrust_demand(nav_at(k * DT_S, 3.0), 3.0, -0.2, DT_S)
    held = law.thrust_demand(nav_at(1.0, 3.0), math.nan, math.nan, DT_S)
    assert math.isfinite(held) and held > 0.0
    with pytest.raises(ValueError, match="speed settings"):
        AmSpeedConfig(dnu_cutoff_radps=0.0)


def test_reference_model_shapes_a_speed_step_without_overshoot() -> None:
    """With the optional reference model, the desired speed rises monotonically to the command."""
    law = AmSpeedLaw(toy_model(), AmSpeedConfig(ref_radps=1.0))
    law.accel_demand(nav_at(0.0, 2.0), 2.0, DT_S)
    refs = []
    for k in range(1, int(15.0 / DT_S)):
        law.accel_demand(nav_at(k * DT_S, 2.0), 6.0, DT_S)
        assert law.reference_mps is not None
        refs.append(law.reference_mps)
    assert all(b >= a for a, b in itertools.pairwise(refs))
    assert refs[-1] == pytest.approx(6.0, abs=0.01) and max(refs) <= 6.0 + 1e-9
    assert refs[int(1.0 / DT_S)] < 4.0  # shaped, not a jump


def gusty_speed_rms(ctrl_type: int, seed: int) -> float:
    """5 m/s into an 8 m/s gusty wind 20 degrees off the bow, calm water: surge speed RMS error."""
    rig = Rig(ctrl_type, Environment(seed=seed, wind_mps=8.0, wind_from_deg=20.0), shipped_model())
    target = ControlTarget(0.0, 5.0, is_heading=True)
    for _ in range(int(20.0 / DT_S)):
        rig.step(target)
    err = [rig.step(target).u_mps - 5.0 for _ in range(int(40.0 / DT_S))]
    return float(np.sqrt(np.mean(np.square(err))))


@pytest.mark.parametrize("seed", [1, 2])
def test_active_model_holds_speed_in_gusts_better_than_pid(seed: int) -> None:
    """The UKF's delta_nu_u sees a gust's drag as it builds up and the law cancels it; the PID
    integrator only reacts after the speed has sagged.  Same plant, wind and seed."""
    am = gusty_speed_rms(CTRL_ACTIVE_MODEL, seed)
    pid = gusty_speed_rms(CTRL_PID, seed)
    assert am < 0.9 * pid, (am, pid)


def test_no_speed_controller_can_cancel_the_wave_surge_motion() -> None:
    """Why the speed figures in waves are close to a tie: even an oracle that knows the wave surge
    force ahead and inverts the 0.4 s engine lag removes little of the surge motion within the
    throttle range and slew rate."""
    floor = speed_wave_floor(shipped_model(), seed=1, quick=True)
    assert floor["surge_rms_mps"] > 0.02
    assert floor["oracle_rms_mps"] > 0.8 * floor["surge_rms_mps"]
    assert floor["throttle_at_6mps"] > 0.8  # little headroom above the operating point


