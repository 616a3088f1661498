"""How much can a *held* model error help?  The bound behind the chapter's Table 4 ratio.

The active model (Eq. 5) predicts h seconds ahead with the UKF's delta_nu estimated at the
start of the horizon and held constant.  A perfect estimator would hand it the *exact* model
error at the start of the horizon; whether holding that helps depends only on how long the
model error persists.  This module measures that on a record:

* the model error series ``e(t) = d/dt nu_ref(t) - f(nu_ref(t), u(t))`` of Eq. 5, where
  ``nu_ref`` is the noiseless truth when the log has it (simulator ``*_true`` columns) and the
  zero-phase Savitzky-Golay smoothed measurement otherwise (real boat logs: an estimate);
* its autocorrelation at the horizon lag: holding e for h seconds pays off only if e(t + h)
  still resembles e(t);
* the "oracle" h-ahead J of Eq. 12 (from the reference state, exact e held) over the h-ahead
  J without model error from the same states, per DOF: the active/no-error ratio a perfect
  UKF would give.  A filter that lags (a smoothed past of e) can do somewhat better or worse
  than this, not fundamentally differently: when e's correlation over the horizon is low, no
  held value brings the ratio near the chapter's one third.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from companion.models.base import DOF_NAMES, FloatArray, LinearInParamsModel, error_index
from companion.models.identify import smooth
from companion.models.logs import Record


@dataclass(frozen=True)
class HeldErrorBound:
    """Per-DOF figures of one model on one record at one horizon (see module docstring)."""

    horizon_s: float
    reference: str
    autocorr: dict[str, float]
    """Autocorrelation of the model error e at lag ``horizon_s`` (1 = perfectly persistent)."""
    j_without: dict[str, float]
    """h-ahead J from the reference state without model error."""
    j_oracle: dict[str, float]
    """h-ahead J from the reference state with the exact model error held."""

    @property
    def ratio(self) -> dict[str, float]:
        """Active / no-model-error ratio with the exact model error held (oracle J over J without)."""
        return {d: self.j_oracle[d] / self.j_without[d] if self.j_without[d] > 0 else float("nan")
                for d in DOF_NAMES}

    def as_dict(self) -> dict[str, object]:
        return {"horizon_s": self.horizon_s, "reference": self.reference,
                "model_error_autocorr": _rounded(self.autocorr),
                "j_without_pct": _rounded({d: 100 * x for d, x in self.j_without.items()}),
                "j_oracle_held_pct": _rounded({d: 100 * x for d, x in self.j_oracle.items()}),
                "oracle_ratio": _rounded(self.ratio)}


def reference_state(rec: Record) -> tuple[FloatArray, str]:
    """The state the bound is computed on: truth if the log has it, else smoothed measurements."""
    if rec.nu_true is not None:
        return np.asarray(rec.nu_true, dtype=float), "truth (*_true columns)"
    return smooth(rec)[0], "smoothed measurements (estimate)"


def model_error_series(model: LinearInParamsModel, rec: Record, nu: FloatArray | None = None) -> FloatArray:
    """e(t) = d/dt nu - f(nu, u) (Eq. 5's delta_nu as the data show it), (N, 3), on ``nu``
    (default: :func:`reference_state`)."""
    if nu is None:
        nu, _ = reference_state(rec)
    nu_dot = np.gradient(nu, rec.t_s, axis=0)
    return np.asarray(nu_dot - model.derivative(nu, rec.throttle, rec.delta_rad))


def autocorrelation(x: FloatArray, lag: int) -> FloatArray:
    """Per-column correlation coefficient of ``x[t]`` and ``x[t + lag]`` (Pearson; 1 = the
    series a ``lag`` later still looks like the series now; nan for a constant column)."""
    x = np.asarray(x, dtype=float)
    if lag <= 0:
        return np.ones(x.shape[1])
    a = x[:-lag] - np.mean(x[:-lag], axis=0)
    b = x[lag:] - np.mean(x[lag:], axis=0)
    den = np.sqrt(np.sum(a**2, axis=0) * np.sum(b**2, axis=0))
    return np.asarray(np.where(den > 0, np.sum(a * b, axis=0) / np.where(den > 0, den, 1.0), np.nan))


def held_error_bound(model: LinearInParamsModel, rec: Record, horizon_s: float = 1.0) -> HeldErrorBound:
    """The oracle bound of the module docstring for ``model`` on ``rec``."""
    nu, ref_name = reference_state(rec)
    err = model_error_series(model, rec, nu)
    dt = float(np.median(np.diff(rec.t_s)))
    lag = max(1, round(horizon_s / dt))
    rho = autocorrelation(err, lag)
    idx, without = model.predict_ahead(rec.t_s, nu, rec.throttle, rec.delta_rad, horizon_s)
    _, oracle = model.predict_ahead(rec.t_s, nu, rec.throttle, rec.delta_rad, horizon_s, delta_nu=err)
    j0 = error_index(without, nu[idx])
    j1 = error_index(oracle, nu[idx])
    return HeldErrorBound(horizon_s, ref_name, _per_dof(rho), _per_dof(j0), _per_dof(j1))


def _per_dof(x: FloatArray) -> dict[str, float]:
    return {d: float(v) for d, v in zip(DOF_NAMES, x, strict=True)}


def _rounded(d: dict[str, float]) -> dict[str, float]:
    return {k: round(v, 3) for k, v in d.items()}
