"""Active-model UKF step time: ours (compiled and numpy) vs filterpy on the same problem."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from companion.models.params_file import load_model_params
from companion.models.ukf import UKF, make_ukf


def run(quick: bool) -> dict[str, Any]:
    model = load_model_params()
    n = 500 if quick else 5000
    dt = 0.01
    rng = np.random.default_rng(0)
    t = np.arange(n) * dt
    dl = np.pi / 3 * np.sin(2 * np.pi * t / 10.0)
    z = np.column_stack([2.0 + 0.1 * rng.normal(size=n), 0.1 * rng.normal(size=n), 0.01 * rng.normal(size=n)])

    def fx(x: np.ndarray, dt: float, thr: float, dl: float) -> np.ndarray:
        y = x.copy()
        y[:3] += dt * (model.derivative(x[:3], thr, dl) + x[3:])
        return y

    fast, slow = make_ukf(model), UKF(model.derivative)
    ref = UnscentedKalmanFilter(6, 3, dt, lambda x: x[:3], fx, MerweScaledSigmaPoints(6, 1e-3, 2.0, 0.0))
    ref.Q, ref.R, ref.P = fast.Q.copy(), fast.R.copy(), fast.P.copy()
    for f in (fast, slow):
        f.initialize(z[0])
    ref.x = fast.x.copy()
    fast.step(z[1], 0.3, dl[0], dt)  # compile outside the timing

    def timed(step: Any) -> float:
        t0 = time.perf_counter()
        for k in range(2, n):
            step(k)
        return (time.perf_counter() - t0) / (n - 2) * 1e6

    ours = timed(lambda k: fast.step(z[k], 0.3, dl[k - 1], dt))
    ours_np = timed(lambda k: slow.step(z[k], 0.3, dl[k - 1], dt))

    def fp(k: int) -> None:
        ref.predict(dt, thr=0.3, dl=dl[k - 1])
        ref.update(z[k])

    theirs = timed(fp)
    return {"steps": n - 2, "ours_compiled_us_per_step": round(ours, 2),
            "ours_numpy_us_per_step": round(ours_np, 1), "filterpy_us_per_step": round(theirs, 1),
            "speedup_vs_filterpy": round(theirs / ours, 1),
            "state_diff_vs_filterpy_end": float(np.abs(fast.x - ref.x).max())}
