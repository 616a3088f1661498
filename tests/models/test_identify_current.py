"""Identification takes a log's current out (issue 14): a log recorded in a flood current gives
that current back, and a calm log is left over ground (no current invented from noise)."""

from __future__ import annotations

import math

import pytest

from benchmarks.identify import simulated_record
from companion.models.current import estimate_currents
from companion.models.identify import fit_qlpv

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
