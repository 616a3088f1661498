"""Water-relative velocities and the current of each identification log (issue 14).

The hull feels the water, not the ground.  With an irrotational current V_c = [V_cN, V_cE]
(earth frame, m/s, the direction the water flows toward), the qLPV model (Eq. 3-4) holds for
the water-relative velocity (Fossen 2021, Sec. 10.3):

    nu_r = nu - R(psi)^T [V_cN, V_cE, 0]^T,     nu_r_dot = A(nu_r) nu_r + B u,

where nu = [u, v, r] is what the GPS-INS measures (over ground), psi the heading (clockwise
from north) and R(psi)^T [V_cN, V_cE, 0]^T = [cos psi V_cN + sin psi V_cE,
-sin psi V_cN + cos psi V_cE, 0] the current in the body frame.

Identification.  A log recorded in a current identifies the hull only if the current is taken
out first.  Given the heading, nu_r is linear in the log's (constant) current, so the current of
every log and the thrust-map coefficient c are found by variable projection, as c alone is in
:func:`companion.models.identify.fit_qlpv`: an outer nonlinear least-squares search over
(c, V_c of each log) with the qLPV parameters solved exactly by linear least squares inside
(on the same Savitzky-Golay smoothed states and derivatives).  The current moves a regressor's
value, so it is found where the log turns: the sway row has no constant term that could absorb
a cross current, and the body-frame current rotates with the heading.  On a straight run a
current along the track is indistinguishable from a change of thrust.

The estimated current is kept only if it improves the *free-run* fit of the training logs (the
hull simulated through the water, the current added back at the logged heading), like every
other refinement of :mod:`companion.models.identify`; in calm water that leaves the over-ground
fit exactly as it was.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import OptimizeResult, least_squares
from scipy.signal import savgol_filter

from companion.models.base import NU_LIMIT, FloatArray
from companion.models.current_kernel import over_ground_residuals_batch
from companion.models.current_quick import QuickCost
from companion.models.logs import Record
from companion.models.qlpv import QLPVModel

MAX_CURRENT_MPS = 5.0
"""Bound of the current search (m/s per axis): well above any flood current a 10 m/s boat works in."""


@dataclass(frozen=True)
class LogCurrent:
    """The current estimated for one log (earth frame, toward which the water flows)."""

    north_mps: float
    east_mps: float
    std_mps: float = float("nan")
    """Standard deviation of each component (from the search's Jacobian), nan if unknown."""

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.north_mps, self.east_mps)

    @property
    def toward_rad(self) -> float:
        """Direction the water flows toward, clockwise from north in [0, 2 pi)."""
        return math.atan2(self.east_mps, self.north_mps) % (2.0 * math.pi)

    def as_dict(self) -> dict[str, float]:
        return {"north_mps": round(self.north_mps, 4), "east_mps": round(self.east_mps, 4),
                "speed_mps": round(self.speed_mps, 4), "toward_deg": round(math.degrees(self.toward_rad), 1),
                "std_mps": round(self.std_mps, 4)}


CALM = LogCurrent(0.0, 0.0, 0.0)


def current_body(psi_rad: FloatArray, north_mps: FloatArray | float, east_mps: FloatArray | float
                 ) -> FloatArray:
    """R(psi)^T [V_cN, V_cE, 0]^T: the current in the body frame, shape (N, 3) (r column zero)."""
    psi = np.asarray(psi_rad, dtype=float)
    c, s = np.cos(psi), np.sin(psi)
    n, e = np.asarray(north_mps, dtype=float), np.asarray(east_mps, dtype=float)
    out = np.zeros((*psi.shape, 3))
    out[..., 0] = c * n + s * e
    out[..., 1] = -s * n + c * e
    return out


def water_relative(rec: Record, current: LogCurrent) -> Record:
    """``rec`` with nu (and the truth) made water-relative: nu - R(psi)^T V_c.  A log without a
    heading, or a zero current, is returned unchanged."""
    if rec.psi_rad is None or (current.north_mps == 0.0 and current.east_mps == 0.0):
        return rec
    nu = rec.nu - current_body(rec.psi_rad, current.north_mps, current.east_mps)
    truth = rec.nu_true
    if truth is not None:
        psi_t = rec.psi_true_rad if rec.psi_true_rad is not None else rec.psi_rad
        truth = truth - current_body(psi_t, current.north_mps, current.east_mps)
    return replace(rec, nu=nu, nu_true=truth)


def over_ground(nu_r: FloatArray, psi_rad: FloatArray, current: LogCurrent) -> FloatArray:
    """Inverse of :func:`water_relative` for a simulated or predicted series: nu_r + R(psi)^T V_c."""
    return np.asarray(nu_r + current_body(psi_rad, current.north_mps, current.east_mps))


@dataclass
class _Log:
    """One log, smoothed once: over-ground nu and its derivative, and the smoothed body-frame
    current bases (what V_cN = 1 and V_cE = 1 add to nu and nu_dot), over the whole record."""

    rec: Record
    nu: FloatArray
    nu_dot: FloatArray
    basis: FloatArray
    """(2, N, 3): smoothed R(psi)^T [1, 0, 0]^T and R(psi)^T [0, 1, 0]^T."""
    basis_dot: FloatArray
    edge: int
    scale: FloatArray
    """Per-DOF RMS of the smoothed over-ground nu (free-run cost weights)."""
    raw_basis: FloatArray
    """(2, N, 3): the same bases unsmoothed (what a current adds to a free run over ground)."""

    def water_relative(self, cn: float, ce: float) -> tuple[FloatArray, FloatArray]:
        return (self.nu - cn * self.basis[0] - ce * self.basis[1],
                self.nu_dot - cn * self.basis_dot[0] - ce * self.basis_dot[1])


def _prepare(rec: Record, window_s: float, polyorder: int = 3) -> _Log:
    if rec.psi_rad is None:
        raise ValueError(f"{rec.name}: no heading column 'psi': the current cannot be estimated")
    dt = rec.dt_s
    win = max(polyorder + 2, round(window_s / dt) | 1)

    def sg(x: FloatArray, deriv: int = 0) -> FloatArray:
        return np.asarray(savgol_filter(x, win, polyorder, deriv=deriv, delta=dt, axis=0, mode="interp"))

    bases = np.stack([current_body(rec.psi_rad, 1.0, 0.0), current_body(rec.psi_rad, 0.0, 1.0)])
    nu = sg(rec.nu)
    return _Log(rec, nu, sg(rec.nu, 1), np.stack([sg(b) for b in bases]), np.stack([sg(b, 1) for b in bases]),
                max(5, round(window_s / dt) | 1) // 2, np.sqrt(np.mean(nu**2, axis=0)) + 1e-3, bases)


def _quick_fit(logs: Sequence[_Log], currents: FloatArray, c_thrust: float) -> QLPVModel:
    """Least squares of the qLPV rows on the water-relative smoothed logs (normal equations on
    scaled columns: the fast inner fit of the current search; the final fit is the pipeline's)."""
    proto = QLPVModel(np.zeros((3, len(QLPVModel.FEATURES))), thrust_speed_coeff=c_thrust)
    phis, ys = [], []
    for k, lg in enumerate(logs):
        nu_r, nu_r_dot = lg.water_relative(currents[2 * k], currents[2 * k + 1])
        sl = slice(lg.edge, len(lg.rec) - lg.edge)
        phis.append(proto.features(nu_r[sl], lg.rec.throttle[sl], lg.rec.delta_rad[sl]))
        ys.append(nu_r_dot[sl])
    phi, y = np.concatenate(phis), np.concatenate(ys)
    mask = proto.mask_array() != 0
    theta = np.zeros_like(proto.theta)
    for j in range(3):
        a = phi[:, mask[j]]
        col = np.sqrt(np.mean(a * a, axis=0))
        col[col == 0] = 1.0
        a = a / col
        try:
            theta[j, mask[j]] = np.linalg.solve(a.T @ a, a.T @ y[:, j]) / col
        except np.linalg.LinAlgError:
            theta[j, mask[j]] = np.linalg.lstsq(a, y[:, j], rcond=None)[0] / col
    return QLPVModel(theta, thrust_speed_coeff=c_thrust)


def free_run_over_ground_cost(model: QLPVModel, logs: Sequence[_Log], currents: FloatArray) -> float:
    """Normalised free-run error over ground: the hull simulated through the water from the
    first smoothed water-relative state, the current added back at the logged heading, against
    the smoothed measured (over-ground) nu; summed over DOF and logs."""
    cost = 0.0
    for k, lg in enumerate(logs):
        cn, ce = currents[2 * k], currents[2 * k + 1]
        rec = lg.rec
        nu_r0 = lg.nu[0] - cn * lg.basis[0, 0] - ce * lg.basis[1, 0]
        sim = model.simulate(rec.t_s, nu_r0, rec.throttle, rec.delta_rad)
        assert rec.psi_rad is not None
        og = sim + current_body(rec.psi_rad, cn, ce)
        cost += float(np.sum(np.mean((og - lg.nu) ** 2, axis=0) / lg.scale**2))
    return cost if np.isfinite(cost) else float("inf")


GRID_STEP_MPS = 0.25
GRID_MAX_MPS = 2.0
"""Stage 1 tries every current on this grid (per axis, m/s, within a disk of this radius)."""
VALLEY_SCAN_MPS: tuple[float, ...] = tuple(np.arange(-2.0, 2.01, 0.2))
"""Stage 2 starts short output-error fits at these offsets (m/s) along each log's valley (the
direction in which the quick fit's cost curves least: along the track)."""
SCAN_SIM_EVERY = 5
SCAN_NFEV = 8
"""The scan's fits simulate at a fifth of the log's rate and stop after this many evaluations."""
RESIDUAL_EVERY = 10
"""The output-error fit simulates at the log's rate and compares every 10th sample (10 Hz at
100 Hz): a free-run error is smooth, and the fit's cost is in the Jacobian's size."""
SIGNIFICANCE_CHI2 = 13.8
"""A log's current is kept if its Mahalanobis distance from zero exceeds this (chi-square, 2
degrees of freedom, 0.1 %) and it is at least :data:`MIN_CURRENT_MPS`."""
MIN_CURRENT_MPS = 0.1
"""Smallest current identification takes out of a log (m/s).  The covariance from the Jacobian
is optimistic on a smooth manoeuvre (measured: the calm 120 s sine of the shipped model's
protocol gave 0.04 m/s at 4.7 standard deviations); below 0.1 m/s, the order of the GNSS
velocity noise, a current moves the boat less than 6 m a minute and the over-ground fit is kept,
so calm logs identify exactly as over ground."""


@dataclass
class CurrentFit:
    """Result of :func:`estimate_currents`."""

    estimated: list[LogCurrent]
    """The estimate of every log, with its standard deviation."""
    significant: list[bool]
    cost: float
    """Training free-run cost over ground with the estimated currents (output-error fit)."""

    @property
    def currents(self) -> list[LogCurrent]:
        """What identification uses: the estimate where significant, else no current."""
        return [c if keep else CALM for c, keep in zip(self.estimated, self.significant, strict=True)]


def estimate_currents(records: Sequence[Record], c_thrust: float, window_s: float = 2.0) -> CurrentFit:
    """The constant current of every record (each needs a heading): see the module docstring.

    1. Every current on a grid, then a simplex search, each candidate scored by the free-run cost
       over ground of a quick least-squares fit: finds the valley of the cost (the current across
       the track is sharp there, along it weakly determined and biased by the noisy regressors).
    2. Output error over ground, jointly over the qLPV parameters and every current, started at a
       few points along each log's valley; the lowest cost wins.  Its Jacobian gives each
       current's covariance (inflated for the residuals' correlation, AR(1)).
    """
    logs = [_prepare(rec, window_s) for rec in records]
    n = len(logs)

    quick_cost = QuickCost(logs, c_thrust)
    best = _grid_search(quick_cost, n)
    for k in range(n):
        direction = _weakest_direction(quick_cost, best, k)
        scan = []
        for t in VALLEY_SCAN_MPS:
            start = best.copy()
            start[2 * k:2 * k + 2] += t * direction
            scan.append(_output_error(logs, start, c_thrust, sim_every=SCAN_SIM_EVERY, max_nfev=SCAN_NFEV))
        best = min(scan, key=lambda r: float(r.cost)).x[-2 * n:]
    sol = _output_error(logs, best, c_thrust)
    currents = sol.x[-2 * n:]
    cov = _current_covariance(sol, n)
    estimated, significant = [], []
    for k in range(n):
        c = currents[2 * k:2 * k + 2]
        ck = cov[2 * k:2 * k + 2, 2 * k:2 * k + 2]
        try:
            maha = float(c @ np.linalg.solve(ck, c))
        except np.linalg.LinAlgError:
            maha = 0.0
        std = float(np.sqrt(max(ck[0, 0], ck[1, 1], 0.0)))
        estimated.append(LogCurrent(float(c[0]), float(c[1]), std))
        significant.append(bool(maha > SIGNIFICANCE_CHI2 and math.hypot(c[0], c[1]) >= MIN_CURRENT_MPS))
    return CurrentFit(estimated, significant, float(2.0 * sol.cost))


def _grid_search(cost: QuickCost, n: int) -> FloatArray:
    """Stage 1: grid (one log at a time, the grid's candidates scored together), then a simplex
    search over all currents."""
    from scipy.optimize import minimize

    best = np.zeros(2 * n)
    best_cost = cost(best)
    axis = np.arange(-GRID_MAX_MPS, GRID_MAX_MPS + 1e-9, GRID_STEP_MPS)
    grid = np.array([(cn, ce) for cn in axis for ce in axis if math.hypot(cn, ce) <= GRID_MAX_MPS + 1e-9])
    for _ in range(2 if n > 1 else 1):
        for k in range(n):
            candidates = np.tile(best, (len(grid), 1))
            candidates[:, 2 * k:2 * k + 2] = grid
            for p, c in zip(candidates, cost.costs(candidates), strict=True):
                if c < best_cost:  # the first of equal minima, as one at a time
                    best, best_cost = p.copy(), float(c)
    simplex = best + np.vstack([np.zeros(2 * n), 0.5 * GRID_STEP_MPS * np.eye(2 * n)])
    res = minimize(cost, best, method="Nelder-Mead",
                   options={"xatol": 2e-3, "fatol": 1e-6 * best_cost, "initial_simplex": simplex})
    return np.asarray(res.x) if res.fun < best_cost else best


def _weakest_direction(cost: QuickCost, p: FloatArray, k: int, h: float = 0.02) -> FloatArray:
    """Unit vector of log ``k``'s current along which ``cost`` curves least (finite differences;
    the 16 points scored together)."""
    points = []
    for i in range(2):
        for j in range(2):
            ei, ej = np.zeros_like(p), np.zeros_like(p)
            ei[2 * k + i], ej[2 * k + j] = h, h
            points += [p + ei + ej, p + ei - ej, p - ei + ej, p - ei - ej]
    c = cost.costs(np.array(points)).reshape(2, 2, 4)
    hess = (c[..., 0] - c[..., 1] - c[..., 2] + c[..., 3]) / (4 * h * h)
    _, vecs = np.linalg.eigh(0.5 * (hess + hess.T))
    return np.asarray(vecs[:, 0])


_SOLVER_TAKES_WORKERS = "workers" in inspect.signature(least_squares).parameters


def _output_error(logs: Sequence[_Log], currents: FloatArray, c_thrust: float, sim_every: int = 1,
                  max_nfev: int = 200) -> OptimizeResult:
    """Least squares of the free-run error over ground, over the non-zero qLPV parameters (started
    from the quick fit at ``currents``) and the currents; ``x`` ends with the currents.  The
    simulation runs on every ``sim_every``-th sample (inputs held), the residual is taken at 10 Hz.
    The finite-difference Jacobian's parameter vectors are simulated together
    (:func:`companion.models.current_kernel.over_ground_residuals_batch`, handed to the solver as
    its ``workers`` map): the same residuals, so the same fit, as one at a time."""
    c_thrust = float(c_thrust)
    start = _quick_fit(logs, currents, c_thrust)
    idx = np.flatnonzero(start.theta.ravel() != 0)
    n_theta = idx.size
    stride = max(1, RESIDUAL_EVERY // sim_every)
    every = stride * sim_every
    sl = slice(None, None, sim_every)
    raw_bases = [np.ascontiguousarray(lg.raw_basis[:, ::every]) for lg in logs]
    targets = [np.ascontiguousarray(lg.nu[::every]) for lg in logs]
    inputs = [tuple(np.ascontiguousarray(x[sl], dtype=float)
                    for x in (lg.rec.t_s, lg.rec.throttle, lg.rec.delta_rad)) for lg in logs]

    def residuals_of(params: Iterable[FloatArray]) -> list[FloatArray]:
        p = np.array(list(params), dtype=float)
        thetas = np.zeros((len(p), start.theta.size))
        thetas[:, idx] = p[:, :n_theta]
        thetas = thetas.reshape(len(p), *start.theta.shape)
        out = []
        for k, (lg, raw, target, (t_s, throttle, delta_rad)) in enumerate(
                zip(logs, raw_bases, targets, inputs, strict=True)):
            cn = np.ascontiguousarray(p[:, n_theta + 2 * k])
            ce = np.ascontiguousarray(p[:, n_theta + 2 * k + 1])
            nu_r0 = lg.nu[0] - cn[:, None] * lg.basis[0, 0] - ce[:, None] * lg.basis[1, 0]
            out.append(over_ground_residuals_batch(t_s, nu_r0, throttle, delta_rad, thetas, c_thrust,
                                                   NU_LIMIT, cn, ce, raw[0], raw[1], target, lg.scale,
                                                   stride))
        return list(np.concatenate(out, axis=1))

    def residuals(p: FloatArray) -> FloatArray:
        return residuals_of([p])[0]

    def batch_map(_fun: Callable[[FloatArray], FloatArray], params: Iterable[FloatArray]
                  ) -> list[FloatArray]:
        return residuals_of(params)

    x0 = np.concatenate([start.theta.ravel()[idx], currents])
    batched = {"workers": batch_map} if _SOLVER_TAKES_WORKERS else {}  # scipy >= 1.16; else one at a time
    res = least_squares(residuals, x0, x_scale=np.abs(x0) + 1e-2, max_nfev=max_nfev, **batched)
    res.n_theta = n_theta
    return res


def _current_covariance(sol: OptimizeResult, n: int) -> FloatArray:
    """Covariance of the currents (last 2n entries of ``sol.x``): sigma^2 (J^T J)^-1, inflated by
    (1 + rho) / (1 - rho) for the residuals' lag-one correlation rho (a free-run error is smooth)."""
    r = np.asarray(sol.fun)
    sigma2 = float(r @ r) / max(1, r.size - sol.x.size)
    cols = r.reshape(-1, 3)
    rho = float(np.nanmean([np.corrcoef(cols[:-1, j], cols[1:, j])[0, 1] for j in range(3)]))
    rho = min(max(rho, 0.0), 0.9999)
    jac = np.asarray(sol.jac)
    cov = np.linalg.pinv(jac.T @ jac) * sigma2 * (1.0 + rho) / (1.0 - rho)
    return np.asarray(cov[-2 * n:, -2 * n:])
