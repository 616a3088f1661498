"""3-DOF surge/sway/yaw dynamics in Fossen's notation, and the RK4 step.

    eta_dot = R(psi) nu_r + v_c                                  (kinematics, current v_c in NED)
    M nu_r_dot + C_RB(nu_r) nu_r + C_A(nu_r) nu_r + D(nu_r) nu_r = tau_jet + tau_wind + tau_wave

with eta = [north_m, east_m, psi_rad], nu_r = [u, v, r] relative to the water (irrotational
current, Fossen 2021 Sec. 10.3), M = M_RB + M_A with the sway-yaw off-diagonal terms,
C_RB and C_A the rigid-body and added-mass Coriolis/centripetal matrices (Munk moment
included), and D(nu_r) made of

* linear damping plus speed-proportional hull lift (sway/yaw),
* cross-flow drag integrated over the hull length by 6-point Gauss quadrature,
* surge resistance that changes with the Froude number Fr = U / sqrt(g L): ITTC-57
  friction on a wetted area that shrinks as the hull rises to plane (Fr > 1), and a
  residual (wave-making) resistance hump over the semi-displacement range (0.5 < Fr < 1).

The water jet delivers momentum thrust T = rho A Vj (Vj - u) (falling with boat speed),
directed by the nozzle angle delta (positive = jet deflected so the boat turns to
starboard): tau_jet = [T cos delta, -T sin delta, -x_jet T sin delta].

This is deliberately *not* the chapter's qLPV structure (Eq. 3-4): resistance is not a
polynomial in |u|, yaw has a u*v Munk term and cross-flow terms in |v + x r|, thrust
depends on speed, and the hull changes with Fr; the qLPV model is an approximation of it.

The same :func:`nu_dot` serves one boat (Python floats and :mod:`math`) and a batch of
boats (numpy arrays): pass :data:`SCALAR` or :data:`VECTOR`.  One boat in the simulator
runs the compiled copy of these equations, :mod:`sim_bridge.plant_kernel`, which is tied
to them bit for bit by tests/sim/test_plant.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sim_bridge.hull import KINEMATIC_VISCOSITY_M2PS, RHO_WATER_KGPM3, Derived


@dataclass(frozen=True, slots=True)
class MathOps:
    """The elementary functions the dynamics needs, for floats or numpy arrays."""

    sin: Any
    cos: Any
    sqrt: Any
    tanh: Any
    log10: Any
    fabs: Any


SCALAR = MathOps(math.sin, math.cos, math.sqrt, math.tanh, math.log10, abs)
VECTOR = MathOps(np.sin, np.cos, np.sqrt, np.tanh, np.log10, np.abs)


def planing_fraction(froude: Any, xp: MathOps) -> Any:
    """0 in displacement (Fr < 0.5), rising through semi-displacement, ~1 planing (Fr > 1.5)."""
    return 0.5 * (1.0 + xp.tanh((froude - 1.0) * 4.0))


def surge_resistance_n(u_mps: Any, speed_mps: Any, d: Derived, xp: MathOps) -> Any:
    """Calm-water resistance (N, positive opposing forward motion) as a function of Fr."""
    p = d.p
    froude = speed_mps * d.inv_sqrt_gl
    s = planing_fraction(froude, xp)
    area_m2 = p.wetted_area_m2 * d.displacement_scale**2 * (1.0 - p.planing_area_loss * s)
    reynolds = speed_mps * p.length_m / KINEMATIC_VISCOSITY_M2PS + 1.0e5
    cf = 0.075 / (xp.log10(reynolds) - 2.0) ** 2
    friction = 0.5 * RHO_WATER_KGPM3 * area_m2 * (1.0 + p.form_factor) * cf * u_mps * xp.fabs(u_mps)
    x = froude / p.hump_froude
    x2 = x * x
    residual_ratio = p.hump_resistance_ratio * 2.0 * x2 / (1.0 + x2 * x2)
    residual = d.weight_n * residual_ratio * u_mps / (speed_mps + 1e-6)
    return friction + residual - p.x_u_nspm * u_mps


def jet_thrust_n(jet_speed_mps: Any, u_mps: Any, d: Derived) -> Any:
    """Momentum thrust of the water jet, falling linearly with the inflow speed."""
    return RHO_WATER_KGPM3 * d.p.jet_area_m2 * jet_speed_mps * (jet_speed_mps - u_mps)


def nu_dot(u: Any, v: Any, r: Any, jet_speed_mps: Any, cos_d: Any, sin_d: Any,
           tau_x: Any, tau_y: Any, tau_n: Any, d: Derived, xp: MathOps) -> tuple[Any, Any, Any]:
    """Accelerations [u_dot, v_dot, r_dot] relative to the water."""
    p = d.p
    m, xg = d.mass_kg, d.xg_m
    speed = xp.sqrt(u * u + v * v)
    froude = speed * d.inv_sqrt_gl
    s = planing_fraction(froude, xp)
    draft_m = p.draft_m * d.displacement_scale * (1.0 - p.planing_draft_loss * s)

    thrust = jet_thrust_n(jet_speed_mps, u, d)
    fx = thrust * cos_d - surge_resistance_n(u, speed, d, xp)
    fy = -thrust * sin_d
    fn = -p.jet_x_m * thrust * sin_d

    # linear damping with speed-proportional hull lift
    fy += (p.y_v_nspm + p.y_v_per_speed_nspm * speed) * v + p.y_r_nsprad * r
    fn += (p.n_v_nsm + p.n_v_per_speed_ns * speed) * v + (p.n_r_nmsprad + p.n_r_per_speed_nmsprad * speed) * r

    # cross-flow drag: -0.5 rho T Cd integral of |v + x r| (v + x r) [1, x] dx
    k = -0.5 * RHO_WATER_KGPM3 * draft_m * p.crossflow_cd
    for x_i, w_i in zip(d.strips_x_m, d.strips_w_m, strict=True):
        vc = v + x_i * r
        f = k * w_i * xp.fabs(vc) * vc
        fy += f
        fn += x_i * f

    # Coriolis/centripetal: C_RB(nu) nu + C_A(nu) nu (Fossen 2021, Eq. 6.43 and 6.50)
    b = p.y_vdot_kg * v + p.y_rdot_kgm * r
    a = p.x_udot_kg * u
    fx += m * (v + xg * r) * r - b * r
    fy += -m * u * r + a * r
    fn += -m * xg * u * r + b * u - a * v

    fx += tau_x
    fy += tau_y
    fn += tau_n
    mi = d.minv
    return (mi[0] * fx + mi[1] * fy + mi[2] * fn,
            mi[3] * fx + mi[4] * fy + mi[5] * fn,
            mi[6] * fx + mi[7] * fy + mi[8] * fn)


def rk4_step(x_n: Any, y_e: Any, psi: Any, u: Any, v: Any, r: Any, dt_s: float,
             jet_speed_mps: Any, delta_rad: Any, tau: tuple[Any, Any, Any],
             current_n_mps: Any, current_e_mps: Any, d: Derived, xp: MathOps) -> tuple[Any, ...]:
    """One classical Runge-Kutta 4 step of eta and nu_r with inputs held over the step.

    RK4 rather than forward Euler: at planing speed the sway/yaw modes are fast and
    lightly coupled through the Munk moment; Euler at 0.01 s adds energy there while RK4's
    stability region covers them with a wide margin (checked by tests/sim/test_plant.py).
    """
    cd, sd = xp.cos(delta_rad), xp.sin(delta_rad)
    tx, ty, tn = tau

    def f(ps: Any, uu: Any, vv: Any, rr: Any) -> tuple[Any, ...]:
        c, s = xp.cos(ps), xp.sin(ps)
        du, dv, dr = nu_dot(uu, vv, rr, jet_speed_mps, cd, sd, tx, ty, tn, d, xp)
        return (c * uu - s * vv + current_n_mps, s * uu + c * vv + current_e_mps, rr, du, dv, dr)

    h = dt_s
    k1 = f(psi, u, v, r)
    k2 = f(psi + 0.5 * h * k1[2], u + 0.5 * h * k1[3], v + 0.5 * h * k1[4], r + 0.5 * h * k1[5])
    k3 = f(psi + 0.5 * h * k2[2], u + 0.5 * h * k2[3], v + 0.5 * h * k2[4], r + 0.5 * h * k2[5])
    k4 = f(psi + h * k3[2], u + h * k3[3], v + h * k3[4], r + h * k3[5])
    h6 = h / 6.0
    state = (x_n, y_e, psi, u, v, r)
    return tuple(s + h6 * (a + 2.0 * b + 2.0 * c + e)
                 for s, a, b, c, e in zip(state, k1, k2, k3, k4, strict=True))
