"""One interface for every velocity model: derivative, free-run simulation, h-step prediction.

All models of the chapter (the qLPV model of Eq. 3-4 and the two linear baselines of
Table 3) are *linear in their parameters*: each row of ``nu_dot = f(nu, input)`` is a dot
product ``theta_j . phi_j(nu, throttle, delta)`` of a parameter row with a feature vector.
:class:`LinearInParamsModel` captures that once, so identification
(:mod:`companion.models.identify`), the UKF (:mod:`companion.models.ukf`), the
controller and the report all evaluate the very same code.

Arrays are vectorised: ``nu`` has shape ``(..., 3)`` (surge u m/s, sway v m/s, yaw rate
r rad/s), ``throttle`` (0..1) and ``delta_rad`` (nozzle angle) broadcast against
``nu[..., 0]``.  An optional additive model error ``delta_nu`` (chapter Eq. 5) is added to
the derivative.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

DOF_NAMES: tuple[str, str, str] = ("u", "v", "r")
"""Degrees of freedom in the order of nu = [u, v, r]."""


@dataclass(frozen=True)
class LinearInParamsModel:
    """``nu_dot[j] = sum_k theta[j, k] * phi_k(nu, throttle, delta)`` over the features in ``mask[j]``.

    Subclasses define :attr:`FEATURES` (names) and :meth:`features`.  ``theta`` has shape
    ``(3, n_features)``; entries outside ``mask`` are structurally zero.
    """

    theta: FloatArray
    name: str = "model"
    meta: dict[str, Any] = field(default_factory=dict)

    FEATURES: ClassVar[tuple[str, ...]] = ()
    MASK: ClassVar[tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]] = ((), (), ())

    def __post_init__(self) -> None:
        theta = np.asarray(self.theta, dtype=float)
        if theta.shape != (3, len(self.FEATURES)):
            raise ValueError(f"{type(self).__name__}: theta must have shape (3, {len(self.FEATURES)}), "
                             f"got {theta.shape}")
        object.__setattr__(self, "theta", theta * self.mask_array())

    @classmethod
    def mask_array(cls) -> FloatArray:
        """0/1 array (3, n_features): which features enter which DOF."""
        m = np.zeros((3, len(cls.FEATURES)))
        for j, names in enumerate(cls.MASK):
            for name in names:
                m[j, cls.FEATURES.index(name)] = 1.0
        return m

    def features(self, nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
        """Feature vectors, shape ``(..., n_features)``."""
        raise NotImplementedError

    def with_theta(self, theta: FloatArray, **meta: Any) -> LinearInParamsModel:
        return replace(self, theta=np.asarray(theta, dtype=float), meta={**self.meta, **meta})

    def derivative(self, nu: FloatArray, throttle: FloatArray | float, delta_rad: FloatArray | float,
                   delta_nu: FloatArray | None = None) -> FloatArray:
        """``nu_dot`` (Eq. 3, plus the model error of Eq. 5 when given), shape like ``nu``."""
        nu = np.asarray(nu, dtype=float)
        phi = self.features(nu, np.asarray(throttle, dtype=float), np.asarray(delta_rad, dtype=float))
        out: FloatArray = phi @ self.theta.T
        if delta_nu is not None:
            out = out + delta_nu
        return out

    def step(self, nu: FloatArray, throttle: FloatArray | float, delta_rad: FloatArray | float, dt_s: float,
             delta_nu: FloatArray | None = None) -> FloatArray:
        """One classical Runge-Kutta-4 step with the input held constant (zero-order hold)."""
        k1 = self.derivative(nu, throttle, delta_rad, delta_nu)
        k2 = self.derivative(nu + 0.5 * dt_s * k1, throttle, delta_rad, delta_nu)
        k3 = self.derivative(nu + 0.5 * dt_s * k2, throttle, delta_rad, delta_nu)
        k4 = self.derivative(nu + dt_s * k3, throttle, delta_rad, delta_nu)
        return np.asarray(nu + dt_s / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4))

    def simulate(self, t_s: FloatArray, nu0: FloatArray, throttle: FloatArray, delta_rad: FloatArray,
                 delta_nu: FloatArray | None = None) -> FloatArray:
        """Free-run simulation over an input record: returns nu at every ``t_s`` (shape (N, 3)).

        ``delta_nu`` (shape (N, 3)), when given, is the model error applied during each
        interval [t_k, t_k+1).  The state is clipped to a physical envelope so that a bad
        model diverging in free run yields a large, finite error index instead of overflow.
        """
        t_s = np.asarray(t_s, dtype=float)
        n = t_s.size
        out = np.empty((n, 3))
        out[0] = nu0
        nu = np.asarray(nu0, dtype=float)
        for k in range(n - 1):
            dn = None if delta_nu is None else delta_nu[k]
            nu = np.clip(self.step(nu, throttle[k], delta_rad[k], t_s[k + 1] - t_s[k], dn),
                         -NU_LIMIT, NU_LIMIT)
            out[k + 1] = nu
        return out

    def predict_ahead(self, t_s: FloatArray, nu_meas: FloatArray, throttle: FloatArray,
                      delta_rad: FloatArray, horizon_s: float,
                      delta_nu: FloatArray | None = None) -> tuple[NDArray[np.intp], FloatArray]:
        """h-step-ahead prediction: for every sample i >= h, start from the measured state at
        i - h and integrate the model over the recorded inputs to i.

        ``delta_nu`` (N, 3), when given, is the model error *estimated at the start* of each
        window (i - h) and held constant over the horizon, as the active model uses it.
        Returns ``(index, nu_pred)``: the sample indices predicted and the predictions.
        All windows are integrated at once (vectorised over start times).
        """
        t_s = np.asarray(t_s, dtype=float)
        dt = float(np.median(np.diff(t_s)))
        h = max(1, round(horizon_s / dt))
        n = t_s.size
        if n <= h:
            raise ValueError(f"record of {n} samples is shorter than the {horizon_s} s horizon")
        starts = np.arange(0, n - h)
        nu = np.array(nu_meas[starts], dtype=float)
        dn = None if delta_nu is None else np.asarray(delta_nu[starts], dtype=float)
        for k in range(h):
            idx = starts + k
            step_dt = (t_s[idx + 1] - t_s[idx])[:, None]
            nu = self.step_vec(nu, throttle[idx], delta_rad[idx], step_dt, dn)
        return np.asarray(starts + h, dtype=np.intp), nu

    def step_vec(self, nu: FloatArray, thr: FloatArray, dl: FloatArray, dt: FloatArray,
                 dn: FloatArray | None) -> FloatArray:
        """One RK4 step of many states at once (rows of ``nu``, per-row ``dt`` of shape (k, 1)),
        clipped to the envelope: the building block of :meth:`predict_ahead`."""
        k1 = self.derivative(nu, thr, dl, dn)
        k2 = self.derivative(nu + 0.5 * dt * k1, thr, dl, dn)
        k3 = self.derivative(nu + 0.5 * dt * k2, thr, dl, dn)
        k4 = self.derivative(nu + dt * k3, thr, dl, dn)
        return np.asarray(np.clip(nu + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), -NU_LIMIT, NU_LIMIT))

    def param_table(self) -> dict[str, dict[str, float]]:
        """Non-zero parameters per DOF, by feature name (for reports and params.toml)."""
        return {dof: {f: float(self.theta[j, k]) for k, f in enumerate(self.FEATURES) if f in self.MASK[j]}
                for j, dof in enumerate(DOF_NAMES)}


NU_LIMIT = np.array([30.0, 15.0, 5.0])
"""Physical envelope for simulated velocities (m/s, m/s, rad/s): well beyond a 10 m/s boat."""


def error_index(estimate: FloatArray, measured: FloatArray) -> FloatArray:
    """The chapter's error index J (Eq. 12) per column: RMS(est - real) / RMS(real)."""
    est = np.asarray(estimate, dtype=float)
    real = np.asarray(measured, dtype=float)
    num = np.sqrt(np.mean((est - real) ** 2, axis=0))
    den = np.sqrt(np.mean(real**2, axis=0))
    return np.asarray(num / np.where(den > 0, den, np.nan))
