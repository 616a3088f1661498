"""Compiled (numba) qLPV derivative (Eq. 3-4) and free-run simulation.

The same arithmetic as :meth:`companion.models.qlpv.QLPVModel.derivative` with the regressors
unrolled (feature order of :data:`companion.models.qlpv.QLPV_FEATURES`), for the 100 Hz UKF
(:mod:`companion.models.ukf_kernel`) and for the free-run simulations identification runs
many times (instrumental variables, the current of each log).  Compiled once per machine
(``cache=True``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def qlpv_derivative(nu: np.ndarray, thr: float, dl: float, theta: np.ndarray, c_thrust: float,
                    out: np.ndarray) -> None:
    """``out[:3] = A(nu) nu + B u`` (Eq. 3-4) at one state, thrust T~ = max(thr^2 - c thr u, 0)."""
    u, v, r = nu[0], nu[1], nu[2]
    t = thr * thr - c_thrust * thr * u
    if t < 0.0:
        t = 0.0
    tc = t * np.cos(dl)
    ts = t * np.sin(dl)
    out[0] = theta[0, 0] * u + theta[0, 1] * abs(u) * u + theta[0, 2] * v * r + theta[0, 3] * r * r \
        + theta[0, 4] * tc
    for j in range(1, 3):
        out[j] = theta[j, 5] * v + theta[j, 6] * r + theta[j, 7] * abs(v) * v + theta[j, 8] * abs(r) * r \
            + theta[j, 9] * u * r + theta[j, 10] * ts


@njit(cache=True)
def qlpv_simulate(t_s: np.ndarray, nu0: np.ndarray, throttle: np.ndarray, delta_rad: np.ndarray,
                  theta: np.ndarray, c_thrust: float, delta_nu: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """Free run: classical RK4 with inputs and ``delta_nu[k]`` held over [t_k, t_k+1), the state
    clipped to +-``limit`` after every step; returns nu at every ``t_s`` (N, 3)."""
    n = t_s.size
    out = np.empty((n, 3))
    nu = nu0.copy()
    out[0] = nu
    k1, k2, k3, k4, tmp = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(n - 1):
        h = t_s[k + 1] - t_s[k]
        thr, dl = throttle[k], delta_rad[k]
        qlpv_derivative(nu, thr, dl, theta, c_thrust, k1)
        for i in range(3):
            k1[i] += delta_nu[k, i]
            tmp[i] = nu[i] + 0.5 * h * k1[i]
        qlpv_derivative(tmp, thr, dl, theta, c_thrust, k2)
        for i in range(3):
            k2[i] += delta_nu[k, i]
            tmp[i] = nu[i] + 0.5 * h * k2[i]
        qlpv_derivative(tmp, thr, dl, theta, c_thrust, k3)
        for i in range(3):
            k3[i] += delta_nu[k, i]
            tmp[i] = nu[i] + h * k3[i]
        qlpv_derivative(tmp, thr, dl, theta, c_thrust, k4)
        for i in range(3):
            k4[i] += delta_nu[k, i]
            x = nu[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            nu[i] = min(max(x, -limit[i]), limit[i])
        out[k + 1] = nu
    return out



@njit(cache=True, inline="always")
def _derivative_column(u: float, v: float, r: float, thr: float, cos_dl: float, sin_dl: float,
                       theta: np.ndarray, c_thrust: float, j: int, out: np.ndarray) -> None:
    """:func:`qlpv_derivative` of model ``j`` (``theta`` (3, 11, M), ``out`` (3, M)), the same
    expression term by term (so the same numbers)."""
    t = thr * thr - c_thrust * thr * u
    if t < 0.0:
        t = 0.0
    tc = t * cos_dl
    ts = t * sin_dl
    out[0, j] = theta[0, 0, j] * u + theta[0, 1, j] * abs(u) * u + theta[0, 2, j] * v * r \
        + theta[0, 3, j] * r * r + theta[0, 4, j] * tc
    for q in range(1, 3):
        out[q, j] = theta[q, 5, j] * v + theta[q, 6, j] * r + theta[q, 7, j] * abs(v) * v \
            + theta[q, 8, j] * abs(r) * r + theta[q, 9, j] * u * r + theta[q, 10, j] * ts



@njit(cache=True, inline="always")
def rk4_step_columns(x: np.ndarray, h: float, thr: float, dl: float, theta: np.ndarray, c_thrust: float,
                     limit: np.ndarray, k: np.ndarray) -> None:
    """One step of :func:`qlpv_simulate` (no ``delta_nu``) for M models side by side, in place:
    ``x`` (3, M) states, ``theta`` (3, 11, M), ``k`` (4, 3, M) scratch for the RK4 stages."""
    m = x.shape[1]
    cd, sd = np.cos(dl), np.sin(dl)
    for j in range(m):
        _derivative_column(x[0, j], x[1, j], x[2, j], thr, cd, sd, theta, c_thrust, j, k[0])
    for j in range(m):
        _derivative_column(x[0, j] + 0.5 * h * k[0, 0, j], x[1, j] + 0.5 * h * k[0, 1, j],
                           x[2, j] + 0.5 * h * k[0, 2, j], thr, cd, sd, theta, c_thrust, j, k[1])
    for j in range(m):
        _derivative_column(x[0, j] + 0.5 * h * k[1, 0, j], x[1, j] + 0.5 * h * k[1, 1, j],
                           x[2, j] + 0.5 * h * k[1, 2, j], thr, cd, sd, theta, c_thrust, j, k[2])
    for j in range(m):
        _derivative_column(x[0, j] + h * k[2, 0, j], x[1, j] + h * k[2, 1, j], x[2, j] + h * k[2, 2, j],
                           thr, cd, sd, theta, c_thrust, j, k[3])
    for i in range(3):
        lim = limit[i]
        for j in range(m):
            y = x[i, j] + h / 6.0 * (k[0, i, j] + 2.0 * k[1, i, j] + 2.0 * k[2, i, j] + k[3, i, j])
            x[i, j] = min(max(y, -lim), lim)


@njit(cache=True)
def qlpv_simulate_batch(t_s: np.ndarray, nu0: np.ndarray, throttle: np.ndarray, delta_rad: np.ndarray,
                        theta: np.ndarray, c_thrust: float, limit: np.ndarray) -> np.ndarray:
    """:func:`qlpv_simulate` (no ``delta_nu``) of M models through the same inputs: ``nu0``
    (M, 3), ``theta`` (M, 3, 11); returns (M, N, 3).  Every trajectory is computed with exactly
    :func:`qlpv_simulate`'s arithmetic (the same numbers, tests/models/test_qlpv_kernel_batch.py);
    the M trajectories are stepped side by side (state and parameters stored model-last), which
    the compiler vectorises: one RK4 step alone is a chain of dependent operations."""
    n, m = t_s.size, nu0.shape[0]
    th = np.ascontiguousarray(theta.transpose(1, 2, 0))
    x = np.ascontiguousarray(nu0.T)
    out = np.empty((n, 3, m))
    out[0] = x
    k = np.empty((4, 3, m))
    for i in range(n - 1):
        rk4_step_columns(x, t_s[i + 1] - t_s[i], throttle[i], delta_rad[i], th, c_thrust, limit, k)
        out[i + 1] = x
    return out.transpose(2, 0, 1)
