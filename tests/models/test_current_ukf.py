"""The current-augmented UKF (issue 14) and the filterpy backend: step-by-step equality with
filterpy and between the compiled and numpy steps, the linear Kalman filter on a linear model,
and known answers (a constant current and a constant model error recovered)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from companion.models.baselines import LinearizedModel
from companion.models.current import current_body
from companion.models.current_ukf import CurrentUKF, measurement_matrix
from companion.models.filterpy_backend import stable_mean
from companion.models.ukf import UKF, UKFSettings, make_ukf
from tests.models.helpers import reference_qlpv, sine_inputs

DT = 0.01
SENSOR_R = (0.01, 0.01, 7.6e-7)
"""Table 2's GPS-INS: 0.1 m/s per velocity axis, 0.05 deg/s gyro."""
SETTINGS = UKFSettings(q_diag=(1e-4, 1e-4, 1e-6, 1e-4, 1e-4, 1e-5), r_diag=SENSOR_R, estimate_current=True,
                       q_current=1e-4)


def _boat_in_current(n: int, current_ne: tuple[float, float], seed: int = 1,
                     delta_nu: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    """The reference hull through the water (a sine manoeuvre about a slight starboard turn, so
    the heading goes round), heading integrated from r, and GPS-INS-like over-ground
    measurements of nu and heading."""
    model = reference_qlpv()
    t, thr, dl = sine_inputs(n * DT)
    dl = dl + 0.1
    nu_r = model.simulate(t, np.array([1.5, 0.0, 0.0]), thr, dl, delta_nu=np.tile(delta_nu, (t.size, 1)))
    psi = np.concatenate([[0.3], 0.3 + np.cumsum(nu_r[:-1, 2]) * DT])
    nu = nu_r + current_body(psi, *current_ne)
    rng = np.random.default_rng(seed)
    z = nu + rng.normal(size=nu.shape) * np.sqrt(SENSOR_R)
    psi_meas = psi + rng.normal(size=psi.size) * np.radians(0.2)
    return model, thr, dl, z, psi_meas, nu_r


def _filterpy_reference(model, settings: UKFSettings) -> UnscentedKalmanFilter:
    def fx(x: np.ndarray, dt: float, thr: float, dl: float) -> np.ndarray:
        y = x.copy()
        y[:3] += dt * (model.derivative(x[:3], thr, dl) + x[3:6])
        return y

    def hx(x: np.ndarray, psi: float) -> np.ndarray:
        return measurement_matrix(psi) @ x

    return UnscentedKalmanFilter(8, 3, DT, hx, fx, MerweScaledSigmaPoints(8, settings.alpha, settings.beta,
                                                                          settings.kappa),
                                 x_mean_fn=stable_mean, z_mean_fn=stable_mean)


def test_current_filter_equals_filterpy_every_step() -> None:
    model, thr, dl, z, psi, _ = _boat_in_current(1200, (0.3, -0.4))
    ukf = CurrentUKF(model.derivative, SETTINGS)
    ukf.initialize(z[0])
    ref = _filterpy_reference(model, SETTINGS)
    ref.Q, ref.R = ukf.q_step(DT).copy(), ukf.R.copy()
    for k in range(1, 1200):
        ref.x, ref.P = ukf.x.copy(), ukf.P.copy()  # same start each step: rounding does not accumulate
        ukf.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        ref.predict(DT, thr=thr[k - 1], dl=dl[k - 1])
        # Eq. 10 draws new sigma points from the predicted mean and covariance (filterpy would
        # reuse the propagated ones, which lack Q; Q's nu and current rows are not zero here)
        ref.sigmas_f = ref.points_fn.sigma_points(ref.x, ref.P)
        ref.update(z[k], psi=psi[k])
        np.testing.assert_allclose(ukf.x, ref.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ukf.P, ref.P, rtol=0, atol=1e-9)


TRANSIENT = replace(SETTINGS, q_nu_transient_s=(0.5, 0.08, 0.72))
"""The same with the nu rows' process noise growing with the model's predicted derivative."""


@pytest.mark.parametrize("settings", [SETTINGS, TRANSIENT])
def test_compiled_current_step_equals_numpy_step(settings: UKFSettings) -> None:
    model, thr, dl, z, psi, _ = _boat_in_current(1000, (-0.5, 0.2))
    slow, fast = CurrentUKF(model.derivative, settings), make_ukf(model, settings)
    assert type(fast) is not CurrentUKF and isinstance(fast, CurrentUKF)
    slow.initialize(z[0])
    for k in range(1, 1000):
        fast.x, fast.P = slow.x.copy(), slow.P.copy()
        slow.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        fast.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=1e-9)


@pytest.mark.parametrize("settings", [UKFSettings(), SETTINGS, TRANSIENT,
                                      UKFSettings(q_nu_transient_s=(0.5, 0.08, 0.72))])
def test_filterpy_backend_gives_the_native_numbers(settings: UKFSettings) -> None:
    model, thr, dl, z, psi, _ = _boat_in_current(800, (0.4, 0.4))
    native, ref = make_ukf(model, settings), make_ukf(model, settings, backend="filterpy")
    for f in (native, ref):
        f.initialize(z[0])
    for k in range(1, 800):
        ref.x, ref.P = native.x.copy(), native.P.copy()
        native.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        ref.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        np.testing.assert_allclose(ref.x, native.x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ref.P, native.P, rtol=0, atol=1e-9)
        assert ref.nis == pytest.approx(native.nis, rel=1e-6, abs=1e-9)


def test_transient_process_noise_grows_with_the_models_predicted_derivative() -> None:
    """Each nu row k gets q_nu_transient_s[k] a_k^2 dt more process noise, a the model's
    derivative at the mean; nothing at rest without thrust, and no other row changes."""
    model = reference_qlpv()
    ukf = make_ukf(model, TRANSIENT)
    assert np.array_equal(ukf.process_noise(DT, 0.0, 0.0), ukf.q_step(DT))  # at rest, no thrust
    ukf.x[:3] = (1.0, -0.3, 0.6)
    a = model.derivative(ukf.x[None, :3], 0.8, 0.5)[0]
    added = ukf.process_noise(DT, 0.8, 0.5) - ukf.q_step(DT)
    expected = np.array(TRANSIENT.q_nu_transient_s) * a**2 * DT
    np.testing.assert_allclose(np.diag(added)[:3], expected, rtol=1e-12)
    assert np.count_nonzero(added) == np.count_nonzero(np.diag(added)[:3]) == 3
    with pytest.raises(ValueError, match="transient"):
        make_ukf(model, replace(TRANSIENT, q_nu_transient_s=(0.5, -0.1, 0.7)))


def test_unknown_backend_is_refused() -> None:
    with pytest.raises(ValueError, match="filterpy"):
        make_ukf(reference_qlpv(), backend="pykalman")


def test_current_filter_equals_linear_kalman_filter_on_linear_model() -> None:
    th = np.zeros((3, 6))
    th[0, :3] = [0.5, -0.3, 2.0]
    th[1, 3:] = [-1.0, 0.2, -0.5]
    th[2, 3:] = [0.3, -1.5, 1.2]
    model = LinearizedModel(th)
    ukf = CurrentUKF(model.derivative, SETTINGS)
    a = np.zeros((8, 8))
    a[:3, :3] = th[:, [1, 3, 4]] * [[1, 0, 0], [0, 1, 1], [0, 1, 1]]
    a[:3, 3:6] = np.eye(3)
    f = np.eye(8) + DT * a
    rng = np.random.default_rng(3)
    for k in range(800):
        thr, dl, psi = 0.3, 0.4 * np.sin(0.02 * k), 0.01 * k
        z = rng.normal(size=3) * 0.1 + [1.5, 0.1, 0.05]
        x, p = ukf.x.copy(), ukf.P.copy()  # compared step by step (rounding of -1e6 weights)
        ukf.step(z, thr, dl, DT, psi)
        bu = np.zeros(8)
        bu[:3] = DT * (th[:, 0] + th[:, 2] * thr) * [1, 0, 0] + DT * th[:, 5] * dl * [0, 1, 1]
        x = f @ x + bu
        p = f @ p @ f.T + ukf.q_step(DT)
        h = measurement_matrix(psi)
        s = h @ p @ h.T + ukf.R
        gain = p @ h.T @ np.linalg.inv(s)
        x = x + gain @ (z - h @ x)
        p = p - gain @ s @ gain.T
        np.testing.assert_allclose(ukf.x, x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ukf.P, p, rtol=0, atol=1e-9)


@pytest.mark.parametrize("current_ne", [(0.0, 0.0), (0.5, 0.0), (-0.35, 0.35), (0.8, -0.6)])
def test_recovers_a_constant_current_and_leaves_no_model_error(current_ne: tuple[float, float]) -> None:
    model, thr, dl, z, psi, nu_r = _boat_in_current(6000, current_ne)
    ukf = make_ukf(model, SETTINGS)
    ukf.initialize(z[0])
    cur, dnu, nu_est = np.empty((6000, 2)), np.empty((6000, 3)), np.empty((6000, 3))
    for k in range(1, 6000):
        dnu[k] = ukf.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        cur[k], nu_est[k] = ukf.current_ne, ukf.x[:3]
    np.testing.assert_allclose(cur[-2000:].mean(axis=0), current_ne, atol=0.02)
    # (the filter's Euler step against the RK4 truth leaves about 0.01 m/s^2 in sway)
    np.testing.assert_allclose(dnu[-2000:].mean(axis=0), 0.0, atol=0.02)
    # the water-relative velocity is recovered better than the raw over-ground measurement
    assert np.sqrt(np.mean((nu_est[-2000:, :2] - nu_r[-2000:, :2]) ** 2)) < 0.05


def test_separates_current_from_a_constant_model_error() -> None:
    offset = (0.05, -0.03, 0.02)
    model, thr, dl, z, psi, _ = _boat_in_current(6000, (0.4, 0.3), delta_nu=offset)
    ukf = make_ukf(model, SETTINGS)
    ukf.initialize(z[0])
    cur, dnu = np.empty((6000, 2)), np.empty((6000, 3))
    for k in range(1, 6000):
        dnu[k] = ukf.step(z[k], thr[k - 1], dl[k - 1], DT, psi[k])
        cur[k] = ukf.current_ne
    np.testing.assert_allclose(cur[-2000:].mean(axis=0), (0.4, 0.3), atol=0.02)
    np.testing.assert_allclose(dnu[-2000:].mean(axis=0), offset, atol=0.02)


def test_chapter_filter_ignores_the_heading() -> None:
    model = reference_qlpv()
    a, b = UKF(model.derivative), UKF(model.derivative)
    for f, psi in ((a, 0.0), (b, 2.0)):
        f.initialize(np.array([1.0, 0.0, 0.0]))
        f.step(np.array([1.1, 0.05, 0.01]), 0.3, 0.1, DT, psi)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.current_ne is None


def test_settings_and_filter_must_agree_on_the_state() -> None:
    with pytest.raises(ValueError, match="describe 8"):
        UKF(reference_qlpv().derivative, SETTINGS)
