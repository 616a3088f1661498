"""Surge row of the active-model controller (chapter Fig. 6): speed law with model-error compensation.

The surge row of the qLPV model (Eq. 3-5) is

    u_dot = [A(nu) nu]_u + b_u * T cos(delta) + delta_nu_u

Feedback linearisation picks the desired surge acceleration and solves the row for the surge
component of the normalised thrust ``T cos delta = (u_dot_d - [A nu]_u - dnu_u) / b_u``, where
``dnu_u`` is the UKF's model-error estimate delta_nu (Eq. 5-11): wind, drift, wave drift and
model mismatch are cancelled by the disturbance observer instead of an integrator.

Desired acceleration.  ``u_dot_d = sat(a_r + k_u (u_r - u), -a_dec, a_acc)``.  By default the
reference is the command itself (``u_r = u_d``, ``a_r = 0``), so a speed step has no overshoot of
its own.  An optional critically damped reference model (``ref_radps``; Fossen 2021, section
12.1) shapes increases of the command; it is off by default because it delays the speed changes
the path follower asks for at corners.

Wave filtering.  The first-order wave surge force (met at 0.6-1.6 Hz) cannot be cancelled
through the engine's 0.4 s lag and the throttle's slew limit (the bound is
:func:`benchmarks.control_scenarios.speed_wave_floor`), and the UKF's delta_nu_u lags it, so
feeding delta_nu_u back at wave frequency only adds motion.  The law therefore passes delta_nu_u
through a second-order Butterworth low-pass at ``dnu_cutoff_radps``, which rejects gusts, drift
and mismatch quickly and damps the wave motion.  How the defaults were chosen, with the figures
measured at the time: ``docs/tuning.md``.

Braking.  A speed excess beyond ``brake_deadband_mps`` is corrected with the firmer
``brake_k_per_s``, so the path follower's slow-down before a corner or the last waypoint is
tracked closely while the wave ripple about the command still sees ``k_u`` alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from companion.messages import NavState
from companion.models.qlpv import QLPVModel

SQRT2 = math.sqrt(2.0)
STALE_S = 0.5
"""A gap of more than this between updates (the law was not running) restarts the reference."""


@dataclass(frozen=True, slots=True)
class AmSpeedConfig:
    k_per_s: float = 0.5
    """k_u: bandwidth of the speed error dynamics (1/s)."""
    brake_k_per_s: float = 1.0
    """k_u for the part of a speed excess beyond ``brake_deadband_mps`` (1/s): braking for a
    corner or the last waypoint is firmer, the wave ripple about the command (centimetres per
    second) still sees ``k_u`` alone.  A first-order law lags a braking profile of deceleration
    a by ``a / k_u``; with ``k_u`` alone the boat reaches a station point too fast to stop there."""
    brake_deadband_mps: float = 0.3
    accel_max_mps2: float = 1.5
    decel_max_mps2: float = 1.0
    ref_radps: float = 0.0
    """Natural frequency of the critically damped reference model on the speed command
    (0: no reference model, the error law acts on the raw command)."""
    dnu_cutoff_radps: float = 5.0
    """Cut-off of the second-order Butterworth low-pass on delta_nu_u (rad/s)."""
    min_thrust: float = 0.0025
    """Smallest normalised thrust the law asks for, so the nozzle keeps some authority."""

    def __post_init__(self) -> None:
        vals = (self.k_per_s, self.brake_k_per_s, self.brake_deadband_mps, self.accel_max_mps2,
                self.decel_max_mps2, self.ref_radps, self.dnu_cutoff_radps)
        if not all(math.isfinite(v) and v >= 0.0 for v in vals) or self.dnu_cutoff_radps == 0.0:
            raise ValueError(f"invalid active-model speed settings {self}")


class SecondOrderLowPass:
    """Butterworth low-pass ``wc^2 / (s^2 + sqrt(2) wc s + wc^2)``, semi-implicit Euler."""

    def __init__(self, cutoff_radps: float, initial: float = 0.0) -> None:
        self.cutoff_radps = cutoff_radps
        self.value = initial
        self.rate = 0.0

    def step(self, x: float, dt_s: float) -> float:
        wc = self.cutoff_radps
        self.rate += dt_s * (wc * wc * (x - self.value) - SQRT2 * wc * self.rate)
        self.value += dt_s * self.rate
        return self.value


class AmSpeedLaw:
    """Desired surge acceleration and surge thrust demand ``T cos delta`` (normalised)."""

    def __init__(self, model: QLPVModel, cfg: AmSpeedConfig | None = None) -> None:
        self.model = model
        self.cfg = cfg or AmSpeedConfig()
        b_u = float(model.b_matrix()[0, 1])
        if b_u <= 0:
            raise ValueError(f"model {model.name!r} has no surge control authority (b_u = {b_u})")
        self._b_u = b_u
        self._dnu = SecondOrderLowPass(self.cfg.dnu_cutoff_radps)
        self._ref_mps: float | None = None
        self._ref_accel_mps2 = 0.0
        self._last_t_s: float | None = None

    def reset(self) -> None:
        """Restart the reference model on the next command (keep the disturbance estimate: it
        describes the water, not the manoeuvre)."""
        self._ref_mps = None

    @property
    def reference_mps(self) -> float | None:
        """The reference speed u_r of the last update (None before the first)."""
        return self._ref_mps

    def accel_demand(self, nav: NavState, speed_mps: float, dt_s: float) -> float:
        """``u_dot_d = sat(a_r + k_u (u_r - u), -a_dec, a_acc)`` (m/s^2)."""
        c = self.cfg
        if self._last_t_s is not None and abs(nav.t_s - self._last_t_s) > STALE_S:
            self.reset()
        self._last_t_s = nav.t_s
        if c.ref_radps <= 0.0 or self._ref_mps is None or speed_mps <= self._ref_mps:
            u_r, a_r = speed_mps, 0.0  # slowing down (e.g. for a corner) is not delayed
        else:
            w = c.ref_radps
            a_r = self._ref_accel_mps2 + dt_s * (w * w * (speed_mps - self._ref_mps)
                                                 - 2.0 * w * self._ref_accel_mps2)
            a_r = min(c.accel_max_mps2, max(-c.decel_max_mps2, a_r))
            u_r = self._ref_mps + dt_s * a_r
        self._ref_mps, self._ref_accel_mps2 = u_r, a_r
        e = u_r - nav.u_mps
        a = a_r + c.k_per_s * e + (c.brake_k_per_s - c.k_per_s) * min(0.0, e + c.brake_deadband_mps)
        return min(c.accel_max_mps2, max(-c.decel_max_mps2, a))

    def thrust_demand(self, nav: NavState, speed_mps: float, delta_nu_u_mps2: float, dt_s: float,
                      f_u_mps2: float | None = None) -> float:
        """Surge thrust demand ``T cos delta`` from the inverted surge row (>= min_thrust).

        ``delta_nu_u_mps2`` is the latest raw UKF model-error estimate of the surge row (0 when
        compensation is off); the law filters it itself.  ``f_u_mps2``: ``[A(nu) nu]_u`` if the
        caller has already evaluated it this period (computed here otherwise)."""
        if not math.isfinite(speed_mps):  # bad command: hold the reference, never raise
            speed_mps = self._ref_mps if self._ref_mps is not None else nav.u_mps
        if f_u_mps2 is None:
            nu = np.array([nav.u_mps, nav.v_mps, nav.r_radps])
            f_u_mps2 = float((self.model.a_of_nu(nu) @ nu)[0])
        f_u = f_u_mps2
        raw = delta_nu_u_mps2 if math.isfinite(delta_nu_u_mps2) else self._dnu.value
        dnu_u = self._dnu.step(raw, dt_s)
        u_dot_d = self.accel_demand(nav, speed_mps, dt_s)
        return max(self.cfg.min_thrust, (u_dot_d - f_u - dnu_u) / self._b_u)
