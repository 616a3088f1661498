"""``python -m benchmarks.turn_capability``: how tightly the simulated boat turns at the nozzle's
stop, and how far a full-power turn started at speed runs out (the bounds under the hold targets,
``docs/tuning.md``)."""

from __future__ import annotations

import pytest

from benchmarks.nav import idle_creep_mps
from benchmarks.turn_capability import entry_row, turn_row


async def test_the_jet_turns_tighter_and_faster_with_more_throttle() -> None:
    """A water jet steers with its thrust: at the nozzle's stop the idling boat turns slowly on a
    wide circle, at full throttle fast on the tightest one."""
    idle, full = await turn_row(0.0), await turn_row(1.0)
    assert full.turn_rate_dps > 3.0 * idle.turn_rate_dps
    assert full.radius_m < idle.radius_m
    assert full.water_speed_mps > idle.water_speed_mps


async def test_a_turn_started_at_speed_runs_out_farther_than_one_started_at_the_idle_creep() -> None:
    """From a straight run at the idle creep, a full-power turn still runs out more than one
    steady turning diameter; from a faster run it runs out farther: the first lap of a hold
    entered at speed."""
    creeping, faster = await entry_row(0.0), await entry_row(0.4)
    tightest = await turn_row(1.0)
    assert creeping.entry_speed_mps == pytest.approx(idle_creep_mps(), abs=0.05)
    assert creeping.max_from_entry_m > 2.0 * tightest.radius_m
    assert faster.entry_speed_mps > creeping.entry_speed_mps + 1.0
    assert faster.max_from_entry_m > creeping.max_from_entry_m + 1.0


async def test_a_turn_started_at_the_idle_creep_runs_out_least_at_full_power() -> None:
    """The jet steers with its thrust: a boat that turns at once from the idle creep keeps closest
    to where it started at full throttle, not by easing off."""
    full, eased = await entry_row(0.0), await entry_row(0.0, turn_throttle=0.3)
    assert full.max_from_entry_m < eased.max_from_entry_m
