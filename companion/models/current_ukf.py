"""The active-model UKF of Eq. 5-11 augmented with the water current (issue 14).

The chapter's filter (:mod:`companion.models.ukf`) runs the qLPV model on the velocity the
GPS-INS measures, over the ground; in moving water a current then looks like a large model
error that turns with the boat.  Here the model runs on the water-relative velocity
(:mod:`companion.models.current`) and the current is estimated as two more states:

    x = [nu_r; delta_nu; V_c]   (n = 8): nu_r = [u_r, v_r, r] through the water, the model error
                                delta_nu of Eq. 5, the current V_c = [V_cN, V_cE] (earth frame, m/s)

    nu_r_{k+1}     = nu_r_k + dt (A(nu_r_k) nu_r_k + B u_k + delta_nu_k)    (Eq. 3 + Eq. 5)
    delta_nu_{k+1} = delta_nu_k                                             (random walk, Q)
    V_c_{k+1}      = V_c_k                                                  (random walk, q_current)

    z = nu (over ground) = nu_r + R(psi)^T [V_cN, V_cE, 0]^T + noise = H(psi) x + noise,
    H(psi) = [I_3, 0_3, C(psi)],  C(psi) = [[cos psi, sin psi], [-sin psi, cos psi], [0, 0]].

The heading psi comes from the same GPS-INS sample (0.2 deg noise, Table 2) and is taken as
known.  The current is observable because the body-frame current turns with the heading while
the hull's response to the inputs (the model) does not; delta_nu keeps what remains (wind,
payload, thrust-map error).  Sigma points, time update and the exact linear measurement update
(closed form, Joseph form) are those of :class:`~companion.models.ukf.UKF` with n = 8.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from companion.models.base import FloatArray
from companion.models.qlpv import QLPVModel
from companion.models.ukf import CURRENT_GATE_CHI2, UKF, CompiledDerivative, Derivative, UKFSettings

TABLE2_R_DIAG: tuple[float, float, float] = (0.1**2, 0.1**2, math.radians(0.05) ** 2)
"""The GPS-INS of the chapter's Table 2 as measurement noise of z = [u, v, r]: 0.1 m/s per
velocity axis, 0.05 deg/s gyro (1 sigma).  The heading's 0.2 deg adds ~0.0035 U m/s, negligible."""


TRANSIENT_Q_S: tuple[float, float, float] = (0.5, 0.08, 0.72)
"""``UKFSettings.q_nu_transient_s`` of the current filter: tau c_k^2 with tau = 2 s (how long a
transient's error lasts) and c = (0.5, 0.2, 0.6), the slope of the qLPV model's rms derivative error
against its predicted derivative |a_k| in u, v, r (the shipped model in calm water, in-process: the
bench's GUIDED-LOITER-RTL sequence from rest, tuning seed 1; rms error 0.07 / 0.04 / 0.06 below
0.05 of |a|, 0.31 / 0.14 / 0.32 at 0.4-0.8, 0.24 / 0.19 / 0.50 above; ``docs/tuning.md``).  Without
it the filter, sure of a nil current while the boat lay still, booked the model's error in the
first turn at full nozzle as a current of 0.21-0.31 m/s at confidence 1 (calm water)."""


def current_filter_settings(r_diag: tuple[float, ...] = TABLE2_R_DIAG) -> UKFSettings:
    """The current-augmented filter's prediction tuning (the filter that gives the vehicle's
    current estimate beside the controller's, and the one ``usv bench identify`` reports): R from
    the sensor (``r_diag``: Table 2, or the ``[ukf]`` noise ``usv identify`` measured), and Q split
    by what persists (issue 14):

    * nu rows (1e-2, 1e-2, 1e-3 per second): the fast model error, which changes sign within
      the prediction horizon (calm-water logs: its correlation with itself 1 s later is
      -0.4..0.4), enters the velocity like process noise instead of moving delta_nu;
    * delta_nu rows (1e-6, 1e-6, 1e-7 per second): only what persists for many seconds
      (payload, wind, thrust-map error) moves delta_nu, so its held value is not noise;
    * the current: random walk 1e-6 (m/s)^2/s, initial variance 0.25 (m/s)^2;
    * nu rows in transients (:data:`TRANSIENT_Q_S`): the model's derivative error grows with its
      predicted derivative, so a start, a hard turn or a sprint is not taken for a current.

    Chosen on simulator tuning logs (seeds apart from the reporting ones; ``usv bench identify``)."""
    return UKFSettings(q_diag=(1e-2, 1e-2, 1e-3, 1e-6, 1e-6, 1e-7), r_diag=tuple(r_diag),
                       estimate_current=True, q_current=1e-6, p0_current=0.25,
                       q_nu_transient_s=TRANSIENT_Q_S)


CONTROL_SURGE_DELTA_NU_Q = 1e-3
"""The control filter's delta_nu_u random walk ((m/s^2)^2 per second; see
:func:`control_filter_settings`)."""


def control_filter_settings(r_diag: tuple[float, ...] = TABLE2_R_DIAG) -> UKFSettings:
    """The current-augmented filter the controller flies on (``models.ukf = "current"``): that of
    :func:`current_filter_settings` with a fast surge model error (delta_nu_u random walk
    :data:`CONTROL_SURGE_DELTA_NU_Q` instead of 1e-6).

    The identified surge row is far off at speed through the water (steady speed at throttle 0.9:
    model 5.5 m/s, simulator 8.3 m/s), which a boat running into a flood current reaches; with
    the slow delta_nu_u of the prediction filter the active-model law overran its speed there and
    swung off its legs.  A fast delta_nu_u also takes up a current along the bow on a straight run
    (the along-track current and a surge model error look alike until the boat turns), so the
    current the vehicle reports and holds by comes from :func:`current_filter_settings` run beside
    it (:class:`~companion.estimation.service.EstimatorStage`).  Measured in ``docs/tuning.md``
    ("A fast surge model error for the controller")."""
    prediction = current_filter_settings(r_diag)
    q = prediction.q_diag
    # without the estimate's transient noise (TRANSIENT_Q_S): the control tuning was measured without it
    return replace(prediction, q_diag=(*q[:3], CONTROL_SURGE_DELTA_NU_Q, *q[4:]),
                   q_nu_transient_s=(0.0, 0.0, 0.0))


def current_mahalanobis(current_ne: FloatArray, cov: FloatArray) -> float:
    """V_c^T P_c^-1 V_c: how many (squared) standard deviations the current is from still water."""
    try:
        return float(current_ne @ np.linalg.solve(cov, current_ne))
    except np.linalg.LinAlgError:
        return 0.0


def current_weight(mahalanobis: float, gate_chi2: float = CURRENT_GATE_CHI2) -> float:
    """Probability-like weight (0..1) that the estimated current is moving water rather than the
    model's own error: a logistic step of width 2 around ``gate_chi2`` (module docstring of
    :mod:`companion.models.active_prediction`)."""
    return 1.0 / (1.0 + math.exp(-max(-50.0, min(50.0, 0.5 * (mahalanobis - gate_chi2)))))


def measurement_matrix(psi_rad: float) -> FloatArray:
    """H(psi) of the module docstring, shape (3, 8)."""
    c, s = math.cos(psi_rad), math.sin(psi_rad)
    h = np.zeros((3, 8))
    h[0, 0] = h[1, 1] = h[2, 2] = 1.0
    h[0, 6], h[0, 7] = c, s
    h[1, 6], h[1, 7] = -s, c
    return h


class CurrentUKF(UKF):
    """UKF on x = [nu_r; delta_nu; V_c] with z = H(psi) x + noise (module docstring)."""

    n = 8

    def __init__(self, derivative: Derivative, settings: UKFSettings | None = None,
                 x0: FloatArray | None = None, p0: FloatArray | None = None) -> None:
        super().__init__(derivative, settings or UKFSettings(estimate_current=True), x0, p0)

    def update(self, z: FloatArray, psi_rad: float = 0.0) -> None:
        """UKF-IV (Eq. 10-11) with z = H(psi) x + noise, exact for this linear measurement."""
        h = measurement_matrix(psi_rad)
        p = self.P
        pht = p @ h.T
        s = h @ pht + self.R
        s_inv = np.linalg.inv(s)
        k = pht @ s_inv
        innov = np.asarray(z, dtype=float) - h @ self.x
        self.x = self.x + k @ innov
        a = np.eye(self.n) - k @ h
        p = a @ p @ a.T + k @ self.R @ k.T
        self.P = 0.5 * (p + p.T)
        self.nis = float(innov @ s_inv @ innov)

    @property
    def current_ne(self) -> FloatArray:
        return self.x[6:8]

    def nu_over_ground(self, psi_rad: float = 0.0) -> FloatArray:
        return np.asarray(measurement_matrix(psi_rad) @ self.x)


class QLPVFastCurrentUKF(CurrentUKF):
    """:class:`CurrentUKF` for a qLPV model, one compiled step
    (:func:`companion.models.ukf_kernel.qlpv_current_ukf_step`, same numbers, tested)."""

    def __init__(self, model: QLPVModel, settings: UKFSettings | None = None,
                 x0: FloatArray | None = None, p0: FloatArray | None = None) -> None:
        super().__init__(model.derivative, settings, x0, p0)
        from companion.models.ukf_kernel import qlpv_current_ukf_step

        self._kernel = qlpv_current_ukf_step
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
        self.nis, jit = self._kernel(self.x, self.P, self._z, float(throttle), float(delta_rad), float(dt_s),
                                     math.cos(psi_rad), math.sin(psi_rad), self._theta, self._c_thrust,
                                     q, self.R, self._wi, self._wc0, self._c)
        self.jitter_count += jit
        return self.x[3:6]
