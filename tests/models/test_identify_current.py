"""Identification takes a log's current out (issue 14): a log recorded in a flood current gives
that current back, a calm log is left over ground (no current invented from noise), and the hull
identified in a 0.5 m/s current flies calm held-out logs like the hull identified in calm water."""

from __future__ import annotations

import math

import pytest

from benchmarks.identify import simulated_record
from companion.models.current import estimate_currents
from companion.models.evaluate import free_run, j_of, reference
from companion.models.identify import fit_qlpv
from companion.models.pipeline import identify_models

pytestmark = pytest.mark.slow


def test_current_of_a_flood_log_is_found_and_a_calm_log_stays_calm() -> None:
    flood = simulated_record("sine", 5, current="0.5,90", duration_s=90.0)
    calm = simulated_record("sine", 1, duration_s=90.0)
    logs = [flood, calm]
    c_thrust = fit_qlpv(logs, 2.0, name="qlpv").model.thrust_speed_coeff
    fit = estimate_currents(logs, c_thrust, 2.0)
    found, still = fit.currents
    assert fit.significant == [True, False]
    assert math.isclose(found.speed_mps, 0.5, abs_tol=0.1), found
    # the sim's '0.5,90' flows toward the east
    assert abs(found.north_mps) < 0.1 and found.east_mps > 0.4, found
    assert still.speed_mps == 0.0


def _free_run_j(model, rec) -> dict[str, float]:
    return j_of(free_run(model, rec), reference(rec))


@pytest.fixture(scope="module")
def hulls() -> dict[str, object]:
    """The hull identified from the same manoeuvre (sine, seed 5, 90 s) in calm water and in a
    0.5 m/s current, the latter with and without taking the current out."""
    calm = [simulated_record("sine", 5, duration_s=90.0)]
    flood = [simulated_record("sine", 5, current="0.5,90", duration_s=90.0)]
    return {"calm": identify_models(calm)["qlpv"].model,
            "flood": identify_models(flood)["qlpv"].model,
            "flood_over_ground": identify_models(flood, current="none")["qlpv"].model}


def test_a_hull_identified_in_a_flood_flies_a_calm_random_log_like_the_calm_one(hulls) -> None:
    held_out = simulated_record("random", 4, duration_s=60.0)
    calm, flood = _free_run_j(hulls["calm"], held_out), _free_run_j(hulls["flood"], held_out)
    assert all(flood[d] <= 1.2 * calm[d] for d in calm), (calm, flood)
    over_ground = _free_run_j(hulls["flood_over_ground"], held_out)
    assert all(over_ground[d] > 1.4 * calm[d] for d in calm), over_ground  # the river, not the hull


@pytest.mark.xfail(strict=True, reason=(
    "measured (sine 5-7 in 0.5 m/s against the same seeds calm): u 0.99-1.03, r 0.95-1.12, but sway "
    "1.26-2.13 times the calm hull's J_v on a calm sine (J_v itself 1.6-3.5 %); on a calm random log "
    "all three within 0.94-1.07"))
def test_a_hull_identified_in_a_flood_flies_a_calm_sine_within_20_percent(hulls) -> None:
    held_out = simulated_record("sine", 2, duration_s=60.0)
    calm, flood = _free_run_j(hulls["calm"], held_out), _free_run_j(hulls["flood"], held_out)
    assert all(flood[d] <= 1.2 * calm[d] for d in calm), (calm, flood)
