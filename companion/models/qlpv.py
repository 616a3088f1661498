"""The chapter's quasi-LPV model (Eq. 3-4) with an identified water-jet thrust map.

    nu_dot = A(nu) nu + B u,   A(nu) = M^-1 (N0 + N1|u| + N2|v| + N3 r + N4|r|),
    u = T [sin delta, cos delta]^T,   B = M^-1 [[0, -1, x_delta], [1, 0, 0]]^T.

Only the products M^-1 N_k and M^-1 B are identifiable from motion data (no force
measurements), so the model stores these *lumped* matrices.  With the block-diagonal
M of a port-starboard symmetric hull (surge decoupled from sway-yaw), M^-1 N_k keeps the
sparsity of N_k, and each DOF is linear in the chapter's regressors:

    u_dot = a1 u + a2 |u|u + a3 v r + a4 r^2 + b_u T cos(delta)                 (N0, N1, N3, B)
    v_dot = c1 v + c2 r + c3 |v|v + c4 |r|r + c5 u r + b_v T sin(delta)         (N0, N2, N4, N3, B)
    r_dot = d1 v + d2 r + d3 |v|v + d4 |r|r + d5 u r + b_r T sin(delta)

Thrust map.  The thrust T is not measured on the boat.  We use the water-jet momentum
law T = rho Q (V_jet - u) with flow Q and jet speed V_jet both proportional to the pump
speed, i.e. to throttle:  T = k1 throttle^2 - k2 throttle u.  k1 is not separable from
M^-1 (it scales B), so the model uses the normalised thrust T~ = throttle^2 - c throttle u
with c = k2/k1 (s/m) identified together with the rest (see
:mod:`companion.models.identify`), and B carries k1 M^-1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.models.base import NU_LIMIT, FloatArray, LinearInParamsModel

QLPV_FEATURES: tuple[str, ...] = ("u", "|u|u", "vr", "rr", "Tcos", "v", "r", "|v|v", "|r|r", "ur", "Tsin")
QLPV_MASK = (
    ("u", "|u|u", "vr", "rr", "Tcos"),
    ("v", "r", "|v|v", "|r|r", "ur", "Tsin"),
    ("v", "r", "|v|v", "|r|r", "ur", "Tsin"),
)
FEATURE_SIGNALS: dict[str, tuple[str, ...]] = {
    "1": (), "u": ("u",), "|u|u": ("u",), "vr": ("v", "r"), "rr": ("r",), "Tcos": ("throttle", "delta"),
    "v": ("v",), "r": ("r",), "|v|v": ("v",), "|r|r": ("r",), "ur": ("u", "r"),
    "Tsin": ("throttle", "delta"), "throttle": ("throttle",), "delta": ("delta",),
}
"""Which recorded signals each regressor is built from (named in identifiability errors)."""


@dataclass(frozen=True)
class QLPVModel(LinearInParamsModel):
    """qLPV model of Eq. 3-4; ``thrust_speed_coeff`` is c in T~ = throttle^2 - c throttle u."""

    thrust_speed_coeff: float = 0.0
    FEATURES = QLPV_FEATURES
    MASK = QLPV_MASK

    def thrust(self, throttle: FloatArray | float, u_mps: FloatArray | float) -> FloatArray:
        """Normalised thrust T~ = throttle^2 - c throttle u, never negative (a jet cannot pull)."""
        thr = np.asarray(throttle, dtype=float)
        return np.asarray(np.maximum(thr * thr - self.thrust_speed_coeff * thr * np.asarray(u_mps), 0.0))

    def features(self, nu: FloatArray, throttle: FloatArray, delta_rad: FloatArray) -> FloatArray:
        u, v, r = nu[..., 0], nu[..., 1], nu[..., 2]
        t = self.thrust(throttle, u)
        return np.stack(np.broadcast_arrays(
            u, np.abs(u) * u, v * r, r * r, t * np.cos(delta_rad),
            v, r, np.abs(v) * v, np.abs(r) * r, u * r, t * np.sin(delta_rad)), axis=-1)

    def simulate(self, t_s: FloatArray, nu0: FloatArray, throttle: FloatArray, delta_rad: FloatArray,
                 delta_nu: FloatArray | None = None) -> FloatArray:
        """:meth:`LinearInParamsModel.simulate` (RK4, inputs held, state clipped), compiled
        (:func:`companion.models.qlpv_kernel.qlpv_simulate`): the same numbers to rounding."""
        from companion.models.qlpv_kernel import qlpv_simulate

        def arr(x: FloatArray | None) -> FloatArray:
            return np.ascontiguousarray(x, dtype=float)

        t = arr(t_s)
        dn = np.zeros((t.size, 3)) if delta_nu is None else arr(delta_nu)
        return np.asarray(qlpv_simulate(t, np.array(nu0, dtype=float), arr(throttle), arr(delta_rad),
                                        arr(self.theta), float(self.thrust_speed_coeff), dn, NU_LIMIT))

    # --- the chapter's matrix form, for model-based controllers -------------------------------
    def _p(self, dof: int, name: str) -> float:
        return float(self.theta[dof, self.FEATURES.index(name)])

    def a_matrices(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        """Lumped M^-1 N0 .. M^-1 N4 (Eq. 4), each 3x3."""
        p = self._p
        a0 = np.array([[p(0, "u"), 0, 0], [0, p(1, "v"), p(1, "r")], [0, p(2, "v"), p(2, "r")]])
        a1 = np.zeros((3, 3))
        a1[0, 0] = p(0, "|u|u")
        a2 = np.zeros((3, 3))
        a2[1, 1], a2[2, 1] = p(1, "|v|v"), p(2, "|v|v")
        a3 = np.array([[0, p(0, "vr"), p(0, "rr")], [p(1, "ur"), 0, 0], [p(2, "ur"), 0, 0]])
        a4 = np.zeros((3, 3))
        a4[1, 2], a4[2, 2] = p(1, "|r|r"), p(2, "|r|r")
        return a0, a1, a2, a3, a4

    def a_of_nu(self, nu: FloatArray) -> FloatArray:
        """A(nu) of Eq. 4 at one state."""
        a0, a1, a2, a3, a4 = self.a_matrices()
        u, v, r = (float(x) for x in nu)
        return np.asarray(a0 + a1 * abs(u) + a2 * abs(v) + a3 * r + a4 * abs(r))

    def b_matrix(self) -> FloatArray:
        """B of Eq. 3 (3x2) acting on the input T~ [sin delta, cos delta]^T."""
        p = self._p
        return np.array([[0.0, p(0, "Tcos")], [p(1, "Tsin"), 0.0], [p(2, "Tsin"), 0.0]])
