"""Identify a qLPV model (Eq. 3-4) of the simulated plant for the control rig.

Excites the plant in calm water with throttle steps and a sine-plus-steps nozzle (as the
chapter's identification run, section 3.2), then fits every row of the model by least squares
on the model's own regressors, scanning the thrust-map coefficient ``c``.  The companion uses the
models package's identified parameters; this keeps the control benchmark self-contained and
reproducible (fixed seed) while that pipeline evolves.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from companion.models.qlpv import QLPV_FEATURES, QLPVModel
from sim_bridge.plant import BoatPlant

DT_S = 0.01


def excitation_record(duration_s: float = 400.0, seed: int = 7) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    plant = BoatPlant(seed=seed)
    n = int(duration_s / DT_S)
    nu = np.zeros((n, 3))
    nu_dot = np.zeros((n, 3))
    thr = np.zeros(n)
    noz = np.zeros(n)
    throttle, hold = 0.5, 0.0
    amp, period = 0.5, 6.0
    for k in range(n):
        t = k * DT_S
        if t >= hold:
            throttle = float(rng.uniform(0.15, 1.0))
            amp = float(rng.uniform(0.05, 1.0))
            period = float(rng.uniform(3.0, 15.0))
            hold = t + float(rng.uniform(5.0, 15.0))
        nozzle = amp * math.sin(2 * math.pi * t / period)
        s = plant.state
        nu[k] = (s.u_r_mps, s.v_r_mps, s.r_radps)
        thr[k], noz[k] = throttle, s.nozzle_rad
        plant.step(DT_S, nozzle, throttle, True)
        nu_dot[k] = ((s.u_r_mps, s.v_r_mps, s.r_radps) - nu[k]) / DT_S
    keep = slice(int(5.0 / DT_S), n)  # engine start-up
    return nu[keep], nu_dot[keep], thr[keep], noz[keep]


@functools.cache
def plant_model() -> QLPVModel:
    """Least-squares qLPV fit of the simulated plant (cached; deterministic)."""
    nu, nu_dot, thr, noz = excitation_record()
    mask = QLPVModel.mask_array()
    best: tuple[float, QLPVModel] | None = None
    for c in np.linspace(0.0, 0.1, 21):
        proto = QLPVModel(theta=np.zeros((3, len(QLPV_FEATURES))), name="plant-fit",
                          thrust_speed_coeff=float(c))
        phi = proto.features(nu, thr, noz)
        theta = np.zeros((3, len(QLPV_FEATURES)))
        sse = 0.0
        for j in range(3):
            cols = np.flatnonzero(mask[j])
            sol, *_ = np.linalg.lstsq(phi[:, cols], nu_dot[:, j], rcond=None)
            theta[j, cols] = sol
            res = phi[:, cols] @ sol - nu_dot[:, j]
            sse += float(res @ res) / float(np.var(nu_dot[:, j]) * len(res))
        model = QLPVModel(theta=theta, name="plant-fit", thrust_speed_coeff=float(c))
        if best is None or sse < best[0]:
            best = (sse, model)
    assert best is not None
    return best[1]
