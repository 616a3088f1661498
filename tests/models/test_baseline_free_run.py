"""The baselines' fast free run (compiled, affine in nu) is the generic RK4 of the base class, and
gives exactly the numbers of the readable Python-float loop it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from companion.models.base import LinearInParamsModel
from companion.models.baselines import LinearizedModel, NomotoSideslipModel


@pytest.mark.parametrize("cls", [LinearizedModel, NomotoSideslipModel])
def test_fast_free_run_matches_the_generic_rk4_including_the_clipping(
        cls: type[LinearizedModel] | type[NomotoSideslipModel]) -> None:
    rng = np.random.default_rng(7)
    theta = rng.normal(scale=0.3, size=(3, 6))
    theta[:, 1] = -np.abs(theta[:, 1]) - 0.05  # some damping, some growth: the run reaches the clip limits
    model = cls(theta)
    n = 3000
    t_s = np.cumsum(rng.uniform(0.005, 0.02, n))  # uneven steps, as in a real log
    throttle, delta = rng.uniform(0.0, 1.0, n), rng.uniform(-0.6, 0.6, n)
    nu0 = np.array([2.0, 0.3, -0.1])
    fast = model.simulate(t_s, nu0, throttle, delta)
    generic = LinearInParamsModel.simulate(model, t_s, nu0, throttle, delta)
    np.testing.assert_allclose(fast, generic, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(fast, model.simulate_python(t_s, nu0, throttle, delta))
    assert fast.shape == (n, 3) and np.all(np.isfinite(fast))
