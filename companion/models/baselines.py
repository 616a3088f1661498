"""The two linear baselines of the chapter's Table 3, in the common model interface.

Linearised speed and steering model (Fossen 1994; chapter ref. [14]): the speed model relates
the speed increment to the throttle increment, the steering model relates sway velocity
and yaw rate linearly to the nozzle angle, both about the operating point (absorbed in
the constant term):

    u_dot = a0 + a1 u + a2 throttle
    v_dot = c1 v + c2 r + c3 delta
    r_dot = d1 v + d2 r + d3 delta

First-order Nomoto model with first-order sideslip (chapter refs. [12], [13]): the yaw rate
follows T r_dot + r = K delta; the sideslip angle beta ~ v/U lags the turn rate,
T_b v_dot + v = K_b r; surge uses the same linear speed model (the Nomoto model has none):

    u_dot = a0 + a1 u + a2 throttle
    v_dot = c1 v + c2 r                (T_b = -1/c1, K_b = -c2/c1)
    r_dot = d2 r + d3 delta            (T = -1/d2,  K = -d3/d2)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.models.base import NU_LIMIT, FloatArray, LinearInParamsModel

LINEAR_FEATURES: tuple[str, ...] = ("1", "u", "throttle", "v", "r", "delta")


def _linear_features(nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
    u, v, r = nu[..., 0], nu[..., 1], nu[..., 2]
    return np.stack(np.broadcast_arrays(np.ones_like(u), u, throttle, v, r, delta_rad), axis=-1)


@dataclass(frozen=True)
class _AffineModel(LinearInParamsModel):
    """A model whose features are affine in nu: ``nu_dot = A nu + b(throttle, delta)``.

    Its free run is the same RK4 with zero-order-hold input and the same clipping as
    :meth:`LinearInParamsModel.simulate`, with ``b`` of every interval computed up front and the
    steps compiled (:func:`companion.models.affine_kernel.affine_simulate`; the baselines are
    simulated dozens of times by ``usv identify``).  :meth:`simulate_python` is the same loop on
    Python floats, the readable reference (the same numbers).
    """

    def simulate(self, t_s: FloatArray, nu0: FloatArray, throttle: FloatArray, delta_rad: FloatArray,
                 delta_nu: FloatArray | None = None) -> FloatArray:
        if delta_nu is not None:
            return super().simulate(t_s, nu0, throttle, delta_rad, delta_nu)
        from companion.models.affine_kernel import affine_simulate

        t = np.asarray(t_s, dtype=float)
        a, b = self._affine_terms(throttle, delta_rad)
        return np.asarray(affine_simulate(np.ascontiguousarray(a), np.ascontiguousarray(b), np.diff(t),
                                          np.array(nu0, dtype=float).reshape(3), NU_LIMIT))

    def _affine_terms(self, throttle: FloatArray, delta_rad: FloatArray) -> tuple[FloatArray, FloatArray]:
        """A (3, 3; columns u, v, r) and b of every sample (N, 3)."""
        names = ("1", "u", "throttle", "v", "r", "delta")
        i1, iu, ithr, iv, ir, idl = (LINEAR_FEATURES.index(name) for name in names)
        th = self.theta
        b = (th[:, i1][None, :] + np.asarray(throttle, dtype=float)[:, None] * th[:, ithr][None, :]
             + np.asarray(delta_rad, dtype=float)[:, None] * th[:, idl][None, :])
        return th[:, [iu, iv, ir]], b

    def simulate_python(self, t_s: FloatArray, nu0: FloatArray, throttle: FloatArray, delta_rad: FloatArray
                        ) -> FloatArray:
        """:meth:`simulate` (no ``delta_nu``) on Python floats: the readable reference."""
        t = np.asarray(t_s, dtype=float)
        n = t.size
        a_arr, b_arr = self._affine_terms(throttle, delta_rad)
        a, b = a_arr.tolist(), b_arr.tolist()
        dts = np.diff(t).tolist()
        lim = NU_LIMIT.tolist()
        (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
        out = np.empty((n, 3))
        out[0] = nu0
        u, v, r = (float(x) for x in np.asarray(nu0, dtype=float))

        def f(u: float, v: float, r: float, bk: list[float]) -> tuple[float, float, float]:
            return (a00 * u + a01 * v + a02 * r + bk[0], a10 * u + a11 * v + a12 * r + bk[1],
                    a20 * u + a21 * v + a22 * r + bk[2])

        for k in range(n - 1):
            dt, bk = dts[k], b[k]
            k1 = f(u, v, r, bk)
            k2 = f(u + 0.5 * dt * k1[0], v + 0.5 * dt * k1[1], r + 0.5 * dt * k1[2], bk)
            k3 = f(u + 0.5 * dt * k2[0], v + 0.5 * dt * k2[1], r + 0.5 * dt * k2[2], bk)
            k4 = f(u + dt * k3[0], v + dt * k3[1], r + dt * k3[2], bk)
            u = min(max(u + dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]), -lim[0]), lim[0])
            v = min(max(v + dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]), -lim[1]), lim[1])
            r = min(max(r + dt / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]), -lim[2]), lim[2])
            out[k + 1] = (u, v, r)
        return out


@dataclass(frozen=True)
class LinearizedModel(_AffineModel):
    """Linearised speed-and-steering model (Table 3, first column)."""

    FEATURES = LINEAR_FEATURES
    MASK = (("1", "u", "throttle"), ("v", "r", "delta"), ("v", "r", "delta"))

    def features(self, nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
        return _linear_features(nu, throttle, delta_rad)


@dataclass(frozen=True)
class NomotoSideslipModel(_AffineModel):
    """First-order Nomoto yaw model with first-order sideslip lag (Table 3, second column)."""

    FEATURES = LINEAR_FEATURES
    MASK = (("1", "u", "throttle"), ("v", "r"), ("r", "delta"))

    def features(self, nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
        return _linear_features(nu, throttle, delta_rad)

    def nomoto_constants(self) -> dict[str, float]:
        """Time constants (s) and gains of the Nomoto and sideslip lags."""
        c1, c2 = self.theta[1, 3], self.theta[1, 4]
        d2, d3 = self.theta[2, 4], self.theta[2, 5]
        out: dict[str, float] = {}
        if d2 != 0:
            out.update(T_s=float(-1 / d2), K_per_s=float(-d3 / d2))
        if c1 != 0:
            out.update(T_beta_s=float(-1 / c1), K_beta_m=float(-c2 / c1))
        return out
