"""The batched free run (M models side by side, what the current search's output-error fits and
quick costs simulate) gives every model exactly the trajectory of the one-model kernel and of
the readable numpy RK4 (:meth:`LinearInParamsModel.simulate`), state clipping included."""

from __future__ import annotations

import numpy as np

from companion.models.base import NU_LIMIT, LinearInParamsModel
from companion.models.params_file import load_model_params
from companion.models.qlpv import QLPVModel
from companion.models.qlpv_kernel import qlpv_simulate, qlpv_simulate_batch


def _inputs(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t_s = np.cumsum(np.full(n, 0.01) + 1e-4 * rng.random(n))  # uneven steps, as a logged clock
    throttle = np.clip(0.5 + 0.3 * rng.standard_normal(n), 0.0, 1.0)
    delta_rad = 0.5 * np.sin(0.3 * t_s) + 0.1 * rng.standard_normal(n)
    return t_s, throttle, delta_rad


def test_every_batched_trajectory_is_the_single_model_trajectory() -> None:
    shipped = load_model_params()
    rng = np.random.default_rng(3)
    t_s, throttle, delta_rad = _inputs(1200, 1)
    m = 5
    thetas = shipped.theta * (1.0 + 0.2 * rng.standard_normal((m, *shipped.theta.shape)))
    thetas[0, 0, 4] *= 400.0  # one model runs into the surge limit: the clipping must match too
    nu0 = np.array([3.0, 0.2, 0.1]) + 0.5 * rng.standard_normal((m, 3))
    c = shipped.thrust_speed_coeff
    batch = qlpv_simulate_batch(t_s, nu0, throttle, delta_rad, thetas, c, NU_LIMIT)
    assert batch.shape == (m, t_s.size, 3)
    assert np.max(np.abs(batch[0, :, 0])) == NU_LIMIT[0]
    for j in range(m):
        one = qlpv_simulate(t_s, nu0[j], throttle, delta_rad, thetas[j], c, np.zeros((t_s.size, 3)), NU_LIMIT)
        np.testing.assert_array_equal(batch[j], one)
        reference = LinearInParamsModel.simulate(QLPVModel(thetas[j], thrust_speed_coeff=c), t_s, nu0[j],
                                                 throttle, delta_rad)
        np.testing.assert_allclose(batch[j], reference, rtol=1e-9, atol=1e-9)
