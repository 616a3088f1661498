"""Instrumental variables against least squares on noisy synthetic qLPV data.

The GPS-INS speed noise (0.1 m/s) is of the order of the sway velocity.  Least squares on
smoothed noisy regressors is biased (errors in variables); the instrumental-variable
estimate must be closer to the true boat, and its free run on a manoeuvre it was not
trained on (a zig-zag-like square nozzle) must be better.
"""

from __future__ import annotations

import numpy as np
import pytest

from companion.models.base import error_index
from companion.models.identify import QLPV_DISSIPATIVE, fit_qlpv, refine_instrumental
from companion.models.logs import Record
from tests.models.helpers import reference_qlpv, sine_inputs

pytestmark = pytest.mark.slow

NOISE = np.array([0.1, 0.1, 0.001])
"""Measurement noise std of u, v (m/s) and r (rad/s), as the simulated GPS-INS."""


def _noisy(t: np.ndarray, thr: np.ndarray, dl: np.ndarray, seed: int) -> Record:
    truth = reference_qlpv().simulate(t, np.array([1.0, 0.0, 0.0]), thr, dl)
    meas = truth + np.random.default_rng(seed).normal(size=truth.shape) * NOISE
    return Record(f"synthetic {seed}", t, meas, thr, dl, truth)


def _square_nozzle(duration_s: float) -> Record:
    t, thr, _ = sine_inputs(duration_s)
    dl = np.pi / 3 * np.sign(np.sin(2 * np.pi * t / 14.0))
    return _noisy(t, thr, dl, seed=7)


def test_instrumental_variables_remove_the_noise_bias_of_least_squares() -> None:
    train = [_noisy(*sine_inputs(90.0, period_s=10.0), seed=3)]
    ls = fit_qlpv(train, window_s=2.0)
    iv = refine_instrumental(ls, train, window_s=2.0, bounds=QLPV_DISSIPATIVE)
    assert iv.method == "instrumental variables"
    assert iv.cond == ls.cond
    val = _square_nozzle(60.0)
    assert val.nu_true is not None
    j = {}
    for name, fit in (("ls", ls), ("iv", iv)):
        sim = fit.model.simulate(val.t_s, val.nu_true[0], val.throttle, val.delta_rad)
        j[name] = error_index(sim, val.nu_true)
    assert j["iv"][1] < 0.8 * j["ls"][1], j
    assert np.all(j["iv"] <= j["ls"] * 1.05), j
    assert np.all(iv.std[iv.model.theta != 0] > 0)


def test_dissipative_bounds_hold() -> None:
    train = [_noisy(*sine_inputs(60.0, period_s=10.0), seed=4)]
    iv = refine_instrumental(fit_qlpv(train, window_s=2.0), train, window_s=2.0, bounds=QLPV_DISSIPATIVE)
    f = iv.model.FEATURES
    for (j, name), (lo, hi) in QLPV_DISSIPATIVE.items():
        assert lo <= iv.model.theta[j, f.index(name)] <= hi, (j, name)
