"""Surge row of the active-model controller (chapter Fig. 6): speed law with model-error compensation.

The surge row of the qLPV model (Eq. 3-5) is

    u_dot = [A(nu) nu]_u + b_u * T cos(delta) + delta_nu_u

Feedback linearisation picks the desired surge acceleration from stable first-order error
dynamics ``u_dot_d = sat(k_u (u_d - u), -a_dec, a_acc)`` and solves the row for the surge
component of the normalised thrust ``T cos delta = (u_dot_d - [A nu]_u - dnu_u) / b_u``, where
``dnu_u`` is the UKF's model-error estimate (Eq. 5-11) through a first-order low-pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.control.pid import LowPass
from companion.messages import NavState
from companion.models.qlpv import QLPVModel


@dataclass(frozen=True, slots=True)
class AmSpeedConfig:
    k_per_s: float = 0.8
    """k_u: bandwidth of the speed error dynamics (1/s)."""
    accel_max_mps2: float = 1.5
    decel_max_mps2: float = 1.0
    model_error_tau_s: float = 1.0
    """Low-pass time constant on delta_nu_u."""
    min_thrust: float = 0.0025
    """Smallest normalised thrust the law asks for, so the nozzle keeps some authority."""


class AmSpeedLaw:
    """Desired surge acceleration and surge thrust demand ``T cos delta`` (normalised)."""

    def __init__(self, model: QLPVModel, cfg: AmSpeedConfig | None = None) -> None:
        self.model = model
        self.cfg = cfg or AmSpeedConfig()
        b_u = float(model.b_matrix()[0, 1])
        if b_u <= 0:
            raise ValueError(f"model {model.name!r} has no surge control authority (b_u = {b_u})")
        self._b_u = b_u
        self._dnu_lp = LowPass(self.cfg.model_error_tau_s, 0.0)
        self.last_accel_mps2 = 0.0
        """Last desired surge acceleration u_dot_d (m/s^2)."""

    def reset(self, nav: NavState) -> None:
        """Keep the disturbance estimate (it describes the water, not the manoeuvre)."""

    def accel_demand(self, nav: NavState, speed_mps: float, dt_s: float) -> float:
        """``u_dot_d = sat(k_u (u_d - u), -a_dec, a_acc)`` (m/s^2)."""
        c = self.cfg
        a = c.k_per_s * (speed_mps - nav.u_mps)
        return min(c.accel_max_mps2, max(-c.decel_max_mps2, a))

    def thrust_demand(self, nav: NavState, speed_mps: float, delta_nu_u_mps2: float, dt_s: float) -> float:
        """Surge thrust demand ``T cos delta`` from the inverted surge row (>= min_thrust).

        ``delta_nu_u_mps2`` is the latest raw UKF model-error estimate of the surge row (0 when
        compensation is off); the law filters it itself."""
        nu = np.array([nav.u_mps, nav.v_mps, nav.r_radps])
        f_u = float((self.model.a_of_nu(nu) @ nu)[0])
        dnu_u = self._dnu_lp.step(delta_nu_u_mps2, dt_s)
        u_dot_d = self.accel_demand(nav, speed_mps, dt_s)
        self.last_accel_mps2 = u_dot_d
        return max(self.cfg.min_thrust, (u_dot_d - f_u - dnu_u) / self._b_u)
