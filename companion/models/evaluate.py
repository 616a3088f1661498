"""The error index J (Eq. 12) of models on a validation record, three ways.

* ``free_run``: the model simulated over the whole record from the first (smoothed)
  measured state, driven by the recorded inputs only;
* ``ahead``: h-step-ahead prediction (h = 1 s by default): from the UKF-filtered state at
  every sample i - h, integrate the model over the recorded inputs to i, *without* model
  error;
* ``ahead_active``: the same, with the UKF-estimated model error delta_nu at i - h held
  constant over the horizon (the active model of Eq. 5), and with the current filter the
  estimated current too, scaled by the gain learnt online from past predictions
  (:mod:`companion.models.active_prediction`).

Reference of J.  The GPS-INS speed noise (0.1 m/s, Table 2) is of the order of the sway
velocity itself, so J against raw measurements would mostly measure sensor noise (a perfect
model would score J_v of about 0.3).  J is therefore computed against the noiseless truth
when the log has it (``u_true``, ``v_true``, ``r_true`` from the simulator) and otherwise
against the zero-phase Savitzky-Golay smoothed measurements (real boat logs); the report
says which.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from companion.models.active_prediction import FilterRun, predict_active, predict_plain, run_filter
from companion.models.base import DOF_NAMES, FloatArray, LinearInParamsModel, error_index
from companion.models.identify import smooth
from companion.models.logs import Record
from companion.models.persistence import held_error_bound
from companion.models.ukf import UKFSettings

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
    run = run_filter(model, rec, settings)
    return run.nu_over_ground, run.delta_nu


def free_run(model: LinearInParamsModel, rec: Record) -> FloatArray:
    """The model simulated over the whole record from the first smoothed measured state."""
    nu_s, _ = smooth(rec)
    return model.simulate(rec.t_s, nu_s[0], rec.throttle, rec.delta_rad)


def active_ahead(model: LinearInParamsModel, rec: Record, horizon_s: float = 1.0,
                 settings: UKFSettings | None = None, backend: str = "native"
                 ) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
    """``(index, active, delta_nu)``: the h-ahead prediction of the active model (Eq. 5, see
    :mod:`companion.models.active_prediction`) and the delta_nu series."""
    run = run_filter(model, rec, settings, backend)
    idx, active = predict_active(model, rec, run, horizon_s)
    return idx, active, run.delta_nu


def evaluate(model: LinearInParamsModel, rec: Record, horizon_s: float = 1.0,
             settings: UKFSettings | None = None, backend: str = "native") -> Evaluation:
    """J per DOF and prediction mode of ``model`` on ``rec`` (1 s ahead: the model alone and the
    active model, both from the filter ``settings`` describe)."""
    free = free_run(model, rec)
    run = run_filter(model, rec, settings, backend)
    idx, ahead = predict_plain(model, rec, run, horizon_s)
    _, active = predict_active(model, rec, run, horizon_s)
    meas = reference(rec)
    j = {
        "free_run": j_of(free, meas),
        "ahead": j_of(ahead, meas[idx]),
        "ahead_active": j_of(active, meas[idx]),
    }
    return Evaluation(model.name, j, free, idx.astype(float), ahead, active, run.nu_over_ground, run.delta_nu)


HORIZONS_S: tuple[float, ...] = (0.01, 0.1, 0.5, 1.0, 2.0)
"""The horizon sweep of the report (issue 14)."""


def horizon_sweep(model: LinearInParamsModel, rec: Record, runs: Mapping[str, FilterRun],
                  horizons_s: Sequence[float] = HORIZONS_S) -> list[dict[str, object]]:
    """Per horizon: J of the model alone and of each filter's active model (each from that
    filter's own estimate), their ratio, and the held-model-error bound (a perfect UKF:
    :func:`companion.models.persistence.held_error_bound`)."""
    meas = reference(rec)
    rows: list[dict[str, object]] = []
    for h in horizons_s:
        row: dict[str, object] = {"horizon_s": h}
        for name, run in runs.items():
            idx, plain = predict_plain(model, rec, run, h)
            _, active = predict_active(model, rec, run, h)
            j0, j1 = j_of(plain, meas[idx]), j_of(active, meas[idx])
            row[name] = {"j_plain": j0, "j_active": j1,
                         "ratio": {d: j1[d] / j0[d] if j0[d] > 0 else float("nan") for d in DOF_NAMES}}
        row["bound_ratio"] = held_error_bound(model, rec, h).ratio
        rows.append(row)
    return rows


def reference(rec: Record) -> FloatArray:
    """What J compares against: the truth if the log has it, else smoothed measurements."""
    return rec.nu_true if rec.nu_true is not None else smooth(rec)[0]


def reference_name(rec: Record) -> str:
    return "truth (*_true columns)" if rec.nu_true is not None else "smoothed measurements"


def j_of(est: FloatArray, meas: FloatArray) -> dict[str, float]:
    """J of Eq. 12 per DOF name."""
    return {dof: float(x) for dof, x in zip(DOF_NAMES, error_index(est, meas), strict=True)}


def j_table(models: Mapping[str, LinearInParamsModel], rec: Record, horizon_s: float = 1.0,
            settings: UKFSettings | None = None, backend: str = "native"
            ) -> tuple[dict[str, dict[str, dict[str, float]]], dict[str, Evaluation]]:
    """``table[model][mode][dof]`` for every model, and the evaluations behind it."""
    evals = {name: evaluate(m, rec, horizon_s, settings, backend) for name, m in models.items()}
    return {name: e.j for name, e in evals.items()}, evals
