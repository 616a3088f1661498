"""Compiled (numba) free run of the affine baselines (Table 3: linearised, Nomoto with sideslip).

The same arithmetic, in the same order, as the Python-float loop of
:meth:`companion.models.baselines._AffineModel.simulate_python` (the readable reference; the two
give the same numbers, tests/models/test_baseline_free_run.py): classical RK4 of
nu_dot = A nu + b_k with b_k held over [t_k, t_k+1), the state clipped to +-limit after every step.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def affine_simulate(a: np.ndarray, b: np.ndarray, dts: np.ndarray, nu0: np.ndarray, limit: np.ndarray
                    ) -> np.ndarray:
    """Free run from ``nu0``: ``a`` (3, 3), ``b`` (N, 3) the input term of every interval (the
    last row unused), ``dts`` (N - 1) the steps; returns nu at every sample (N, 3)."""
    n = b.shape[0]
    out = np.empty((n, 3))
    a00, a01, a02 = a[0, 0], a[0, 1], a[0, 2]
    a10, a11, a12 = a[1, 0], a[1, 1], a[1, 2]
    a20, a21, a22 = a[2, 0], a[2, 1], a[2, 2]
    u, v, r = nu0[0], nu0[1], nu0[2]
    out[0, 0], out[0, 1], out[0, 2] = u, v, r
    for k in range(n - 1):
        dt, b0, b1, b2 = dts[k], b[k, 0], b[k, 1], b[k, 2]
        k10 = a00 * u + a01 * v + a02 * r + b0
        k11 = a10 * u + a11 * v + a12 * r + b1
        k12 = a20 * u + a21 * v + a22 * r + b2
        x0, x1, x2 = u + 0.5 * dt * k10, v + 0.5 * dt * k11, r + 0.5 * dt * k12
        k20 = a00 * x0 + a01 * x1 + a02 * x2 + b0
        k21 = a10 * x0 + a11 * x1 + a12 * x2 + b1
        k22 = a20 * x0 + a21 * x1 + a22 * x2 + b2
        x0, x1, x2 = u + 0.5 * dt * k20, v + 0.5 * dt * k21, r + 0.5 * dt * k22
        k30 = a00 * x0 + a01 * x1 + a02 * x2 + b0
        k31 = a10 * x0 + a11 * x1 + a12 * x2 + b1
        k32 = a20 * x0 + a21 * x1 + a22 * x2 + b2
        x0, x1, x2 = u + dt * k30, v + dt * k31, r + dt * k32
        k40 = a00 * x0 + a01 * x1 + a02 * x2 + b0
        k41 = a10 * x0 + a11 * x1 + a12 * x2 + b1
        k42 = a20 * x0 + a21 * x1 + a22 * x2 + b2
        u = min(max(u + dt / 6.0 * (k10 + 2.0 * k20 + 2.0 * k30 + k40), -limit[0]), limit[0])
        v = min(max(v + dt / 6.0 * (k11 + 2.0 * k21 + 2.0 * k31 + k41), -limit[1]), limit[1])
        r = min(max(r + dt / 6.0 * (k12 + 2.0 * k22 + 2.0 * k32 + k42), -limit[2]), limit[2])
        out[k + 1, 0], out[k + 1, 1], out[k + 1, 2] = u, v, r
    return out
