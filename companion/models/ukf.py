"""Unscented Kalman filter for the active model of Eq. 5-11.

State x = [nu; delta_nu] (n = 6): body velocities nu = [u, v, r] and the unstructured
model error delta_nu of Eq. 5.  Process model (Euler discretisation at the control period,
0.01 s in the chapter):

    nu_{k+1}       = nu_k + dt (A(nu_k) nu_k + B u_k + delta_nu_k)       (Eq. 3 + Eq. 5)
    delta_nu_{k+1} = delta_nu_k  (random walk driven by Q)

Measurement z = nu + noise (Eq. 5).  Defaults are the chapter's Eq. 13:
Q = 1e-2 diag(0,0,0,16,2,1), R = 1e-3 diag(16,2,1), alpha = 1e-3, beta = 2, kappa = 0.

Discretisation of Q.  Eq. 13 does not state the sample time Q refers to.  By default
(``q_discretization="rate"``) the chapter's Q is read as a continuous-time intensity of the
random walk delta_nu (units (m/s^2)^2/s), so each step of length dt adds Q_k = Q dt; the
filter then behaves the same at 100, 50 or 10 Hz.  ``"per_step"`` adds Q itself every step
(the literal reading): at the 10 ms control period delta_nu's random walk then has a
variance growth 100x larger, and measured on simulator logs it follows the 0.1 m/s GPS
velocity noise instead of the model error (see ``usv identify`` report).

Implementation notes.

* Sigma points (Eq. 8) are Van der Merwe's scaled points, the same as filterpy's
  ``MerweScaledSigmaPoints`` (rows of the upper Cholesky factor of (n+lambda)P), and all
  13 are propagated through the model in one vectorised call (Eq. 9).
* Measurement update (Eq. 10-11).  The chapter draws new sigma points from the predicted
  mean and covariance; because z = H x is linear in the state, the unscented transform of
  those points is exact: P_z = H P H^T + R and P_xz = P H^T.  We use these closed forms
  (identical in exact arithmetic, not an approximation) and the Joseph form of Eq. 11's
  covariance update, P = (I-KH) P (I-KH)^T + K R K^T, which stays symmetric positive
  semidefinite in floating point.
* alpha = 1e-3 makes lambda = alpha^2 n - n and the central weights about -1e6.  The mean
  is accumulated relative to the central point (sum of weights is 1) to avoid cancelling
  1e6-sized terms, the covariance is symmetrised after every step, and if P ever fails the
  Cholesky factorisation, a jitter of 1e-12 * (trace(P)/n + 1) on the diagonal is added
  (doubling until it factors) and counted in :attr:`UKF.jitter_count`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from companion.models.base import FloatArray, LinearInParamsModel
from companion.models.qlpv import QLPVModel

CHAPTER_Q_DIAG: tuple[float, ...] = tuple(1e-2 * np.array([0.0, 0.0, 0.0, 16.0, 2.0, 1.0]))
CHAPTER_R_DIAG: tuple[float, ...] = tuple(1e-3 * np.array([16.0, 2.0, 1.0]))

DEFAULT_Q_CURRENT = 1e-4
"""(m/s)^2/s: a current component wanders about 0.1 m/s in 100 s (a flood's eddies drift over minutes)."""
DEFAULT_P0_CURRENT = 1.0
"""(m/s)^2: before the first turn the current is known to within about 1 m/s (flood currents)."""

CURRENT_GATE_CHI2 = 50.0
"""The active model uses the estimated current once its squared distance from still water,
V_c^T P_c^-1 V_c, passes about this (7 standard deviations): below it, an estimate of a few
cm/s is more likely the model's own error than moving water (chosen on tuning logs)."""

Derivative = Callable[[FloatArray, float, float], FloatArray]
"""``(nu (k,3), throttle, delta_rad) -> nu_dot (k,3)``: the structured model, vectorised."""


@dataclass(frozen=True)
class UKFSettings:
    """Tuning of the active-model UKF; defaults are the chapter's Eq. 13."""

    q_diag: tuple[float, ...] = CHAPTER_Q_DIAG
    r_diag: tuple[float, ...] = CHAPTER_R_DIAG
    alpha: float = 1e-3
    beta: float = 2.0
    kappa: float = 0.0
    p0_diag: tuple[float, ...] = field(default=())
    """Initial covariance (Eq. 7); empty means diag(R, model-error block of Q * 100)."""
    q_discretization: str = "rate"
    """``"rate"``: Q is a continuous intensity, Q_k = Q dt; ``"per_step"``: Q_k = Q."""
    estimate_current: bool = False
    """Augment the state with the earth-frame water current (:mod:`companion.models.current_ukf`)."""
    q_current: float = DEFAULT_Q_CURRENT
    """Random-walk intensity of each current component ((m/s)^2/s, read like Q)."""
    p0_current: float = DEFAULT_P0_CURRENT
    """Initial variance of each current component ((m/s)^2)."""
    q_nu_transient_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Process noise on the nu rows that grows with the model's own predicted derivative
    a = A(nu) nu + B u at the mean: each step adds ``q_nu_transient_s[k] * a_k^2`` to Q's row k
    (read like Q: an intensity, times dt for ``"rate"``).  The qLPV model's derivative error grows
    with a (transients: starts, hard turns, sprints), and without this a persistent transient
    error was taken for a current (:func:`companion.models.current_ukf.current_filter_settings`).
    Zero (the default, Eq. 13): Q alone."""

    @property
    def n_states(self) -> int:
        return 8 if self.estimate_current else 6


def merwe_weights(n: int, alpha: float, beta: float, kappa: float) -> tuple[float, FloatArray, FloatArray]:
    """(lambda, Wm, Wc) of the scaled unscented transform, as filterpy computes them."""
    lam = alpha**2 * (n + kappa) - n
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)
    return lam, wm, wc


class UKF:
    """Active-model UKF on x = [nu; delta_nu] with z = nu + noise (chapter Eq. 5-11).

    Subclasses may append states after delta_nu (``n`` > 6): the process model carries them
    unchanged (random walks) and :meth:`update` takes their measurement matrix into account.
    """

    n = 6
    m = 3

    def __init__(self, derivative: Derivative, settings: UKFSettings | None = None,
                 x0: FloatArray | None = None, p0: FloatArray | None = None) -> None:
        self.settings = s = settings or UKFSettings()
        if len(s.q_diag) != 6 or len(s.r_diag) != 3:
            raise ValueError("UKF needs 6 process-noise and 3 measurement-noise variances")
        if min(s.q_diag) < 0 or min(s.r_diag) <= 0:
            raise ValueError("Q must be >= 0 and R > 0 on the diagonal")
        if s.q_discretization not in ("rate", "per_step"):
            raise ValueError(f"q_discretization {s.q_discretization!r}; accepted: 'rate', 'per_step'")
        self._q_rate = s.q_discretization == "rate"
        self._q_dt = -1.0
        self.derivative = derivative
        if s.n_states != self.n:
            raise ValueError(f"{type(self).__name__} has {self.n} states; these settings describe "
                             f"{s.n_states} (estimate_current={s.estimate_current})")
        if s.q_current < 0 or s.p0_current <= 0:
            raise ValueError("the current's Q must be >= 0 and its initial variance > 0")
        if len(s.q_nu_transient_s) != 3 or not all(q >= 0 for q in s.q_nu_transient_s):
            raise ValueError("the transient process noise needs 3 values >= 0 (one per nu row)")
        self._q_transient = np.asarray(s.q_nu_transient_s, dtype=float)
        self._transient = bool(self._q_transient.any())
        extra = self.n - 6  # states after delta_nu (the current), random walks
        self.Q = np.diag(np.concatenate([np.asarray(s.q_diag, dtype=float), np.full(extra, s.q_current)]))
        self.R = np.diag(np.asarray(s.r_diag, dtype=float))
        self.lam, self.Wm, self.Wc = merwe_weights(self.n, s.alpha, s.beta, s.kappa)
        self._c = self.n + self.lam
        self._wi = float(self.Wm[1])
        self.x = np.zeros(self.n) if x0 is None else np.array(x0, dtype=float)
        if p0 is not None:
            self.P = np.array(p0, dtype=float)
        elif s.p0_diag:
            self.P = np.diag(np.asarray(s.p0_diag, dtype=float))
        else:
            self.P = np.diag(np.concatenate([s.r_diag, 100.0 * np.asarray(s.q_diag[3:]),
                                             np.full(extra, s.p0_current)]))
        self.jitter_count = 0
        self.nis = 0.0
        self._sigmas = np.empty((2 * self.n + 1, self.n))
        self._q_k = self.Q.copy()

    def q_step(self, dt_s: float) -> FloatArray:
        """Process noise added in one step of ``dt_s`` (Q dt or Q, see the module docstring)."""
        if not self._q_rate:
            return self.Q
        if dt_s != self._q_dt:
            self._q_k = self.Q * dt_s
            self._q_dt = dt_s
        return self._q_k

    def process_noise(self, dt_s: float, throttle: float, delta_rad: float) -> FloatArray:
        """Q of this step: :meth:`q_step` plus, with ``q_nu_transient_s``, the nu rows' share
        that grows with the model's predicted derivative at the mean (:class:`UKFSettings`)."""
        q = self.q_step(dt_s)
        if not self._transient:
            return q
        a = self._predicted_derivative(throttle, delta_rad)
        q = q.copy()
        scale = dt_s if self._q_rate else 1.0
        for k in range(3):
            q[k, k] += scale * self._q_transient[k] * a[k] * a[k]
        return q

    def _predicted_derivative(self, throttle: float, delta_rad: float) -> FloatArray:
        """A(nu) nu + B u of the model at the mean nu (without delta_nu)."""
        return np.asarray(self.derivative(self.x[None, :3], throttle, delta_rad))[0]

    def initialize(self, z: FloatArray) -> None:
        """UKF-I (Eq. 7): start from the first measurement, zero model error."""
        self.x[:3] = z
        self.x[3:] = 0.0

    def _sqrt(self, p: FloatArray) -> FloatArray:
        try:
            return np.asarray(np.linalg.cholesky(self._c * p), dtype=float)
        except np.linalg.LinAlgError:
            jitter = 1e-12 * (float(np.trace(p)) / self.n + 1.0)
            eye = np.eye(self.n)
            while True:
                self.jitter_count += 1
                try:
                    return np.asarray(np.linalg.cholesky(self._c * (p + jitter * eye)), dtype=float)
                except np.linalg.LinAlgError:
                    jitter *= 2.0

    def sigma_points(self) -> FloatArray:
        """Eq. 8: x, x + columns of sqrt((n+lambda)P), x - columns; shape (2n+1, n)."""
        low = self._sqrt(self.P)
        sig = self._sigmas
        sig[0] = self.x
        np.add(self.x, low.T, out=sig[1:self.n + 1])
        np.subtract(self.x, low.T, out=sig[self.n + 1:])
        return sig

    def predict(self, throttle: float, delta_rad: float, dt_s: float) -> None:
        """UKF-II/III (Eq. 8-9) with the input held over ``dt_s``."""
        sig = self.sigma_points()
        y = sig.copy()
        y[:, :3] += dt_s * (self.derivative(sig[:, :3], throttle, delta_rad) + sig[:, 3:6])
        d = y[1:] - y[0]
        mean = y[0] + self._wi * d.sum(axis=0)
        dev = y - mean
        p = (dev.T * self.Wc) @ dev + self.process_noise(dt_s, throttle, delta_rad)
        self.x = mean
        self.P = 0.5 * (p + p.T)

    def update(self, z: FloatArray, psi_rad: float = 0.0) -> None:
        """UKF-IV (Eq. 10-11), exact for the linear measurement z = nu + noise (the heading
        ``psi_rad`` is for filters whose measurement depends on it)."""
        p = self.P
        s = p[:3, :3] + self.R
        s_inv = np.linalg.inv(s)
        k = p[:, :3] @ s_inv
        innov = np.asarray(z, dtype=float) - self.x[:3]
        self.x = self.x + k @ innov
        a = np.eye(self.n)
        a[:, :3] -= k
        p = a @ p @ a.T + k @ self.R @ k.T
        self.P = 0.5 * (p + p.T)
        self.nis = float(innov @ s_inv @ innov)

    def step(self, z: FloatArray, throttle: float, delta_rad: float, dt_s: float, psi_rad: float = 0.0
             ) -> FloatArray:
        """predict + update; returns the model-error estimate delta_nu."""
        self.predict(throttle, delta_rad, dt_s)
        self.update(z, psi_rad)
        return self.x[3:6]

    @property
    def delta_nu(self) -> FloatArray:
        return self.x[3:6]

    @property
    def current_ne(self) -> FloatArray | None:
        """Estimated water current [north, east] (m/s), or None for a filter without it."""
        return None

    def nu_over_ground(self, psi_rad: float = 0.0) -> FloatArray:
        """The filtered over-ground velocity nu (what z measures)."""
        return self.x[:3]


class CompiledDerivative:
    """A(nu) nu + B u of a qLPV model at one state, by the compiled kernel into a kept buffer (the
    fast filters' :meth:`UKF._predicted_derivative`, every step)."""

    def __init__(self, model: QLPVModel) -> None:
        from companion.models.qlpv_kernel import qlpv_derivative

        self._kernel = qlpv_derivative
        self._theta = np.ascontiguousarray(model.theta)
        self._c_thrust = float(model.thrust_speed_coeff)
        self._out = np.empty(3)

    def __call__(self, x: FloatArray, throttle: float, delta_rad: float) -> FloatArray:
        self._kernel(x, float(throttle), float(delta_rad), self._theta, self._c_thrust, self._out)
        return self._out


class QLPVFastUKF(UKF):
    """The same filter for a :class:`~companion.models.qlpv.QLPVModel`, one compiled step.

    :meth:`step` runs :func:`companion.models.ukf_kernel.qlpv_ukf_step` (numba); the
    numpy :meth:`predict`/:meth:`update` of the base class remain available and give the
    same numbers (tested).
    """

    def __init__(self, model: QLPVModel, settings: UKFSettings | None = None,
                 x0: FloatArray | None = None, p0: FloatArray | None = None) -> None:
        super().__init__(model.derivative, settings, x0, p0)
        from companion.models.ukf_kernel import qlpv_ukf_step

        self._kernel = qlpv_ukf_step
        self._theta = np.ascontiguousarray(model.theta)
        self._c_thrust = float(model.thrust_speed_coeff)
        self._wc0 = float(self.Wc[0])
        self._z = np.empty(3)
        self._at_mean = CompiledDerivative(model)

    def _predicted_derivative(self, throttle: float, delta_rad: float) -> FloatArray:
        return self._at_mean(self.x, throttle, delta_rad)

    def step(self, z: FloatArray, throttle: float, delta_rad: float, dt_s: float, psi_rad: float = 0.0
             ) -> FloatArray:
        self._z[:] = z
        q = self.process_noise(dt_s, throttle, delta_rad)
        self.nis, jit = self._kernel(self.x, self.P, self._z, float(throttle), float(delta_rad),
                                     float(dt_s), self._theta, self._c_thrust, q, self.R,
                                     self._wi, self._wc0, self._c)
        self.jitter_count += jit
        return self.x[3:6]


BACKENDS: tuple[str, ...] = ("native", "filterpy")
"""``native``: this module's filters (compiled for the qLPV model); ``filterpy``: the same
equations run by filterpy's UnscentedKalmanFilter (:mod:`companion.models.filterpy_backend`),
a slow reference that gives the same numbers."""


def make_ukf(model: LinearInParamsModel, settings: UKFSettings | None = None,
             x0: FloatArray | None = None, backend: str = "native") -> UKF:
    """The filter ``settings`` describe for ``model``: the chapter's (x = [nu; delta_nu]) or, with
    ``settings.estimate_current``, the current-augmented one; ``backend`` as in :data:`BACKENDS`
    (native: compiled for the qLPV model)."""
    settings = settings or UKFSettings()
    if backend not in BACKENDS:
        raise ValueError(f"UKF backend {backend!r}; accepted: {', '.join(BACKENDS)}")
    if backend == "filterpy":
        from companion.models.filterpy_backend import FilterpyUKF

        return FilterpyUKF(model.derivative, settings, x0)
    if settings.estimate_current:
        from companion.models.current_ukf import CurrentUKF, QLPVFastCurrentUKF

        if isinstance(model, QLPVModel):
            return QLPVFastCurrentUKF(model, settings, x0)
        return CurrentUKF(model.derivative, settings, x0)
    if isinstance(model, QLPVModel):
        return QLPVFastUKF(model, settings, x0)
    return UKF(model.derivative, settings, x0)
