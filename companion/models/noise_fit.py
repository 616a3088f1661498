"""Identify the active-model UKF's noise covariances (Q, R of Eq. 6-11) from the training logs.

The chapter's Eq. 13 gives Q and R for its boat and GPS-IMU; they are this project's defaults.
For another boat, sensor or water, ``usv identify`` also measures them from the same logs it
fits the model on, so a user can opt in (setting ``models.ukf_noise = "identified"``):

* R (measurement noise of z = nu, Eq. 5): the variance of the measurement about a short
  Savitzky-Golay fit (0.2 s, cubic), divided by ``1 - h0`` where ``h0`` is the filter's centre
  coefficient (the part of the noise the local fit itself absorbs), per DOF.
* Q (random-walk intensity of delta_nu, Eq. 5): the model error the data show,
  ``e = d/dt nu_s - f(nu_s, u)`` on the identification smoothing (``window_s``), changes over
  the prediction horizon h by ``Var(e(t + h) - e(t))``; a random walk of intensity q changes by
  ``q h`` in that time, so ``q = Var(e(t + h) - e(t)) / h``.  This sizes delta_nu's bandwidth to
  what persists over the horizon the active model predicts, instead of to the sensor noise.
  The Q rows of nu stay zero as in Eq. 13 (the structured model carries nu).

The result is a :class:`~companion.models.ukf.UKFSettings` with the chapter's alpha, beta
and kappa, Q read as a continuous intensity (Q dt per step) like the defaults.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.signal import savgol_coeffs, savgol_filter

from companion.models.base import FloatArray, LinearInParamsModel
from companion.models.identify import IdentificationError, smooth
from companion.models.logs import Record
from companion.models.ukf import UKFSettings

R_WINDOW_S = 0.2
R_POLYORDER = 3
Q_FLOOR = 1e-8
"""Smallest Q entry written ((m/s^2)^2/s), so the filter never freezes delta_nu entirely."""
R_FLOOR = 1e-8


def measurement_noise_var(records: Sequence[Record]) -> FloatArray:
    """Per-DOF variance of the measurement noise of nu (see module docstring), (3,)."""
    sq, n = np.zeros(3), 0
    for rec in records:
        win = max(R_POLYORDER + 2, round(R_WINDOW_S / rec.dt_s) | 1)
        if win >= len(rec):
            raise IdentificationError(f"{rec.name}: record shorter than the {R_WINDOW_S} s noise window")
        h0 = float(savgol_coeffs(win, R_POLYORDER)[win // 2])
        resid = rec.nu - savgol_filter(rec.nu, win, R_POLYORDER, axis=0, mode="interp")
        sq += np.sum(resid**2, axis=0) / (1.0 - h0)
        n += len(rec)
    return np.maximum(sq / n, R_FLOOR)


def model_error_increment_rate(model: LinearInParamsModel, records: Sequence[Record], horizon_s: float,
                               window_s: float = 2.0) -> FloatArray:
    """Per-DOF ``Var(e(t + h) - e(t)) / h`` of the model error the smoothed data show, (3,)."""
    incs = []
    for rec in records:
        nu_s, nu_dot = smooth(rec, window_s)
        err = nu_dot - model.derivative(nu_s, rec.throttle, rec.delta_rad)
        lag = max(1, round(horizon_s / rec.dt_s))
        if lag >= len(rec):
            raise IdentificationError(f"{rec.name}: record shorter than the {horizon_s} s horizon")
        incs.append(err[lag:] - err[:-lag])
    d = np.concatenate(incs)
    return np.maximum(np.var(d, axis=0) / horizon_s, Q_FLOOR)


def fit_ukf_noise(model: LinearInParamsModel, records: Sequence[Record], horizon_s: float = 1.0,
                  window_s: float = 2.0, base: UKFSettings | None = None) -> UKFSettings:
    """UKF settings with Q and R measured from ``records`` for ``model`` (module docstring)."""
    base = base or UKFSettings()
    r = measurement_noise_var(records)
    q = model_error_increment_rate(model, records, horizon_s, window_s)
    return UKFSettings(q_diag=(0.0, 0.0, 0.0, *map(float, q)), r_diag=tuple(map(float, r)),
                       alpha=base.alpha, beta=base.beta, kappa=base.kappa, q_discretization="rate")
