"""Compiled (numba) predict+update step of the active-model UKF for the qLPV model.

Exactly the arithmetic of :class:`companion.models.ukf.UKF` and
:class:`companion.models.current_ukf.CurrentUKF` (sigma points of Eq. 8,
time update Eq. 9, the exact linear measurement update of Eq. 10-11 in Joseph form), with
the qLPV features of :mod:`companion.models.qlpv` unrolled, so one 100 Hz step costs a few
microseconds instead of the tens of microseconds that small numpy operations cost.  The
function is compiled once per machine (``cache=True``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from companion.models.qlpv_kernel import qlpv_derivative as _qlpv_derivative


@njit(cache=True)
def _cholesky(a: np.ndarray, low: np.ndarray) -> bool:
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            low[i, j] = 0.0
    for j in range(n):
        s = a[j, j]
        for k in range(j):
            s -= low[j, k] * low[j, k]
        if not s > 0.0:
            return False
        d = np.sqrt(s)
        low[j, j] = d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s / d
    return True


@njit(cache=True)
def _scaled_sqrt(p: np.ndarray, c_scale: float, low: np.ndarray) -> int:
    """low = Cholesky factor of c_scale * P (jitter added until it factors); returns the count."""
    n = p.shape[0]
    sp = np.empty((n, n))
    jit = 0
    jitter = 0.0
    tr = 0.0
    for i in range(n):
        tr += p[i, i]
    while True:
        for i in range(n):
            for j in range(n):
                sp[i, j] = c_scale * p[i, j]
            sp[i, i] += c_scale * jitter
        if _cholesky(sp, low):
            break
        jit += 1
        jitter = 1e-12 * (tr / n + 1.0) if jitter == 0.0 else 2.0 * jitter
    return jit


@njit(cache=True)
def _time_update(x: np.ndarray, p: np.ndarray, low: np.ndarray, thr: float, dl: float, dt: float,
                 theta: np.ndarray, c_thrust: float, q: np.ndarray, wi: float, wc0: float) -> None:
    """Sigma points (Eq. 8) through the process model (Eq. 9), in place: the first three states
    follow the qLPV model plus delta_nu (states 3-5), every later state is a random walk."""
    n = x.size
    y = np.empty((2 * n + 1, n))
    sig = np.empty(n)
    d = np.empty(3)
    for i in range(2 * n + 1):
        for k in range(n):
            sig[k] = x[k]
        if i >= 1:
            col = (i - 1) % n
            sign = 1.0 if i <= n else -1.0
            for k in range(n):
                sig[k] += sign * low[k, col]
        _qlpv_derivative(sig, thr, dl, theta, c_thrust, d)
        for k in range(3):
            y[i, k] = sig[k] + dt * (d[k] + sig[3 + k])
        for k in range(3, n):
            y[i, k] = sig[k]
    mean = np.empty(n)
    for k in range(n):
        acc = 0.0
        for i in range(1, 2 * n + 1):
            acc += y[i, k] - y[0, k]
        mean[k] = y[0, k] + wi * acc
    for a in range(n):
        for b in range(a, n):
            acc = wc0 * (y[0, a] - mean[a]) * (y[0, b] - mean[b])
            for i in range(1, 2 * n + 1):
                acc += wi * (y[i, a] - mean[a]) * (y[i, b] - mean[b])
            p[a, b] = acc + q[a, b]
            p[b, a] = p[a, b]
    for k in range(n):
        x[k] = mean[k]


@njit(cache=True)
def _inverse3(s: np.ndarray) -> np.ndarray:
    det = (s[0, 0] * (s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1])
           - s[0, 1] * (s[1, 0] * s[2, 2] - s[1, 2] * s[2, 0])
           + s[0, 2] * (s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0]))
    si = np.empty((3, 3))
    si[0, 0] = (s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1]) / det
    si[0, 1] = (s[0, 2] * s[2, 1] - s[0, 1] * s[2, 2]) / det
    si[0, 2] = (s[0, 1] * s[1, 2] - s[0, 2] * s[1, 1]) / det
    si[1, 0] = (s[1, 2] * s[2, 0] - s[1, 0] * s[2, 2]) / det
    si[1, 1] = (s[0, 0] * s[2, 2] - s[0, 2] * s[2, 0]) / det
    si[1, 2] = (s[0, 2] * s[1, 0] - s[0, 0] * s[1, 2]) / det
    si[2, 0] = (s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0]) / det
    si[2, 1] = (s[0, 1] * s[2, 0] - s[0, 0] * s[2, 1]) / det
    si[2, 2] = (s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]) / det
    return si


@njit(cache=True)
def _nis(innov: np.ndarray, si: np.ndarray) -> float:
    nis = 0.0
    for a in range(3):
        for b in range(3):
            nis += innov[a] * si[a, b] * innov[b]
    return nis


@njit(cache=True)
def _joseph(p: np.ndarray, amat: np.ndarray, gain: np.ndarray, r_cov: np.ndarray) -> None:
    """P = A P A^T + K R K^T, symmetrised, in place (Eq. 11 in Joseph form)."""
    n = p.shape[0]
    pn = amat @ p @ amat.T + gain @ r_cov @ gain.T
    for a in range(n):
        for b in range(n):
            p[a, b] = 0.5 * (pn[a, b] + pn[b, a])


@njit(cache=True)
def qlpv_ukf_step(x: np.ndarray, p: np.ndarray, z: np.ndarray, thr: float, dl: float, dt: float,
                  theta: np.ndarray, c_thrust: float, q: np.ndarray, r_cov: np.ndarray,
                  wi: float, wc0: float, c_scale: float) -> tuple[float, int]:
    """The chapter's filter, in place: x (6,), p (6,6) become the updated estimate.
    Returns (NIS, jitter count)."""
    n = 6
    low = np.empty((n, n))
    jit = _scaled_sqrt(p, c_scale, low)
    _time_update(x, p, low, thr, dl, dt, theta, c_thrust, q, wi, wc0)
    # measurement update (Eq. 10-11), exact for z = nu + noise, Joseph form
    s = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            s[a, b] = p[a, b] + r_cov[a, b]
    si = _inverse3(s)
    gain = np.ascontiguousarray(p[:, :3]) @ si
    innov = np.empty(3)
    for k in range(3):
        innov[k] = z[k] - x[k]
    nis = _nis(innov, si)
    for k in range(n):
        x[k] += gain[k, 0] * innov[0] + gain[k, 1] * innov[1] + gain[k, 2] * innov[2]
    amat = np.eye(n)
    for k in range(n):
        for j in range(3):
            amat[k, j] -= gain[k, j]
    _joseph(p, amat, gain, r_cov)
    return nis, jit


@njit(cache=True)
def qlpv_current_ukf_step(x: np.ndarray, p: np.ndarray, z: np.ndarray, thr: float, dl: float, dt: float,
                          cos_psi: float, sin_psi: float, theta: np.ndarray, c_thrust: float, q: np.ndarray,
                          r_cov: np.ndarray, wi: float, wc0: float, c_scale: float) -> tuple[float, int]:
    """The current-augmented filter (:mod:`companion.models.current_ukf`), in place: x (8,),
    p (8,8).  z = H x + noise with H = [I, 0, C(psi)].  Returns (NIS, jitter count)."""
    n = 8
    low = np.empty((n, n))
    jit = _scaled_sqrt(p, c_scale, low)
    _time_update(x, p, low, thr, dl, dt, theta, c_thrust, q, wi, wc0)
    h = np.zeros((3, n))
    h[0, 0] = 1.0
    h[1, 1] = 1.0
    h[2, 2] = 1.0
    h[0, 6], h[0, 7] = cos_psi, sin_psi
    h[1, 6], h[1, 7] = -sin_psi, cos_psi
    pht = p @ h.T
    s = h @ pht + r_cov
    si = _inverse3(s)
    gain = pht @ si
    innov = z - h @ x
    nis = _nis(innov, si)
    for k in range(n):
        x[k] += gain[k, 0] * innov[0] + gain[k, 1] * innov[1] + gain[k, 2] * innov[2]
    amat = np.eye(n) - gain @ h
    _joseph(p, amat, gain, r_cov)
    return nis, jit
