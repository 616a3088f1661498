"""Compiled (numba) normal equations of the current search's quick fit.

:func:`companion.models.current._quick_fit` solves the qLPV rows (Eq. 3-4) by least squares on
the water-relative smoothed logs, nu_r = nu - V_cN b_N - V_cE b_E (b the smoothed body-frame
current bases, :mod:`companion.models.current`).  The search scores about a thousand candidate
currents, so this kernel accumulates the Gram matrix Phi^T Phi and Phi^T nu_r_dot of one log at
one current in a single pass over its rows, without building Phi: surge rows use the regressors
0-4, sway and yaw the regressors 5-10 (:data:`companion.models.qlpv.QLPV_MASK`), so only those
two diagonal blocks are formed.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from companion.models.qlpv_kernel import rk4_step_columns


@njit(cache=True)
def quick_normal_equations(nu: np.ndarray, nu_dot: np.ndarray, basis: np.ndarray, basis_dot: np.ndarray,
                           throttle: np.ndarray, cos_delta: np.ndarray, sin_delta: np.ndarray, lo: int,
                           hi: int, cn: float, ce: float, c_thrust: float) -> tuple[np.ndarray, np.ndarray]:
    """Phi^T Phi (11, 11; the surge block 0-4 and the sway-yaw block 5-10) and Phi^T Y (11, 3;
    the surge column on rows 0-4, the sway and yaw columns on rows 5-10) over rows [lo, hi) at the
    current (``cn``, ``ce``) m/s; regressors in the order of :data:`companion.models.qlpv.QLPV_FEATURES`
    with T~ = max(throttle^2 - c throttle u, 0); ``cos_delta``, ``sin_delta``: of the nozzle angle
    (computed once per log: they do not depend on the current)."""
    gram = np.zeros((11, 11))
    rhs = np.zeros((11, 3))
    f = np.empty(11)
    y = np.empty(3)
    for i in range(lo, hi):
        u = nu[i, 0] - cn * basis[0, i, 0] - ce * basis[1, i, 0]
        v = nu[i, 1] - cn * basis[0, i, 1] - ce * basis[1, i, 1]
        r = nu[i, 2] - cn * basis[0, i, 2] - ce * basis[1, i, 2]
        for q in range(3):
            y[q] = nu_dot[i, q] - cn * basis_dot[0, i, q] - ce * basis_dot[1, i, q]
        thr = throttle[i]
        t = thr * thr - c_thrust * thr * u
        if t < 0.0:
            t = 0.0
        f[0], f[1], f[2], f[3], f[4] = u, abs(u) * u, v * r, r * r, t * cos_delta[i]
        f[5], f[6], f[7], f[8], f[9], f[10] = v, r, abs(v) * v, abs(r) * r, u * r, t * sin_delta[i]
        for a in range(5):
            for b in range(a, 5):
                gram[a, b] += f[a] * f[b]
            rhs[a, 0] += f[a] * y[0]
        for a in range(5, 11):
            for b in range(a, 11):
                gram[a, b] += f[a] * f[b]
            rhs[a, 1] += f[a] * y[1]
            rhs[a, 2] += f[a] * y[2]
    for a in range(11):
        for b in range(a):
            gram[a, b] = gram[b, a]
    return gram, rhs


@njit(cache=True)
def over_ground_error_batch(t_s: np.ndarray, nu_r0: np.ndarray, throttle: np.ndarray, delta_rad: np.ndarray,
                            theta: np.ndarray, c_thrust: float, limit: np.ndarray, cn: np.ndarray,
                            ce: np.ndarray, basis_n: np.ndarray, basis_e: np.ndarray,
                            target: np.ndarray) -> np.ndarray:
    """Sum over samples of the squared free-run error over ground, per model and DOF (M, 3): each
    of the M models (``theta`` (M, 3, 11)) runs through the water from ``nu_r0`` (M, 3) as
    :func:`companion.models.qlpv_kernel.qlpv_simulate_batch` does, its current (``cn``, ``ce``)
    is added back, nu_r + V_cN ``basis_n`` + V_cE ``basis_e`` (bases (N, 3) at the logged
    heading), and it is compared with ``target`` (N, 3), without storing the runs."""
    n, m = t_s.size, nu_r0.shape[0]
    th = np.ascontiguousarray(theta.transpose(1, 2, 0))
    x = np.ascontiguousarray(nu_r0.T)
    k = np.empty((4, 3, m))
    sq = np.zeros((3, m))
    for i in range(n):
        if i > 0:
            h = t_s[i] - t_s[i - 1]
            rk4_step_columns(x, h, throttle[i - 1], delta_rad[i - 1], th, c_thrust, limit, k)
        for q in range(3):
            for j in range(m):
                e = x[q, j] + cn[j] * basis_n[i, q] + ce[j] * basis_e[i, q] - target[i, q]
                sq[q, j] += e * e
    return sq.T.copy()


@njit(cache=True)
def over_ground_residuals_batch(t_s: np.ndarray, nu_r0: np.ndarray, throttle: np.ndarray,
                                delta_rad: np.ndarray, theta: np.ndarray, c_thrust: float, limit: np.ndarray,
                                cn: np.ndarray, ce: np.ndarray, basis_n: np.ndarray, basis_e: np.ndarray,
                                target: np.ndarray, scale: np.ndarray, stride: int) -> np.ndarray:
    """The output-error residuals of M parameter vectors (M, 3 K): the free runs of
    :func:`over_ground_error_batch` on ``t_s``, taken at every ``stride``-th sample (K of them;
    ``basis_*`` and ``target`` (K, 3) there), ((nu_r + V_cN b_N + V_cE b_E) - target) / scale / sqrt(K),
    in that order of operations (the numbers numpy gives for the same expression)."""
    n, m = t_s.size, nu_r0.shape[0]
    n_out = target.shape[0]
    th = np.ascontiguousarray(theta.transpose(1, 2, 0))
    x = np.ascontiguousarray(nu_r0.T)
    k = np.empty((4, 3, m))
    out = np.empty((m, 3 * n_out))
    root = np.sqrt(n_out)
    for i in range(n):
        if i > 0:
            h = t_s[i] - t_s[i - 1]
            rk4_step_columns(x, h, throttle[i - 1], delta_rad[i - 1], th, c_thrust, limit, k)
        if i % stride == 0:
            o = i // stride
            for q in range(3):
                for j in range(m):
                    og = x[q, j] + cn[j] * basis_n[o, q] + ce[j] * basis_e[o, q]
                    out[j, 3 * o + q] = (og - target[o, q]) / scale[q] / root
    return out
