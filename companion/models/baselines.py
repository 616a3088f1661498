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

from companion.models.base import FloatArray, LinearInParamsModel

LINEAR_FEATURES: tuple[str, ...] = ("1", "u", "throttle", "v", "r", "delta")


def _linear_features(nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
    u, v, r = nu[..., 0], nu[..., 1], nu[..., 2]
    return np.stack(np.broadcast_arrays(np.ones_like(u), u, throttle, v, r, delta_rad), axis=-1)


@dataclass(frozen=True)
class LinearizedModel(LinearInParamsModel):
    """Linearised speed-and-steering model (Table 3, first column)."""

    FEATURES = LINEAR_FEATURES
    MASK = (("1", "u", "throttle"), ("v", "r", "delta"), ("v", "r", "delta"))

    def features(self, nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
        return _linear_features(nu, throttle, delta_rad)


@dataclass(frozen=True)
class NomotoSideslipModel(LinearInParamsModel):
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
