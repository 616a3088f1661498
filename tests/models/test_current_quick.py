"""The current search's quick cost, computed for many candidate currents at once (compiled normal
equations kept per log and current, batched free runs), is the readable reference's cost
(``_quick_fit`` + ``free_run_over_ground_cost``, numpy) to rounding, and finds its minimum at the
same grid point: the search that uses it finds the same currents."""

from __future__ import annotations

import numpy as np

from benchmarks.identify import simulated_record
from companion.models.current import _prepare, _quick_fit, free_run_over_ground_cost
from companion.models.current_quick import QuickCost
from companion.models.identify import fit_qlpv


def test_batched_quick_cost_is_the_reference_cost_to_rounding() -> None:
    recs = [simulated_record("sine", 5, current="0.5,90", duration_s=30.0),
            simulated_record("random", 4, duration_s=30.0)]
    c_thrust = fit_qlpv(recs, 2.0, name="qlpv").model.thrust_speed_coeff
    logs = [_prepare(r, 2.0) for r in recs]
    rng = np.random.default_rng(7)
    east = np.linspace(-1.0, 1.0, 9)  # the flood log's current on a line through the true 0.5 m/s east
    candidates = np.vstack([np.column_stack([np.zeros(9), east, np.zeros((9, 2))]),
                            rng.uniform(-1.5, 1.5, (4, 4))])

    def reference_cost(p: np.ndarray) -> float:
        return free_run_over_ground_cost(_quick_fit(logs, p, c_thrust), logs, p)

    reference = np.array([reference_cost(p) for p in candidates])
    quick = QuickCost(logs, c_thrust)
    costs = quick.costs(candidates)
    np.testing.assert_allclose(costs, reference, rtol=1e-9)
    best = int(np.argmin(costs[:9]))
    assert best == int(np.argmin(reference[:9])) and east[best] > 0.0  # the flood flows east
    for p in candidates[[0, 6, 11]]:  # one at a time (and from the kept equations) as in the batch
        assert np.isclose(quick(p), reference_cost(p), rtol=1e-9)
        np.testing.assert_allclose(quick.theta(p), _quick_fit(logs, p, c_thrust).theta, rtol=1e-7, atol=1e-12)
