"""Issue 14's targets on the product, as a user flies it: the reduced grid of ``usv bench nav``.

Each cell is a ``usv sitl`` process with default parameters flown over MAVLink UDP by the bench's
pymavlink ground station (GUIDED go-to, LOITER 120 s, RTL, the 50 m square and the four-point
sampling mission); figures come from the simulator's truth log.  The cells are the hardest of the
full grid (:func:`benchmarks.nav_grid.reduced_grid`), on reporting seeds.  The assertions are the
issue's targets.  Where today's product misses one, the test is ``xfail(strict=True)`` with the figures
measured on it: whoever makes the product meet the target removes the mark (an unexpected pass fails).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from benchmarks.nav import fly_all, report
from benchmarks.nav_grid import REPORTING_SEEDS, reduced_grid

pytestmark = [pytest.mark.integration, pytest.mark.slow, pytest.mark.timeout(1200)]

TODAY = "usv bench nav, main at 08b0103, worst of these cells [full grid]: "
NOW = ("usv bench nav --quick, wip/path 79a807e..64b38ec (4 runs), with wip/hold merged (8dfe91f, 2 runs; "
       "corner braking 0.25 m/s^2 and USV_WP_DRIFT 0, 1 run): ")
HOLD = "usv bench nav --quick, wip/hold (LOITER/GUIDED/RTL hold from the current estimate): "
LOITER = ("usv bench nav cells flown alone at --speedup 6 (benchmarks.nav_flight.run_cell), wip/loiter "
          "(the orbit entered at its centre turns at once, entry turn upstream), reporting seed 102: ")
MISSED_TODAY = {
    "loiter_max_m_current_below_creep":
        LOITER + "3.5-4.6 m in four flights, 3.5 m in the last (main at 3ab8456: 9.4 m): the entry "
                 "turn peaks near 3.5 m and the settled orbit swings out to 2.8-4.5 m on its "
                 "downstream half, where the boat runs at 2.1-2.4 m/s over ground for 1.5 commanded. "
        + HOLD + "7.3-9.4 m in three flights (main at 08b0103: 9.3 m [9.3 m], two 7-9 m loops before "
                 "it switched to orbiting): orbits at once, but entered at speed while orbiting the "
                 "GUIDED point the boat swings out before it settles on the 2 m circle (1.7-2.7 m from "
                 "the point once settled)",
    "square_side_max_m": NOW + "1.9-2.6 m; 5.0-6.2 m; 6.1 m (main: 2.3-2.4 m [7.8 m]): corners in "
                               "1.2 m/s, the start of the first leg in 0.5 m/s (after the merge from "
                               "RTL's orbit). " + LOITER + "0.5 m/s cell 1.3-5.4 m in four flights, set "
                               "by the heading RTL's orbit has when AUTO starts (14 flights: 0.7-1.6 m "
                               "within 26 deg of the first leg, 5.4-5.9 m at 90 deg, 5.2-10.0 m for a "
                               "U-turn); 1.2 m/s cell 2.3 (main) / 2.7-3.7 m at the corners. "
                               "wip/firstleg (AUTO keeps RTL's orbit until the bow points along the "
                               "first leg, USV_WP_JOIN 70 deg): 0.5 m/s cell 1.28-1.76 m in six flights "
                               "of reporting seeds 101-103 (40 deg: 1.29-2.16 m, the orbit's far side "
                               "while AUTO waits), quick bench 1.36 m; 1.2 m/s cell 3.02-3.65 m at the "
                               "corners (no orbit there)",
    "square_mid_leg_rms_m": NOW + "0.37-0.62 m; 0.98 m; 0.40 m (main: 0.45-0.46 m [0.76 m]): the bow swings "
                                  "+-25 deg in beam seas on the legs across a 1.2 m/s current",
    "square_mid_leg_max_m": NOW + "1.0-1.6 m; 3.3 m, the first corner; 1.14 m (main: 1.2-1.3 m [4.2 m])",
    "circle_error_max_m": NOW + "2.8-5.3 m; 1.98-2.27 m; 1.54 m (main: 8.2-8.5 m [10.2 m]): in 1.2 m/s "
                                "the item holds on the circle bow into the current (USV_CIRC_HOLD_C), "
                                "0.5-2.0 m from it after the merge; in 0.5 m/s it circles, 1.0-2.3 m. "
                                "Full grid at 41d5ff3 (the hold on the circle reworked), these two "
                                "cells: 1.76 m (1.2 m/s, holding) and 1.26 m (0.5 m/s, circling); "
                                "with the hold below the creep the default (USV_CIRC_HOLD_C 0.4), full "
                                "grid: 2.17 m (1.2 m/s) and 1.75 m (0.5 m/s, holding, wind across)",
}
"""Targets today's product misses on these cells, with the figures measured (the xfail reasons).
LOITER above idle creep holds since wip/hold: 0.65 m (main at 08b0103: 11.7-12.2 m)."""
STRADDLING_TODAY: dict[str, str] = {}
"""Targets today's product meets or misses by a few centimetres depending on timing (non-strict xfail)."""


@pytest.fixture(scope="module")
def nav(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    cells = reduced_grid(REPORTING_SEEDS)
    results = fly_all(cells, Path(tmp_path_factory.mktemp("bench-nav")), keep_truth=False)
    return report(results, len(cells), 0, True, REPORTING_SEEDS, None)


def test_every_cell_flies_the_whole_script_without_a_failsafe(nav: dict[str, Any]) -> None:
    assert nav["errors"] == []
    for cell in nav["cells"]:
        fig = cell["figures"]
        assert fig["square"]["legs_completed"] == 4, cell["name"]
        assert fig["sampling"]["samples_taken"] == 4, cell["name"]
        # the truth log and the ground station's clock agree: telemetry sits on the truth
        assert fig["telemetry_vs_truth_rms_m"] < 0.3, cell["name"]


def _target_cases() -> list[Any]:
    names = ["loiter_max_m_current_above_creep", "loiter_max_m_current_below_creep", "square_side_max_m",
             "square_mid_leg_rms_m", "square_mid_leg_max_m", "circle_error_max_m", "sample_distance_max_m",
             "fill_distance_max_m", "samples_taken_min"]
    cases: list[Any] = []
    for n in names:
        if n in MISSED_TODAY:
            cases.append(pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=MISSED_TODAY[n])))
        elif n in STRADDLING_TODAY:
            cases.append(pytest.param(n, marks=pytest.mark.xfail(strict=False, reason=STRADDLING_TODAY[n])))
        else:
            cases.append(n)
    return cases


@pytest.mark.parametrize("figure", _target_cases())
def test_issue_target_holds_worst_case_over_the_reduced_grid(nav: dict[str, Any], figure: str) -> None:
    row = nav["targets"]["figures"][figure]
    assert row["pass"], f"{figure}: worst {row['worst']} (target {row['target']}) in {row['cell']}"
    assert not math.isnan(float(row["worst"]))
