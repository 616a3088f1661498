"""Compiled (numba) one-boat physics step: RK4 of eta and nu_r, then what the plant reports.

The same equations as the readable reference, :func:`sim_bridge.dynamics.nu_dot` and
:func:`sim_bridge.dynamics.rk4_step` with :data:`~sim_bridge.dynamics.SCALAR`, in the same
floating-point operation order, so the results are bit-identical (checked against the
reference by tests/sim/test_plant.py and end to end by tests/sim/test_golden.py); the hull
constants are precomputed once (:func:`hull_constants`) and the Froude-number terms shared
between resistance and draft.  About 20x cheaper per step than the Python version, which
was most of the simulator's share of a lockstep SITL step.

Two details keep the floats identical to CPython's:

* ``(log10(Re) - 2) ** 2`` in the ITTC-57 line: CPython computes ``x ** 2`` with the C
  library's ``pow``, which differs from ``x * x`` in the last bit for ~0.1 % of arguments.
  LLVM rewrites ``pow(x, 2.0)`` with a constant exponent into ``x * x``, so the exponent is
  read from the constants array (:data:`K_TWO`), which the compiler cannot fold.
* no ``fastmath``: no reassociation and no fused multiply-add contraction.

The function is compiled once per machine (``cache=True``, like the UKF kernel).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim_bridge.hull import KINEMATIC_VISCOSITY_M2PS, RHO_WATER_KGPM3, Derived

# indices into the constants array of :func:`hull_constants`
K_INV_SQRT_GL = 0
K_AREA0 = 1
K_LOSS_AREA = 2
K_LOSS_DRAFT = 3
K_LENGTH = 4
K_HALF_RHO = 5
K_ONE_PLUS_FORM = 6
K_HUMP_FROUDE = 7
K_HUMP_RATIO_2 = 8
K_WEIGHT = 9
K_X_U = 10
K_DRAFT0 = 11
K_RHO_JET_AREA = 12
K_NEG_JET_X = 13
K_Y_V = 14
K_Y_V_SPEED = 15
K_Y_R = 16
K_N_V = 17
K_N_V_SPEED = 18
K_N_R = 19
K_N_R_SPEED = 20
K_NEG_HALF_RHO = 21
K_CROSSFLOW_CD = 22
K_MASS = 23
K_XG = 24
K_NEG_MASS = 25
K_NEG_MASS_XG = 26
K_Y_VDOT = 27
K_Y_RDOT = 28
K_X_UDOT = 29
K_KIN_VISC = 30
K_TWO = 31
K_TWO_PI = 32
K_MINV = 33  # 9 entries, row-major M^-1
K_STRIP_X = K_MINV + 9  # N_STRIPS entries
N_STRIPS = 6
K_STRIP_W = K_STRIP_X + N_STRIPS
N_CONSTANTS = K_STRIP_W + N_STRIPS


def hull_constants(d: Derived) -> np.ndarray:
    """The numbers :func:`plant_step` needs, computed as the reference computes them."""
    p = d.p
    ds = d.displacement_scale
    if len(d.strips_x_m) != N_STRIPS:
        raise ValueError(f"the compiled step integrates cross-flow over {N_STRIPS} strips")
    k = np.empty(N_CONSTANTS)
    k[K_INV_SQRT_GL] = d.inv_sqrt_gl
    k[K_AREA0] = p.wetted_area_m2 * ds**2
    k[K_LOSS_AREA], k[K_LOSS_DRAFT] = p.planing_area_loss, p.planing_draft_loss
    k[K_LENGTH], k[K_HALF_RHO], k[K_ONE_PLUS_FORM] = p.length_m, 0.5 * RHO_WATER_KGPM3, 1.0 + p.form_factor
    k[K_HUMP_FROUDE], k[K_HUMP_RATIO_2] = p.hump_froude, p.hump_resistance_ratio * 2.0
    k[K_WEIGHT], k[K_X_U] = d.weight_n, p.x_u_nspm
    k[K_DRAFT0] = p.draft_m * ds
    k[K_RHO_JET_AREA] = RHO_WATER_KGPM3 * p.jet_area_m2
    k[K_NEG_JET_X] = -p.jet_x_m
    k[K_Y_V], k[K_Y_V_SPEED], k[K_Y_R] = p.y_v_nspm, p.y_v_per_speed_nspm, p.y_r_nsprad
    k[K_N_V], k[K_N_V_SPEED] = p.n_v_nsm, p.n_v_per_speed_ns
    k[K_N_R], k[K_N_R_SPEED] = p.n_r_nmsprad, p.n_r_per_speed_nmsprad
    k[K_NEG_HALF_RHO], k[K_CROSSFLOW_CD] = -0.5 * RHO_WATER_KGPM3, p.crossflow_cd
    k[K_MASS], k[K_XG] = d.mass_kg, d.xg_m
    k[K_NEG_MASS], k[K_NEG_MASS_XG] = -d.mass_kg, -d.mass_kg * d.xg_m
    k[K_Y_VDOT], k[K_Y_RDOT], k[K_X_UDOT] = p.y_vdot_kg, p.y_rdot_kgm, p.x_udot_kg
    k[K_KIN_VISC] = KINEMATIC_VISCOSITY_M2PS
    k[K_TWO] = 2.0
    k[K_TWO_PI] = 2.0 * math.pi
    k[K_MINV:K_MINV + 9] = d.minv
    k[K_STRIP_X:K_STRIP_X + N_STRIPS] = d.strips_x_m
    k[K_STRIP_W:K_STRIP_W + N_STRIPS] = d.strips_w_m
    return k


@njit(cache=True)
def _nu_dot(uu: float, vv: float, rr: float, jet: float, cd: float, sd: float, tx: float, ty: float,
            tn: float, k: np.ndarray) -> tuple[float, float, float]:
    """[u_dot, v_dot, r_dot] = M^-1 (tau_jet - D(nu_r) nu_r - C(nu_r) nu_r + tau), as
    :func:`sim_bridge.dynamics.nu_dot`."""
    speed = math.sqrt(uu * uu + vv * vv)
    froude = speed * k[K_INV_SQRT_GL]
    s = 0.5 * (1.0 + math.tanh((froude - 1.0) * 4.0))  # planing fraction
    draft_m = k[K_DRAFT0] * (1.0 - k[K_LOSS_DRAFT] * s)
    # surge resistance: ITTC-57 friction on the wetted area + residual hump
    area_m2 = k[K_AREA0] * (1.0 - k[K_LOSS_AREA] * s)
    reynolds = speed * k[K_LENGTH] / k[K_KIN_VISC] + 1.0e5
    cf = 0.075 / (math.log10(reynolds) - 2.0) ** k[K_TWO]
    friction = k[K_HALF_RHO] * area_m2 * k[K_ONE_PLUS_FORM] * cf * uu * abs(uu)
    x = froude / k[K_HUMP_FROUDE]
    x2 = x * x
    residual = k[K_WEIGHT] * (k[K_HUMP_RATIO_2] * x2 / (1.0 + x2 * x2)) * uu / (speed + 1e-6)
    resistance = friction + residual - k[K_X_U] * uu
    # water jet
    thrust = k[K_RHO_JET_AREA] * jet * (jet - uu)
    fx = thrust * cd - resistance
    fy = -thrust * sd
    fn = k[K_NEG_JET_X] * thrust * sd
    # linear damping with speed-proportional hull lift
    fy += (k[K_Y_V] + k[K_Y_V_SPEED] * speed) * vv + k[K_Y_R] * rr
    fn += (k[K_N_V] + k[K_N_V_SPEED] * speed) * vv + (k[K_N_R] + k[K_N_R_SPEED] * speed) * rr
    # cross-flow drag over the hull strips
    kc = k[K_NEG_HALF_RHO] * draft_m * k[K_CROSSFLOW_CD]
    for i in range(N_STRIPS):
        x_i = k[K_STRIP_X + i]
        vc = vv + x_i * rr
        ff = kc * k[K_STRIP_W + i] * abs(vc) * vc
        fy += ff
        fn += x_i * ff
    # Coriolis/centripetal C_RB(nu) nu + C_A(nu) nu
    b = k[K_Y_VDOT] * vv + k[K_Y_RDOT] * rr
    a = k[K_X_UDOT] * uu
    fx += k[K_MASS] * (vv + k[K_XG] * rr) * rr - b * rr
    fy += k[K_NEG_MASS] * uu * rr + a * rr
    fn += k[K_NEG_MASS_XG] * uu * rr + b * uu - a * vv
    fx += tx
    fy += ty
    fn += tn
    m = K_MINV
    return (k[m] * fx + k[m + 1] * fy + k[m + 2] * fn,
            k[m + 3] * fx + k[m + 4] * fy + k[m + 5] * fn,
            k[m + 6] * fx + k[m + 7] * fy + k[m + 8] * fn)


@njit(cache=True)
def _eta_nu_dot(psi: float, u: float, v: float, r: float, jet: float, cd: float, sd: float, tx: float,
                ty: float, tn: float, cn: float, ce: float, k: np.ndarray
                ) -> tuple[float, float, float, float, float, float]:
    """[eta_dot, nu_r_dot]: R(psi) nu_r + v_c and :func:`_nu_dot` (the RK4 right-hand side)."""
    c, s = math.cos(psi), math.sin(psi)
    du, dv, dr = _nu_dot(u, v, r, jet, cd, sd, tx, ty, tn, k)
    return (c * u - s * v + cn, s * u + c * v + ce, r, du, dv, dr)


@njit(cache=True)
def rk4(x_n: float, y_e: float, psi: float, u: float, v: float, r: float, dt_s: float, jet: float,
        delta_rad: float, tx: float, ty: float, tn: float, cn: float, ce: float, k: np.ndarray
        ) -> tuple[float, float, float, float, float, float]:
    """One RK4 step of eta = [x_n, y_e, psi] and nu_r = [u, v, r], inputs held over the step
    (as :func:`sim_bridge.dynamics.rk4_step`; ``tx, ty, tn`` the external force, ``cn, ce``
    the current in NED)."""
    cd, sd = math.cos(delta_rad), math.sin(delta_rad)
    h = dt_s
    hh = 0.5 * h
    k1 = _eta_nu_dot(psi, u, v, r, jet, cd, sd, tx, ty, tn, cn, ce, k)
    k2 = _eta_nu_dot(psi + hh * k1[2], u + hh * k1[3], v + hh * k1[4], r + hh * k1[5], jet, cd, sd, tx, ty,
                     tn, cn, ce, k)
    k3 = _eta_nu_dot(psi + hh * k2[2], u + hh * k2[3], v + hh * k2[4], r + hh * k2[5], jet, cd, sd, tx, ty,
                     tn, cn, ce, k)
    k4 = _eta_nu_dot(psi + h * k3[2], u + h * k3[3], v + h * k3[4], r + h * k3[5], jet, cd, sd, tx, ty,
                     tn, cn, ce, k)
    h6 = h / 6.0
    return (x_n + h6 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            y_e + h6 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            psi + h6 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
            u + h6 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
            v + h6 * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]),
            r + h6 * (k1[5] + 2.0 * k2[5] + 2.0 * k3[5] + k4[5]))


@njit(cache=True)
def plant_step(x_n: float, y_e: float, psi: float, u: float, v: float, r: float, dt_s: float, jet: float,
               delta_rad: float, tx: float, ty: float, tn: float, cn: float, ce: float, k: np.ndarray
               ) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """:func:`rk4` and what :class:`sim_bridge.plant.BoatPlant` derives from it:
    (x_n, y_e, psi wrapped to [0, 2 pi), u_r, v_r, r, u_dot_r, v_dot_r, u over ground,
    v over ground, jet thrust), in the reference's operation order."""
    x1, y1, psi1, u1, v1, r1 = rk4(x_n, y_e, psi, u, v, r, dt_s, jet, delta_rad, tx, ty, tn, cn, ce, k)
    c, sn = math.cos(psi1), math.sin(psi1)
    return (x1, y1, psi1 % k[K_TWO_PI], u1, v1, r1, (u1 - u) / dt_s, (v1 - v) / dt_s,
            u1 + c * cn + sn * ce, v1 - sn * cn + c * ce, k[K_RHO_JET_AREA] * jet * (jet - u1))


PAIRWISE_BLOCK = 128
"""Longest array :func:`_pairwise_sum` adds (numpy's pairwise block size)."""


@njit(cache=True)
def _pairwise_sum(a: np.ndarray) -> float:
    """``np.sum(a)`` for ``len(a) <= 128``, in numpy's order: eight running sums, combined
    pairwise, then the tail; numpy starts from its identity, 0.0."""
    n = a.shape[0]
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[i]
        return 0.0 + res
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    m = n - n % 8
    for i in range(8, m, 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(m, n):
        res += a[i]
    return 0.0 + res


@njit(cache=True)
def wave_force(t_s: float, x_n: float, y_e: float, psi: float, mass_kg: float, quarter_m: float,
               toward_rad: float, slope_gain: np.ndarray, w_radps: np.ndarray, k_radpm: np.ndarray,
               phase: np.ndarray, drift_n: float, gravity_mps2: float, work: np.ndarray
               ) -> tuple[float, float, float]:
    """First-order slope force at bow and stern plus mean drift (body frame), as
    :meth:`sim_bridge.disturbances.Environment.wave_force_reference`; ``slope_gain`` is
    amplitude x wave number x depth attenuation per component, ``work`` scratch of its size."""
    cb, sb = math.cos(toward_rad), math.sin(toward_rad)
    cp, sp = math.cos(psi), math.sin(psi)
    fx_body = fy_body = fn = 0.0
    for sign in (1.0, -1.0):
        px = x_n + sign * quarter_m * cp
        py = y_e + sign * quarter_m * sp
        along = px * cb + py * sb
        for i in range(work.shape[0]):
            work[i] = slope_gain[i] * math.sin(w_radps[i] * t_s - k_radpm[i] * along + phase[i])
        slope = _pairwise_sum(work)
        f_along = -0.5 * mass_kg * gravity_mps2 * slope
        fn_, fe_ = f_along * cb, f_along * sb
        fxb = cp * fn_ + sp * fe_
        fyb = -sp * fn_ + cp * fe_
        fx_body += fxb
        fy_body += fyb
        fn += sign * quarter_m * fyb
    fx_body += drift_n * math.cos(toward_rad - psi)
    fy_body += drift_n * math.sin(toward_rad - psi)
    return fx_body, fy_body, fn
