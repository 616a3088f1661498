"""The current search's quick cost, for many candidate currents at once.

Stage 1 of :func:`companion.models.current.estimate_currents` scores about a thousand candidate
currents: each by the free-run cost over ground (:func:`companion.models.current.free_run_over_ground_cost`)
of the quick least-squares fit at that current (:func:`companion.models.current._quick_fit`).  This
is the same cost, computed faster and equal to it to rounding
(tests/models/test_current_quick.py):

* the normal equations of each log at each current are accumulated in one compiled pass
  (:func:`companion.models.current_kernel.quick_normal_equations`) and kept: while the grid moves
  one log's current, the other logs' equations are reused; summed over logs they are solved on
  scaled columns, (D^-1 G D^-1) D theta = D^-1 Phi^T Y with D = diag(RMS of each regressor), as
  the reference solves Phi D^-1;
* the free runs of all candidates are stepped together and their error over ground summed on the
  way (:func:`companion.models.current_kernel.over_ground_error_batch`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from companion.models.base import NU_LIMIT, FloatArray
from companion.models.current_kernel import over_ground_error_batch, quick_normal_equations
from companion.models.qlpv import QLPVModel

if TYPE_CHECKING:
    from companion.models.current import _Log

CHUNK_MODELS = 16
"""Candidates simulated together."""


class QuickCost:
    """Free-run cost over ground of the quick fit, for one or many candidate current vectors
    (V_cN, V_cE of every log, in log order)."""

    def __init__(self, logs: Sequence[_Log], c_thrust: float) -> None:
        self._logs = logs
        self._c_thrust = float(c_thrust)
        self._mask = QLPVModel(np.zeros((3, len(QLPVModel.FEATURES)))).mask_array() != 0
        self._equations: dict[tuple[int, float, float], tuple[FloatArray, FloatArray, int]] = {}
        self._inputs = [(np.ascontiguousarray(lg.rec.t_s, dtype=float),
                         np.ascontiguousarray(lg.rec.throttle, dtype=float),
                         np.ascontiguousarray(lg.rec.delta_rad, dtype=float)) for lg in logs]
        self._nozzle = [(np.cos(delta_rad), np.sin(delta_rad)) for _, _, delta_rad in self._inputs]

    def _log_equations(self, k: int, cn: float, ce: float) -> tuple[FloatArray, FloatArray, int]:
        key = (k, cn, ce)
        if key not in self._equations:
            lg = self._logs[k]
            throttle = self._inputs[k][1]
            cos_delta, sin_delta = self._nozzle[k]
            lo, hi = lg.edge, len(lg.rec) - lg.edge
            gram, rhs = quick_normal_equations(lg.nu, lg.nu_dot, lg.basis, lg.basis_dot, throttle, cos_delta,
                                               sin_delta, lo, hi, cn, ce, self._c_thrust)
            self._equations[key] = (gram, rhs, hi - lo)
        return self._equations[key]

    def theta(self, currents: FloatArray) -> FloatArray:
        """The quick fit's qLPV parameters (3, 11) at ``currents``."""
        return self._thetas(np.asarray(currents, dtype=float)[None, :])[0]

    def _thetas(self, cand: FloatArray) -> FloatArray:
        grams = np.zeros((len(cand), 11, 11))
        rhs = np.zeros((len(cand), 11, 3))
        rows = np.zeros(len(cand))
        for i, p in enumerate(cand):
            for k in range(len(self._logs)):
                g, b, n = self._log_equations(k, float(p[2 * k]), float(p[2 * k + 1]))
                grams[i] += g
                rhs[i] += b
                rows[i] += n
        theta = np.zeros((len(cand), *self._mask.shape))
        for j in range(3):
            sel = np.flatnonzero(self._mask[j])
            g = grams[:, sel[:, None], sel[None, :]]
            col = np.sqrt(np.diagonal(g, axis1=1, axis2=2) / rows[:, None])
            col[col == 0] = 1.0
            a = g / (col[:, :, None] * col[:, None, :])
            b = rhs[:, sel, j] / col
            try:
                x = np.linalg.solve(a, b[..., None])[..., 0]
            except np.linalg.LinAlgError:  # one singular: each on its own, as the reference does
                x = np.stack([_solve_or_lstsq(ai, bi) for ai, bi in zip(a, b, strict=True)])
            theta[:, j, sel] = x / col
        return theta

    def costs(self, candidates: FloatArray) -> FloatArray:
        """The cost of every row of ``candidates`` (M, 2 x logs); inf where a free run diverges."""
        cand = np.atleast_2d(np.asarray(candidates, dtype=float))
        out = np.empty(len(cand))
        for s in range(0, len(cand), CHUNK_MODELS):
            out[s:s + CHUNK_MODELS] = self._chunk_costs(cand[s:s + CHUNK_MODELS])
        return out

    def __call__(self, currents: FloatArray) -> float:
        return float(self.costs(np.asarray(currents)[None, :])[0])

    def _chunk_costs(self, cand: FloatArray) -> FloatArray:
        thetas = self._thetas(cand)
        cost = np.zeros(len(cand))
        for k, lg in enumerate(self._logs):
            cn, ce = np.ascontiguousarray(cand[:, 2 * k]), np.ascontiguousarray(cand[:, 2 * k + 1])
            nu_r0 = lg.nu[0] - cn[:, None] * lg.basis[0, 0] - ce[:, None] * lg.basis[1, 0]
            t_s, throttle, delta_rad = self._inputs[k]
            b_n, b_e = lg.raw_basis
            sq = over_ground_error_batch(t_s, nu_r0, throttle, delta_rad, thetas, self._c_thrust, NU_LIMIT,
                                         cn, ce, b_n, b_e, lg.nu)
            cost += np.sum(sq / len(t_s) / lg.scale**2, axis=1)
        cost[~np.isfinite(cost)] = np.inf
        return cost


def _solve_or_lstsq(a: FloatArray, b: FloatArray) -> FloatArray:
    try:
        return np.asarray(np.linalg.solve(a, b))
    except np.linalg.LinAlgError:
        return np.asarray(np.linalg.lstsq(a, b, rcond=None)[0])
