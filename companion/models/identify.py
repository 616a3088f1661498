"""Identification of the qLPV model (Eq. 3-4) and the Table 3 baselines from logs.

1. Smoothing/differentiation: a Savitzky-Golay filter (scipy) fits a local cubic over a
   window (default 0.5 s) to the measured u, v, r and returns the smoothed states and
   their exact derivatives; the regression uses both (edges of each record are dropped).
2. Linear least squares per DOF on the linear-in-parameters regression (every model here is
   linear in its parameters).  Columns are scaled before an SVD; the condition number is
   reported, parameters with covariance sigma^2 (Phi^T Phi)^-1 (inflated by the filter
   window, since smoothed residuals are correlated over it).
3. Identifiability: the recorded inputs must be excited (nozzle angle, yaw rate) or
   :class:`IdentificationError` names what is missing; a regressor that is (nearly) collinear
   with others (e.g. throttle held constant makes the throttle column a copy of the constant)
   is fixed at zero and a warning names it and the signal lacking excitation.
4. The qLPV thrust map's speed coefficient c (T~ = throttle^2 - c throttle u) enters
   bilinearly; it is found by variable projection: a bounded scalar search over c with
   the linear least squares solved exactly inside.
5. Instrumental variables (:func:`refine_instrumental`, the default estimator of the
   pipeline).  The GPS-INS speed noise (0.1 m/s) is of the order of the sway velocity; even
   smoothed, the noise in the *regressors* biases least squares (errors in variables:
   damping shrinks towards zero, and with v and r nearly collinear in a sine manoeuvre the
   sway row goes wrong outside the training envelope).  The instruments are the regressors
   evaluated on the model's own noise-free free-run simulation of the training records
   (Young's bootstrap/refined IV): correlated with the true regressors, uncorrelated with
   the measurement noise.  A few iterations, each accepted only if it does not worsen the
   free-run fit of the training records.  Optional bounds keep the qLPV model's diagonal
   damping dissipative (:data:`QLPV_DISSIPATIVE`), solved by ``scipy.optimize.lsq_linear``.
6. Optional output-error refinement (scipy.optimize.least_squares) of all parameters on
   the free-run simulation error of the training records (resampled to 10 Hz).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares, lsq_linear, minimize_scalar
from scipy.signal import savgol_filter

from companion.models.base import DOF_NAMES, FloatArray, LinearInParamsModel
from companion.models.current import CurrentFit
from companion.models.logs import Record
from companion.models.qlpv import FEATURE_SIGNALS, QLPVModel

COND_LIMIT = 1e5
"""Largest accepted condition number of a column-scaled regression matrix."""
MIN_DELTA_STD_RAD = 0.02
MIN_R_STD_RADPS = 0.005
EXCITATION_STD: dict[str, float] = {"throttle": 0.01, "delta": MIN_DELTA_STD_RAD, "u": 0.02, "v": 0.01,
                                    "r": MIN_R_STD_RADPS}
"""Standard deviation below which a recorded signal counts as not excited."""

Progress = Callable[[int, int], None]

Bounds = dict[tuple[int, str], tuple[float, float]]
"""(DOF index, regressor name) -> (lower, upper) bound on a lumped parameter."""
QLPV_DISSIPATIVE: Bounds = {
    (0, "u"): (-np.inf, 0.0), (0, "|u|u"): (-np.inf, 0.0), (0, "Tcos"): (0.0, np.inf),
    (1, "v"): (-np.inf, 0.0), (1, "|v|v"): (-np.inf, 0.0), (1, "Tsin"): (-np.inf, 0.0),
    (2, "r"): (-np.inf, 0.0), (2, "|r|r"): (-np.inf, 0.0), (2, "Tsin"): (0.0, np.inf),
}
"""Physical signs of the qLPV model (Eq. 4): the diagonal damping of N0..N4 (X_u, X_|u|u,
Y_v, Y_|v|v, N_r, N_|r|r) removes energy, and the jet (B = M^-1 [0, -1, x_delta]^T for the
sine input, x_delta < 0 at the stern) pushes the boat forward, the stern to port and the bow
to starboard for a starboard nozzle."""


class IdentificationError(ValueError):
    """The data cannot identify the model; the message names the missing excitation."""


@dataclass
class FitResult:
    """An identified model with its uncertainty and diagnostics."""

    model: LinearInParamsModel
    method: str
    std: FloatArray
    """Standard deviation of every theta entry (0 where structurally zero or fixed)."""
    cond: tuple[float, float, float]
    warnings: list[str] = field(default_factory=list)
    cov: list[FloatArray] = field(default_factory=list)
    """Per DOF: covariance of the identified (non-fixed) parameters of that row."""
    currents: CurrentFit | None = None
    """The current of every training log, when it was estimated (:mod:`companion.models.current`)."""


def smooth(rec: Record, window_s: float = 0.5, polyorder: int = 3) -> tuple[FloatArray, FloatArray]:
    """Savitzky-Golay smoothed nu and nu_dot of a record (uniform sampling assumed)."""
    dt = rec.dt_s
    win = max(polyorder + 2, round(window_s / dt) | 1)
    if win >= len(rec):
        raise IdentificationError(f"{rec.name}: record shorter than the {window_s} s smoothing window")
    nu_s = savgol_filter(rec.nu, win, polyorder, axis=0, mode="interp")
    nu_dot = savgol_filter(rec.nu, win, polyorder, deriv=1, delta=dt, axis=0, mode="interp")
    return np.asarray(nu_s), np.asarray(nu_dot)


def _window_samples(rec: Record, window_s: float) -> int:
    return max(5, round(window_s / rec.dt_s) | 1)


def check_excitation(records: Sequence[Record]) -> None:
    """Raise :class:`IdentificationError` when steering is not excited at all."""
    delta = np.concatenate([r.delta_rad for r in records])
    yaw = np.concatenate([r.nu[:, 2] for r in records])
    problems = []
    if np.std(delta) < MIN_DELTA_STD_RAD:
        problems.append(f"nozzle angle 'delta' is not excited (std {np.std(delta):.4f} rad < "
                        f"{MIN_DELTA_STD_RAD} rad)")
    if np.std(yaw) < MIN_R_STD_RADPS:
        problems.append(f"yaw rate 'r' is not excited (std {np.std(yaw):.4f} rad/s)")
    if problems:
        raise IdentificationError("; ".join(problems) + ": sway and yaw parameters cannot be identified; "
                                  "record a sine, zig-zag or random manoeuvre (see usv sim maneuver)")


def _regression(model: LinearInParamsModel, records: Sequence[Record], window_s: float,
                smoothed: Sequence[tuple[FloatArray, FloatArray]] | None = None
                ) -> tuple[FloatArray, FloatArray, dict[str, float], int]:
    """Regressors and derivatives of every record (edges dropped); ``smoothed`` (each record's
    :func:`smooth`) saves recomputing them when only the model changes."""
    phis, ys, stds = [], [], {}
    for k, rec in enumerate(records):
        nu_s, nu_dot = smoothed[k] if smoothed is not None else smooth(rec, window_s)
        e = _window_samples(rec, window_s) // 2
        sl = slice(e, len(rec) - e)
        phis.append(model.features(nu_s[sl], rec.throttle[sl], rec.delta_rad[sl]))
        ys.append(nu_dot[sl])
    phi, y = np.concatenate(phis), np.concatenate(ys)
    all_rec = records
    stds["throttle"] = float(np.std(np.concatenate([r.throttle for r in all_rec])))
    stds["delta"] = float(np.std(np.concatenate([r.delta_rad for r in all_rec])))
    for j, name in enumerate(DOF_NAMES):
        stds[name] = float(np.std(np.concatenate([r.nu[:, j] for r in all_rec])))
    return phi, y, stds, _window_samples(records[0], window_s)


def _solve_row(phi: FloatArray, y: FloatArray, names: list[str], inflate: float
               ) -> tuple[FloatArray, FloatArray, float, list[str], float]:
    """LS on the named columns; drops near-collinear columns. Returns theta, cov, cond, dropped, rss."""
    active = list(range(phi.shape[1]))
    dropped: list[str] = []
    while True:
        a = phi[:, active]
        scale = np.sqrt(np.mean(a * a, axis=0))
        scale[scale == 0] = 1.0
        u_, s, vt = np.linalg.svd(a / scale, full_matrices=False)
        cond = float(s[0] / s[-1]) if s[-1] > 0 else np.inf
        if cond <= COND_LIMIT or len(active) == 1:
            break
        worst = active[int(np.argmax(np.abs(vt[-1])))]
        dropped.append(names[worst])
        active.remove(worst)
    coef_scaled = vt.T @ ((u_.T @ y) / s)
    coef = coef_scaled / scale
    theta = np.zeros(phi.shape[1])
    theta[active] = coef
    resid = y - phi @ theta
    dof = max(1, y.size - len(active))
    sigma2 = float(resid @ resid) / dof
    inv = (vt.T / s**2) @ vt / np.outer(scale, scale)
    cov = np.zeros((phi.shape[1], phi.shape[1]))
    cov[np.ix_(active, active)] = sigma2 * inflate * inv
    return theta, cov, cond, dropped, float(resid @ resid)


def fit_least_squares(proto: LinearInParamsModel, records: Sequence[Record], window_s: float = 0.5
                      ) -> FitResult:
    """Per-DOF linear least squares of ``proto``'s structure (its theta is ignored)."""
    check_excitation(records)
    phi, y, stds, win = _regression(proto, records, window_s)
    theta = np.zeros_like(proto.theta)
    std = np.zeros_like(proto.theta)
    conds, covs, warnings = [], [], []
    mask = proto.mask_array()
    for j, dof in enumerate(DOF_NAMES):
        cols = [k for k in range(len(proto.FEATURES)) if mask[j, k]]
        names = [proto.FEATURES[k] for k in cols]
        th, cov, cond, dropped, _ = _solve_row(phi[:, cols], y[:, j], names, float(win))
        theta[j, cols] = th
        std[j, cols] = np.sqrt(np.diag(cov))
        conds.append(cond)
        covs.append(cov)
        for name in dropped:
            weak = [s for s in FEATURE_SIGNALS.get(name, ()) if stds[s] < EXCITATION_STD[s]]
            why = (f"signal(s) {', '.join(repr(w) for w in weak)} not excited" if weak
                   else "collinear with other regressors")
            warnings.append(f"{proto.name}: {dof}-regressor {name!r} not identifiable ({why}); fixed at 0")
    model = proto.with_theta(theta)
    return FitResult(model, "least squares", std, (conds[0], conds[1], conds[2]), warnings, covs)


def fit_qlpv(records: Sequence[Record], window_s: float = 0.5, name: str = "qLPV") -> FitResult:
    """qLPV least squares with the thrust-map coefficient c by variable projection."""
    check_excitation(records)
    thr = np.concatenate([r.throttle for r in records])
    u = np.concatenate([r.nu[:, 0] for r in records])
    on = thr > 0.05
    # T~ >= 0 is enforced by the model (clipped), so allow c up to twice the largest throttle/u.
    c_max = 2.0 * float(np.max(thr[on] / np.maximum(u[on], 0.1))) if np.any(on) else 0.0
    zero = QLPVModel(np.zeros((3, len(QLPVModel.FEATURES))), name=name)
    smoothed = [smooth(rec, window_s) for rec in records]

    def cost(c: float) -> float:
        proto = QLPVModel(zero.theta, name=name, thrust_speed_coeff=c)
        phi, y, _, win = _regression(proto, records, window_s, smoothed)
        total = 0.0
        mask = proto.mask_array()
        for j in range(3):
            cols = [k for k in range(phi.shape[1]) if mask[j, k]]
            rss = _solve_row(phi[:, cols], y[:, j], [proto.FEATURES[k] for k in cols], float(win))[4]
            total += rss / float(np.sum((y[:, j] - y[:, j].mean()) ** 2))
        return total

    warnings = []
    c_best = 0.0
    if c_max > 0:
        grid = np.linspace(0.0, c_max, 41)
        costs = [cost(float(c)) for c in grid]
        i = int(np.argmin(costs))
        lo, hi = float(grid[max(i - 1, 0)]), float(grid[min(i + 1, grid.size - 1)])
        res = minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 1e-5 * c_max})
        c_best = float(res.x)
        c0 = costs[0]
        if c0 - float(res.fun) < 1e-3 * c0:
            warnings.append(f"{name}: thrust-map speed term c barely improves the fit (throttle/speed "
                            "not excited enough); the thrust map is extrapolated outside the recorded "
                            "throttle")
    fit = fit_least_squares(QLPVModel(zero.theta, name=name, thrust_speed_coeff=c_best), records, window_s)
    fit.warnings[:0] = warnings
    fit.model = fit.model.with_theta(fit.model.theta, thrust_speed_coeff_bounds=(0.0, c_max))
    return fit


def _free_run_cost(model: LinearInParamsModel, records: Sequence[Record], smoothed: Sequence[FloatArray]
                   ) -> tuple[float, list[FloatArray]]:
    """Normalised free-run error of ``model`` on the training records (``smoothed``: their
    smoothed states), and the simulated states of every record."""
    cost, sims = 0.0, []
    for rec, nu_s in zip(records, smoothed, strict=True):
        sim = model.simulate(rec.t_s, nu_s[0], rec.throttle, rec.delta_rad)
        sims.append(sim)
        scale = np.sqrt(np.mean(nu_s**2, axis=0)) + 1e-3
        cost += float(np.sum(np.mean((sim - nu_s) ** 2, axis=0) / scale**2))
    return cost, sims


def _iv_row(phi: FloatArray, z: FloatArray, y: FloatArray, lb: FloatArray, ub: FloatArray, inflate: float
            ) -> tuple[FloatArray, FloatArray]:
    """One IV row on column-scaled data: solve Z^T Phi theta = Z^T y (within bounds).
    Returns theta and its covariance sigma^2 (Z^T Phi)^-1 Z^T Z (Phi^T Z)^-1."""
    scale = np.sqrt(np.mean(phi * phi, axis=0))
    scale[scale == 0] = 1.0
    a, zs = phi / scale, z / scale
    zta = zs.T @ a
    zty = zs.T @ y
    if np.all(np.isinf(lb)) and np.all(np.isinf(ub)):
        coef = np.linalg.solve(zta, zty)
    else:
        coef = lsq_linear(zta, zty, bounds=(lb * scale, ub * scale)).x
    theta = coef / scale
    resid = y - phi @ theta
    sigma2 = float(resid @ resid) / max(1, y.size - phi.shape[1])
    inv = np.linalg.pinv(zta)
    cov = sigma2 * inflate * (inv @ (zs.T @ zs) @ inv.T) / np.outer(scale, scale)
    return theta, cov


def refine_instrumental(fit: FitResult, records: Sequence[Record], window_s: float = 0.5,
                        iterations: int = 3, bounds: Bounds | None = None) -> FitResult:
    """Instrumental-variable re-estimation of ``fit`` (see the module docstring, step 5).

    The regression (smoothed measured regressors and derivatives) is the one of
    :func:`fit_least_squares`; regressors that least squares fixed at zero stay fixed.  The
    instruments are the regressors on the free-run simulation of the current model.  An
    iterate is kept only if the training free-run error does not grow; the condition numbers
    and warnings of ``fit`` (the identifiability report) are kept.
    """
    model = fit.model
    proto = model.with_theta(np.zeros_like(model.theta))
    phi, y, _, win = _regression(proto, records, window_s)
    mask = model.mask_array() != 0
    active = (model.theta != 0) & mask
    smoothed = [smooth(rec, window_s)[0] for rec in records]
    best_cost, sims = _free_run_cost(model, records, smoothed)
    best, best_std, best_cov = model, fit.std, fit.cov
    rows = []  # per DOF: estimated columns, their bounds, their places in the row's covariance
    for j in range(3):
        cols = np.flatnonzero(active[j])
        lo_hi = np.array([(bounds or {}).get((j, model.FEATURES[k]), (-np.inf, np.inf)) for k in cols],
                         dtype=float).reshape(-1, 2)
        row_cols = list(np.flatnonzero(mask[j]))
        rows.append((cols, lo_hi[:, 0], lo_hi[:, 1], [row_cols.index(k) for k in cols], len(row_cols)))
    edges = [_window_samples(rec, window_s) // 2 for rec in records]
    accepted = 0
    for _ in range(iterations):
        z = np.concatenate([model.features(sim[e:len(rec) - e], rec.throttle[e:len(rec) - e],
                                           rec.delta_rad[e:len(rec) - e])
                            for rec, sim, e in zip(records, sims, edges, strict=True)])
        theta = np.zeros_like(model.theta)
        std = np.zeros_like(model.theta)
        covs = []
        try:
            for j, (cols, lb, ub, pos, n_row) in enumerate(rows):
                th, cov = _iv_row(phi[:, cols], z[:, cols], y[:, j], lb, ub, float(win))
                theta[j, cols] = th
                std[j, cols] = np.sqrt(np.abs(np.diag(cov)))
                full = np.zeros((n_row, n_row))
                full[np.ix_(pos, pos)] = cov
                covs.append(full)
        except np.linalg.LinAlgError:
            break
        candidate = model.with_theta(theta)
        cost, cand_sims = _free_run_cost(candidate, records, smoothed)
        if not np.isfinite(cost) or cost > best_cost:
            break
        best, best_cost, best_std, best_cov, sims, model = candidate, cost, std, covs, cand_sims, candidate
        accepted += 1
    warnings = list(fit.warnings)
    if accepted == 0:
        warnings.append(f"{model.name}: instrumental variables did not improve the free-run fit of the "
                        "training records; least-squares estimate kept")
    return FitResult(best, "instrumental variables", best_std, fit.cond, warnings, best_cov)


def refine_output_error(fit: FitResult, records: Sequence[Record], rate_hz: float = 10.0,
                        max_nfev: int = 30, progress: Progress | None = None,
                        bounds: Bounds | None = None) -> FitResult:
    """Output-error refinement: minimise the free-run error (normalised per DOF) of all
    non-zero parameters over the training records, starting from ``fit`` (within ``bounds``)."""
    model = fit.model
    idx = np.flatnonzero(model.theta.ravel() != 0)
    decimated = []
    for rec in records:
        step = max(1, round(1.0 / (rate_hz * rec.dt_s)))
        nu_s, _ = smooth(rec)
        decimated.append((rec.t_s[::step], nu_s[::step], rec.throttle[::step], rec.delta_rad[::step]))
    scales = [np.sqrt(np.mean(d[1] ** 2, axis=0)) + 1e-3 for d in decimated]
    calls = [0]

    def residuals(p: FloatArray) -> FloatArray:
        th = model.theta.ravel().copy()
        th[idx] = p
        m = model.with_theta(th.reshape(model.theta.shape))
        out = []
        for (t, nu, thr, dl), sc in zip(decimated, scales, strict=True):
            sim = m.simulate(t, nu[0], thr, dl)
            out.append(((sim - nu) / sc).ravel() / np.sqrt(t.size))
        calls[0] += 1
        if progress is not None:
            progress(min(calls[0], max_nfev * (idx.size + 1)), max_nfev * (idx.size + 1))
        return np.concatenate(out)

    p0 = model.theta.ravel()[idx]
    lb, ub = np.full(idx.size, -np.inf), np.full(idx.size, np.inf)
    for (j, name), (lo, hi) in (bounds or {}).items():
        flat = j * model.theta.shape[1] + model.FEATURES.index(name)
        if flat in idx:
            lb[np.flatnonzero(idx == flat)], ub[np.flatnonzero(idx == flat)] = lo, hi
    p0 = np.clip(p0, np.where(np.isinf(lb), lb, lb + 1e-9), np.where(np.isinf(ub), ub, ub - 1e-9))
    res = least_squares(residuals, p0, x_scale=np.abs(p0) + 1e-6, max_nfev=max_nfev, method="trf",
                        bounds=(lb, ub))
    th = model.theta.ravel().copy()
    th[idx] = res.x
    refined = model.with_theta(th.reshape(model.theta.shape))
    std = np.zeros(th.size)
    try:
        jtj_inv = np.linalg.pinv(res.jac.T @ res.jac)
        sigma2 = float(res.fun @ res.fun) / max(1, res.fun.size - idx.size)
        std[idx] = np.sqrt(np.abs(np.diag(jtj_inv)) * sigma2)
    except np.linalg.LinAlgError:
        pass
    warnings = list(fit.warnings)
    if not res.success:
        warnings.append(f"{model.name}: output-error refinement stopped after {res.nfev} evaluations "
                        f"({res.message})")
    return FitResult(refined, "output error", std.reshape(model.theta.shape), fit.cond, warnings)
