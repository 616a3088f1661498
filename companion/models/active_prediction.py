"""The active model's h-ahead prediction (Eq. 5) with the chapter's filter or the current filter.

Run over a record, the filter gives at every sample i the estimate the active model starts from;
the prediction for sample i + h integrates the model over the recorded inputs from there, with
the estimated model error delta_nu held (Eq. 5).  Two filters:

* ``chapter`` (:class:`~companion.models.ukf.UKF`): the model on over-ground velocities, as
  the chapter runs it; the prediction is :meth:`LinearInParamsModel.predict_ahead` from the
  filtered nu with delta_nu held.
* ``current`` (:class:`~companion.models.current_ukf.CurrentUKF`): the model on
  water-relative velocities.  From nu_r with delta_nu held the hull is integrated, the heading
  with it (from the measured heading at i, by the predicted yaw rate), and the current, held in
  the earth frame, is added back at the predicted heading: nu(i + h) = nu_r + R(psi)^T V_c.

Still water or moving water?  A current estimate of a few cm/s costs a 1-s prediction about 0.7
times its error in sway (the hull relaxes, the held current does not) while the model alone,
in calm water, is already within mm/s; and a model error along the track looks like a current
until the boat turns.  So the prediction uses the current weighted by how clearly it stands out
of its own uncertainty, w = logistic((V_c^T P_c^-1 V_c - gate) / 2)
(:func:`~companion.models.current_ukf.current_weight`); the rest (1 - w) of the body-frame
current stays in the starting velocity, as the model alone would treat it.

Never worse than the model alone.  What the filter holds over the horizon (delta_nu, and the
current) helps only where the model error persists for that long; where it does not (calm
water: the error changes sign within a second) holding it adds noise to the prediction.  So
the active prediction is the plain one plus each held correction (the current's part and
delta_nu's part, separately) scaled, per DOF, by a gain g in [0, 1] learnt online from the
predictions whose outcome is already measured (:func:`held_correction_gain`): the
least-squares slope b of the realised plain-prediction error on the held correction, over an
exponentially forgotten past (:data:`GAIN_MEMORY_S`), with its standard error s and t = b / s.
A :class:`GainRule` decides what is used:

* significance: g = 0 unless t > ``min_t``, and before ``min_history_s`` of the record;
* out of sample: the gain as it was applied must have beaten the plain prediction over the
  past (the exponentially forgotten mean drop e^2 - (e - g c)^2, its t statistic above
  ``min_t_beaten``): a relation fitted on the past that no longer holds is dropped;
* plausibility: a held correction explains about the error it stands for (somewhat more where
  the filter lags it), so a slope well above one, (b - ``slope_limit``) / s >
  ``max_t_above_limit``, is something else the correction happens to track (a gyro bias in the
  measured yaw rate, which the truth does not have: slopes of 3-10 in calm water), and g = 0.

delta_nu, which in calm water mostly carries noise, gets the strict rule
(:data:`DELTA_NU_GAIN_RULE`); the current, a physical and persistent part, the lenient one
(:data:`CURRENT_GAIN_RULE`).  Shrinking the gain toward 0 by its standard error (or James-Stein)
was tried: it lost most of the gain where the error does persist (a third of the no-error J
became a half).  The gain at sample i uses only predictions that ended by i, as a
boat would.  ``gated=False`` gives the raw held correction (g = 1), as the chapter's Eq. 5
holds it.  The rules were chosen on the tuning seed offsets of ``benchmarks.identify.active_gate``.

The *plain* prediction, which the active one is compared with (Table 4's ratio), is the qLPV
model alone from the same filter's over-ground velocity estimate, without model error or current.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from companion.models.base import FloatArray, LinearInParamsModel
from companion.models.current import current_body
from companion.models.current_ukf import current_mahalanobis, current_weight
from companion.models.logs import Record
from companion.models.ukf import CURRENT_GATE_CHI2, UKFSettings, make_ukf

GAIN_MEMORY_S = 30.0
"""Time constant (s) of the exponential forgetting of :func:`held_correction_gain`."""
GAIN_MIN_T = 2.0
"""Default significance threshold: the held correction is used only where the slope's t
statistic exceeds this."""


@dataclass(frozen=True)
class GainRule:
    """When and how much of a held correction is used (module docstring)."""

    memory_s: float = GAIN_MEMORY_S
    """Time constant (s) of the exponential forgetting."""
    min_t: float = GAIN_MIN_T
    """g = 0 unless the slope's t statistic exceeds this."""
    max_t_above_limit: float = math.inf
    """g = 0 where the slope exceeds ``slope_limit`` by more than this many standard errors."""
    slope_limit: float = 1.0
    """The largest plausible slope (a filter that lags the error holds somewhat less than it)."""
    min_history_s: float = 0.0
    """g = 0 until the fit has seen this much of the record (its first windows are few and did
    not carry over)."""
    min_t_beaten: float = -math.inf
    """g = 0 unless the gain, as it was applied, has beaten the plain prediction over the past
    (same memory): the t statistic of the drop in squared error must exceed this; -inf: no check."""


CURRENT_GAIN_RULE = GainRule(min_t=2.0, max_t_above_limit=2.0)
"""The current's part of the held correction (current filter only)."""
DELTA_NU_GAIN_RULE = GainRule(min_t=2.5, max_t_above_limit=1.0, slope_limit=1.5, min_history_s=10.0,
                              min_t_beaten=1.0)
"""delta_nu's part of the held correction."""


@dataclass
class FilterRun:
    """The filter's estimate at every sample of a record."""

    settings: UKFSettings
    nu_over_ground: FloatArray
    """(N, 3) filtered over-ground velocity (what the GPS-INS measures)."""
    nu_model: FloatArray
    """(N, 3) the model's state: nu over ground (chapter) or nu_r through the water (current)."""
    delta_nu: FloatArray
    current_ne: FloatArray
    """(N, 2) estimated current [north, east] (m/s); zeros for the chapter's filter."""
    current_var: FloatArray
    """(N, 2) variance of each current component."""
    weight: FloatArray
    """(N,) weight of the current in the prediction (module docstring)."""


def run_filter(model: LinearInParamsModel, rec: Record, settings: UKFSettings | None = None,
               backend: str = "native", gate_chi2: float = CURRENT_GATE_CHI2) -> FilterRun:
    """Run the active-model UKF ``settings`` describe over ``rec`` (the current filter needs the
    log's heading column)."""
    settings = settings or UKFSettings()
    if settings.estimate_current and rec.psi_rad is None:
        raise ValueError(f"{rec.name}: the current filter needs the heading column 'psi'")
    psi = rec.psi_rad if rec.psi_rad is not None else np.zeros(len(rec))
    ukf = make_ukf(model, settings, backend=backend)
    ukf.initialize(rec.nu[0])
    n = len(rec)
    xs = np.empty((n, ukf.n))
    pd = np.empty((n, ukf.n))
    maha = np.zeros(n)
    xs[0], pd[0] = ukf.x, np.diag(ukf.P)
    for k in range(1, n):
        ukf.step(rec.nu[k], rec.throttle[k - 1], rec.delta_rad[k - 1], rec.t_s[k] - rec.t_s[k - 1], psi[k])
        xs[k], pd[k] = ukf.x, np.diag(ukf.P)
        if ukf.n == 8:
            maha[k] = current_mahalanobis(ukf.x[6:8], ukf.P[6:8, 6:8])
    if ukf.n == 6:
        zero = np.zeros((n, 2))
        return FilterRun(settings, xs[:, :3], xs[:, :3], xs[:, 3:6], zero, zero, np.zeros(n))
    current, var = xs[:, 6:8], pd[:, 6:8]
    weight = np.array([current_weight(m, gate_chi2) for m in maha])
    return FilterRun(settings, xs[:, :3] + current_body(psi, current[:, 0], current[:, 1]), xs[:, :3],
                     xs[:, 3:6], current, var, weight)


def predict_plain(model: LinearInParamsModel, rec: Record, run: FilterRun, horizon_s: float
                  ) -> tuple[NDArray[np.intp], FloatArray]:
    """The model alone, h ahead, from the filtered over-ground velocity (no model error)."""
    return model.predict_ahead(rec.t_s, run.nu_over_ground, rec.throttle, rec.delta_rad, horizon_s)


def held_correction_gain(correction: FloatArray, plain_error: FloatArray, horizon_steps: int,
                         dt_s: float, memory_s: float = GAIN_MEMORY_S, min_t: float = GAIN_MIN_T,
                         rule: GainRule | None = None) -> FloatArray:
    """Per start sample and DOF, the gain g in [0, 1] of the held correction (module docstring).

    ``correction`` (n, 3): active minus plain prediction of the window starting at each sample;
    ``plain_error`` (n, 3): the measured state at the window's end minus the plain prediction.
    The window starting at j ends at j + h, so the gain at start i is fitted on windows j <= i - h.
    Samples 1 s apart are far from independent: the t statistic counts one sample per horizon.
    ``rule`` (default: significance alone, ``memory_s`` and ``min_t``) says what is used."""
    rule = rule or GainRule(memory_s=memory_s, min_t=min_t)
    lam = math.exp(-dt_s / rule.memory_s)
    sxy, sxx, syy = (_forgotten_mean(x, lam) for x in (correction * plain_error, correction * correction,
                                                         plain_error * plain_error))
    n = correction.shape[0]
    n_eff = _effective_samples(n, lam, horizon_steps)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        slope = np.where(sxx > 0, sxy / sxx, 0.0)
        resid = np.maximum(syy - slope * sxy, 1e-30)
        std_err = np.sqrt(resid / np.maximum(sxx * n_eff[:, None], 1e-300))
        t_stat = slope / std_err
        implausible = (slope - rule.slope_limit) > rule.max_t_above_limit * std_err
    fitted = np.where((t_stat > rule.min_t) & ~implausible, np.clip(slope, 0.0, 1.0), 0.0)
    fitted[: round(rule.min_history_s / dt_s)] = 0.0
    gain = np.zeros_like(correction)
    gain[horizon_steps:] = fitted[: n - horizon_steps]
    if math.isfinite(rule.min_t_beaten):
        gain *= _has_beaten_plain(gain, correction, plain_error, horizon_steps, lam, rule.min_t_beaten)
    return np.asarray(gain)


def _has_beaten_plain(gain: FloatArray, correction: FloatArray, plain_error: FloatArray,
                      horizon_steps: int, lam: float, min_t: float) -> FloatArray:
    """1 where the windows that ended so far say the gain, as applied, lowered the squared error
    of the plain prediction (t statistic of the mean drop above ``min_t``, one sample per
    horizon), else 0; per start sample and DOF, known h after each window's start."""
    drop = plain_error**2 - (plain_error - gain * correction) ** 2
    n = drop.shape[0]
    mean, mean_sq = _forgotten_mean(drop, lam), _forgotten_mean(drop * drop, lam)
    n_eff = _effective_samples(n, lam, horizon_steps)
    std_err = np.sqrt(np.maximum(mean_sq - mean**2, 1e-300) / n_eff[:, None])
    beaten = np.zeros_like(drop)
    beaten[horizon_steps:] = (mean / std_err > min_t)[: n - horizon_steps]
    return beaten


def _forgotten_mean(x: FloatArray, lam: float) -> FloatArray:
    """Exponentially forgotten running mean along axis 0 (factor ``lam`` per sample), divided by
    the weight the forgetting sum has seen so far (no start-up bias toward 0)."""
    from scipy.signal import lfilter

    weight = 1.0 - lam ** np.arange(1, x.shape[0] + 1)
    return np.asarray(lfilter([1.0 - lam], [1.0, -lam], x, axis=0) / weight[:, None])


def _effective_samples(n: int, lam: float, horizon_steps: int) -> FloatArray:
    """Independent samples behind each running mean: the forgetting's memory (at most
    1 / (1 - lam)) counted one per horizon, since windows 1 s apart overlap."""
    return np.asarray(np.minimum(np.arange(1, n + 1), 1.0 / (1.0 - lam)) / max(horizon_steps, 1))


def predict_active(model: LinearInParamsModel, rec: Record, run: FilterRun, horizon_s: float,
                   gated: bool = True) -> tuple[NDArray[np.intp], FloatArray]:
    """The active model h ahead: delta_nu held; with the current filter, the hull through the
    water and the (weighted) current held in the earth frame; the current's and delta_nu's parts
    of the held correction each scaled by :func:`held_correction_gain` under their
    :class:`GainRule` unless ``gated`` is False (module docstring)."""
    idx, raw = _predict_held(model, rec, run, horizon_s)
    if not gated:
        return idx, raw
    _, plain = predict_plain(model, rec, run, horizon_s)
    h = int(idx[0])
    dt_s = float(np.median(np.diff(rec.t_s)))
    plain_error = rec.nu[idx] - plain
    if run.settings.estimate_current:
        _, current_only = _predict_held(model, rec, replace(run, delta_nu=np.zeros_like(run.delta_nu)),
                                        horizon_s)
    else:
        current_only = plain
    current_part, delta_nu_part = current_only - plain, raw - current_only
    gain_current = held_correction_gain(current_part, plain_error, h, dt_s, rule=CURRENT_GAIN_RULE)
    gain_delta_nu = held_correction_gain(delta_nu_part, plain_error, h, dt_s, rule=DELTA_NU_GAIN_RULE)
    return idx, np.asarray(plain + gain_current * current_part + gain_delta_nu * delta_nu_part)


def _predict_held(model: LinearInParamsModel, rec: Record, run: FilterRun, horizon_s: float
                  ) -> tuple[NDArray[np.intp], FloatArray]:
    """The h-ahead prediction with what the filter estimated held (g = 1)."""
    if not run.settings.estimate_current:
        return model.predict_ahead(rec.t_s, run.nu_model, rec.throttle, rec.delta_rad, horizon_s,
                                   delta_nu=run.delta_nu)
    assert rec.psi_rad is not None
    t_s = rec.t_s
    h = max(1, round(horizon_s / float(np.median(np.diff(t_s)))))
    if t_s.size <= h:
        raise ValueError(f"record of {t_s.size} samples is shorter than the {horizon_s} s horizon")
    starts = np.arange(0, t_s.size - h)
    w = run.weight[starts]
    cur = run.current_ne[starts] * w[:, None]
    psi = np.array(rec.psi_rad[starts], dtype=float)
    unused = run.current_ne[starts] * (1.0 - w)[:, None]
    nu = run.nu_model[starts] + current_body(psi, unused[:, 0], unused[:, 1])
    dn = run.delta_nu[starts]
    for k in range(h):
        idx = starts + k
        step_dt = (t_s[idx + 1] - t_s[idx])[:, None]
        r0 = nu[:, 2].copy()
        nu = model.step_vec(nu, rec.throttle[idx], rec.delta_rad[idx], step_dt, dn)
        psi += 0.5 * (r0 + nu[:, 2]) * step_dt[:, 0]
    return np.asarray(starts + h, dtype=np.intp), np.asarray(nu + current_body(psi, cur[:, 0], cur[:, 1]))
