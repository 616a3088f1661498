"""The active-model UKF (Eq. 5-11): filterpy equivalence, linear-KF equivalence, SPD, estimation."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from companion.models.baselines import LinearizedModel
from companion.models.ukf import UKF, UKFSettings, make_ukf
from tests.models.helpers import reference_qlpv, sine_inputs

DT = 0.01


def _measurements(n: int, seed: int = 1, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    model = reference_qlpv()
    t, thr, dl = sine_inputs(n * DT)
    truth = model.simulate(t, np.array([1.0, 0.0, 0.0]), thr, dl, delta_nu=np.tile(offset, (t.size, 1)))
    rng = np.random.default_rng(seed)
    z = truth + rng.normal(size=truth.shape) * np.sqrt([0.016, 0.002, 0.001])
    return model, thr, dl, truth, z


def test_equals_filterpy_every_step_with_chapter_settings() -> None:
    model, thr, dl, _, z = _measurements(1500)
    ukf = UKF(model.derivative)
    ukf.initialize(z[0])

    def fx(x: np.ndarray, dt: float, thr: float, dl: float) -> np.ndarray:
        y = x.copy()
        y[:3] += dt * (model.derivative(x[:3], thr, dl) + x[3:])
        return y

    def stable_mean(sigmas: np.ndarray, wm: np.ndarray) -> np.ndarray:
        # filterpy's documented hook for custom means; summing relative to the central point
        # avoids cancelling the +-1e6 weights that alpha = 1e-3 produces (same maths).
        return sigmas[0] + wm[1:] @ (sigmas[1:] - sigmas[0])

    ref = UnscentedKalmanFilter(6, 3, DT, lambda x: x[:3], fx, MerweScaledSigmaPoints(6, 1e-3, 2.0, 0.0),
                                x_mean_fn=stable_mean, z_mean_fn=stable_mean)
    ref.Q, ref.R = ukf.q_step(DT).copy(), ukf.R.copy()
    for k in range(1, 1500):
        # Same starting point every step, so that rounding does not accumulate over the run.
        ref.x, ref.P = ukf.x.copy(), ukf.P.copy()
        ukf.step(z[k], thr[k - 1], dl[k - 1], DT)
        ref.predict(DT, thr=thr[k - 1], dl=dl[k - 1])
        ref.update(z[k])
        np.testing.assert_allclose(ukf.x, ref.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ukf.P, ref.P, rtol=0, atol=1e-9)


def test_compiled_step_equals_numpy_step() -> None:
    model, thr, dl, _, z = _measurements(1000)
    slow, fast = UKF(model.derivative), make_ukf(model)
    assert type(fast) is not UKF
    slow.initialize(z[0])
    fast.initialize(z[0])
    for k in range(1, 1000):
        fast.x, fast.P = slow.x.copy(), slow.P.copy()
        slow.step(z[k], thr[k - 1], dl[k - 1], DT)
        fast.step(z[k], thr[k - 1], dl[k - 1], DT)
        np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=1e-9)


def test_equals_linear_kalman_filter_on_linear_model() -> None:
    th = np.zeros((3, 6))
    th[0, :3] = [0.5, -0.3, 2.0]
    th[1, 3:] = [-1.0, 0.2, -0.5]
    th[2, 3:] = [0.3, -1.5, 1.2]
    model = LinearizedModel(th)
    settings = UKFSettings(q_diag=(1e-4, 2e-4, 1e-4, 0.16, 0.02, 0.01))
    ukf = UKF(model.derivative, settings)
    a = np.zeros((6, 6))
    a[:3, :3] = th[:, [1, 3, 4]] * [[1, 0, 0], [0, 1, 1], [0, 1, 1]]
    a[:3, 3:] = np.eye(3)
    f = np.eye(6) + DT * a
    x, p = ukf.x.copy(), ukf.P.copy()
    rng = np.random.default_rng(3)
    h = np.eye(3, 6)
    for k in range(800):
        thr, dl = 0.3, 0.4 * np.sin(0.02 * k)
        z = rng.normal(size=3) * 0.1 + [1.5, 0.1, 0.05]
        x, p = ukf.x.copy(), ukf.P.copy()  # compared step by step (rounding of -1e6 weights)
        ukf.step(z, thr, dl, DT)
        bu = np.zeros(6)
        bu[:3] = DT * (th[:, 0] + th[:, 2] * thr + th[:, 5] * dl) * [1, 0, 0] + DT * th[:, 5] * dl * [0, 1, 1]
        x = f @ x + bu
        p = f @ p @ f.T + ukf.q_step(DT)
        s = h @ p @ h.T + ukf.R
        k_gain = p @ h.T @ np.linalg.inv(s)
        x = x + k_gain @ (z - h @ x)
        p = p - k_gain @ s @ k_gain.T
        np.testing.assert_allclose(ukf.x, x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ukf.P, p, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_covariance_stays_symmetric_positive_definite_over_long_run() -> None:
    model, thr, dl, _, z = _measurements(60_000, seed=7)  # 10 minutes at 100 Hz
    ukf = make_ukf(model)
    ukf.initialize(z[0])
    min_eig = np.inf
    for k in range(1, z.shape[0]):
        ukf.step(z[k], thr[k - 1], dl[k - 1], DT)
        if k % 500 == 0:
            assert np.array_equal(ukf.P, ukf.P.T)
            min_eig = min(min_eig, float(np.linalg.eigvalsh(ukf.P).min()))
            np.linalg.cholesky(ukf.P)
    assert min_eig > 0
    assert np.all(np.isfinite(ukf.x))


def test_estimates_a_constant_model_error() -> None:
    offset = (0.05, -0.03, 0.02)
    model, thr, dl, _, z = _measurements(3000, offset=offset)
    ukf = make_ukf(model)
    ukf.initialize(z[0])
    est = np.empty((z.shape[0], 3))
    for k in range(1, z.shape[0]):
        est[k] = ukf.step(z[k], thr[k - 1], dl[k - 1], DT)
    np.testing.assert_allclose(est[-1000:].mean(axis=0), offset, atol=0.01)


def test_q_is_a_rate_by_default_so_the_filter_does_not_depend_on_the_sample_time() -> None:
    """Eq. 13's Q read as a continuous intensity: Q_k = Q dt, and the steady-state uncertainty
    of delta_nu is (nearly) the same at 100 Hz and 50 Hz; the literal per-step reading is not."""
    model = reference_qlpv()
    ukf = UKF(model.derivative)
    np.testing.assert_allclose(ukf.q_step(0.01), ukf.Q * 0.01)
    literal = UKF(model.derivative, UKFSettings(q_discretization="per_step"))
    np.testing.assert_array_equal(literal.q_step(0.01), ukf.Q)

    def steady_var(dt: float, mode: str) -> np.ndarray:
        f = make_ukf(model, UKFSettings(q_discretization=mode))
        f.initialize(np.array([1.0, 0.0, 0.0]))
        for _ in range(round(20.0 / dt)):
            f.step(np.array([1.0, 0.0, 0.0]), 0.3, 0.0, dt)
        return np.diag(f.P)[3:]

    ratio_rate = steady_var(0.01, "rate") / steady_var(0.02, "rate")
    ratio_step = steady_var(0.01, "per_step") / steady_var(0.02, "per_step")
    # R is per sample, so at 50 Hz half the measurements arrive: with Q a rate only that changes
    # (variance ratio measured 0.84, ~2^(-1/4)); per step, Q's growth per second doubles too (1.41).
    assert np.all(np.abs(np.log(ratio_rate)) < 0.25)
    assert np.all(np.abs(np.log(ratio_step)) > 1.5 * np.abs(np.log(ratio_rate)))
