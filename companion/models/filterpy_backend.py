"""filterpy as a reference backend of the active-model UKF (``models.ukf_backend = "filterpy"``).

The same filters as :mod:`companion.models.ukf` (the chapter's, x = [nu; delta_nu]) and
:mod:`companion.models.current_ukf` (x = [nu_r; delta_nu; V_c]), run by filterpy's
``UnscentedKalmanFilter`` with Van der Merwe's scaled sigma points: the process model is the
Euler step of Eq. 9 as ``fx``, the measurement z = H x (H = [I, 0] or H(psi)) as ``hx``.  Two
details make it the chapter's algorithm, and so give the native filters' numbers:

* Eq. 10 draws *new* sigma points from the predicted mean and covariance before the update
  (filterpy by default reuses the propagated ones, which lack Q); they are redrawn through
  filterpy's own ``points_fn`` and set as its documented ``sigmas_f``;
* with alpha = 1e-3 the central weight is about -1e6, so means are accumulated relative to the
  central sigma point (filterpy's ``x_mean_fn``/``z_mean_fn`` hooks; same maths).

About 100 times slower than the compiled native step (``usv bench ukf``): a reference, for
checking, not for the boat.
"""

from __future__ import annotations

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from companion.models.base import FloatArray
from companion.models.current_ukf import measurement_matrix
from companion.models.ukf import UKF, Derivative, UKFSettings


def stable_mean(sigmas: FloatArray, wm: FloatArray) -> FloatArray:
    """Weighted mean of sigma points, summed relative to the central point (weights sum to 1)."""
    return np.asarray(sigmas[0] + wm[1:] @ (sigmas[1:] - sigmas[0]))


class FilterpyUKF(UKF):
    """The active-model UKF (with or without the current states) computed by filterpy."""

    def __init__(self, derivative: Derivative, settings: UKFSettings | None = None,
                 x0: FloatArray | None = None, p0: FloatArray | None = None) -> None:
        settings = settings or UKFSettings()
        self.n = settings.n_states
        super().__init__(derivative, settings, x0, p0)
        s = self.settings
        points = MerweScaledSigmaPoints(self.n, s.alpha, s.beta, s.kappa)
        self.filter = UnscentedKalmanFilter(self.n, 3, 0.01, hx=self._hx, fx=self._fx, points=points,
                                            x_mean_fn=stable_mean, z_mean_fn=stable_mean)
        self.filter.R = self.R.copy()

    def _fx(self, x: FloatArray, dt: float, throttle: float, delta_rad: float) -> FloatArray:
        """Eq. 9 for one sigma point: nu += dt (f(nu, u) + delta_nu); the rest carried."""
        y = np.array(x, dtype=float)
        y[:3] += dt * (self.derivative(x[:3], throttle, delta_rad) + x[3:6])
        return y

    def _hx(self, x: FloatArray, psi_rad: float) -> FloatArray:
        if self.n == 6:
            return np.asarray(x[:3])
        return np.asarray(measurement_matrix(psi_rad) @ x)

    def predict(self, throttle: float, delta_rad: float, dt_s: float) -> None:
        f = self.filter
        f.x, f.P, f.Q = self.x.copy(), self.P.copy(), self.process_noise(dt_s, throttle, delta_rad)
        f.predict(dt_s, throttle=throttle, delta_rad=delta_rad)
        self.x, self.P = np.array(f.x), np.array(f.P)

    def update(self, z: FloatArray, psi_rad: float = 0.0) -> None:
        f = self.filter
        f.x, f.P = self.x.copy(), self.P.copy()
        f.sigmas_f = f.points_fn.sigma_points(f.x, f.P)  # Eq. 10: from the predicted mean, covariance
        f.update(np.asarray(z, dtype=float), psi_rad=psi_rad)
        self.x, self.P = np.array(f.x), np.array(f.P)
        self.nis = float(f.y @ f.SI @ f.y)

    @property
    def current_ne(self) -> FloatArray | None:
        return self.x[6:8] if self.n == 8 else None

    def nu_over_ground(self, psi_rad: float = 0.0) -> FloatArray:
        return self._hx(self.x, psi_rad)
