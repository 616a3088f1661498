"""The error index J (Eq. 12) of models on a validation record, three ways.

* ``free_run``: the model simulated over the whole record from the first (smoothed)
  measured state, driven by the recorded inputs only;
* ``ahead``: h-step-ahead prediction (h = 1 s by default): from the UKF-filtered state at
  every sample i - h, integrate the model over the recorded inputs to i, *without* model
  error;
* ``ahead_active``: the same, with the UKF-estimated model error delta_nu at i - h held
  constant over the horizon (the active model of Eq. 5).

Reference of J.  The GPS-INS speed noise (0.1 m/s, Table 2) is of the order of the sway
velocity itself, so J against raw measurements would mostly measure sensor noise (a perfect
model would score J_v of about 0.3).  J is therefore computed against the noiseless truth
when the log has it (``u_true``, ``v_true``, ``r_true`` from the simulator) and otherwise
against the zero-phase Savitzky-Golay smoothed measurements (real boat logs); the report
says which.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from companion.models.base import DOF_NAMES, FloatArray, LinearInParamsModel, error_index
from companion.models.identify import smooth
from companion.models.logs import Record
from companion.models.ukf import UKFSettings, make_ukf

MODES: tuple[str, ...] = ("free_run", "ahead", "ahead_active")


@dataclass
class Evaluation:
    """Everything the report needs for one model on one validation record."""

    model_name: str
    j: dict[str, dict[str, float]]
    free_run: FloatArray
    ahead_index: FloatArray
    ahead: FloatArray
    ahead_active: FloatArray
    nu_filtered: FloatArray
    delta_nu: FloatArray


def run_ukf(model: LinearInParamsModel, rec: Record, settings: UKFSettings | None = None
            ) -> tuple[FloatArray, FloatArray]:
    """Run the active-model UKF over a record: (filtered nu, estimated delta_nu), each (N, 3)."""
    ukf = make_ukf(model, settings)
    ukf.initialize(rec.nu[0])
    n = len(rec)
    xs = np.empty((n, 6))
    xs[0] = ukf.x
    for k in range(1, n):
        ukf.step(rec.nu[k], rec.throttle[k - 1], rec.delta_rad[k - 1], rec.t_s[k] - rec.t_s[k - 1])
        xs[k] = ukf.x
    return xs[:, :3], xs[:, 3:]


def free_run(model: LinearInParamsModel, rec: Record) -> FloatArray:
    """The model simulated over the whole record from the first smoothed measured state."""
    nu_s, _ = smooth(rec)
    return model.simulate(rec.t_s, nu_s[0], rec.throttle, rec.delta_rad)


def active_ahead(model: LinearInParamsModel, rec: Record, horizon_s: float = 1.0,
                 settings: UKFSettings | None = None) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
    """``(index, active, delta_nu)``: the h-ahead prediction from the UKF-filtered state with the
    UKF's delta_nu held (the active model, Eq. 5), and the delta_nu series."""
    nu_f, dnu = run_ukf(model, rec, settings)
    idx, active = model.predict_ahead(rec.t_s, nu_f, rec.throttle, rec.delta_rad, horizon_s, delta_nu=dnu)
    return idx, active, dnu


def evaluate(model: LinearInParamsModel, rec: Record, horizon_s: float = 1.0,
             settings: UKFSettings | None = None) -> Evaluation:
    """J per DOF and prediction mode of ``model`` on ``rec``."""
    free = free_run(model, rec)
    nu_f, dnu = run_ukf(model, rec, settings)
    idx, ahead = model.predict_ahead(rec.t_s, nu_f, rec.throttle, rec.delta_rad, horizon_s)
    _, active = model.predict_ahead(rec.t_s, nu_f, rec.throttle, rec.delta_rad, horizon_s, delta_nu=dnu)
    meas = reference(rec)
    j = {
        "free_run": j_of(free, meas),
        "ahead": j_of(ahead, meas[idx]),
        "ahead_active": j_of(active, meas[idx]),
    }
    return Evaluation(model.name, j, free, idx.astype(float), ahead, active, nu_f, dnu)


def reference(rec: Record) -> FloatArray:
    """What J compares against: the truth if the log has it, else smoothed measurements."""
    return rec.nu_true if rec.nu_true is not None else smooth(rec)[0]


def reference_name(rec: Record) -> str:
    return "truth (*_true columns)" if rec.nu_true is not None else "smoothed measurements"


def j_of(est: FloatArray, meas: FloatArray) -> dict[str, float]:
    """J of Eq. 12 per DOF name."""
    return {dof: float(x) for dof, x in zip(DOF_NAMES, error_index(est, meas), strict=True)}


def j_table(models: Mapping[str, LinearInParamsModel], rec: Record, horizon_s: float = 1.0,
            settings: UKFSettings | None = None
            ) -> tuple[dict[str, dict[str, dict[str, float]]], dict[str, Evaluation]]:
    """``table[model][mode][dof]`` for every model, and the evaluations behind it."""
    evals = {name: evaluate(m, rec, horizon_s, settings) for name, m in models.items()}
    return {name: e.j for name, e in evals.items()}, evals
