"""``python -m benchmarks.idle_drift``: the idling boat's drift over ground by heading, the table
behind ``docs/tuning.md``'s section on holds in wind against the current."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from benchmarks import idle_drift, turn_capability
from benchmarks.idle_drift import drift_row
from benchmarks.nav import idle_creep_mps


async def test_in_slack_water_the_idling_boat_creeps_along_its_bow_and_stays_put_engine_off() -> None:
    """No current, wind or waves: bow "upstream" (south, for a current toward north) the idling jet
    creeps at its idle speed, the speed ``USV_HOLD_CREEP`` stands for; with the engine off the boat
    stays where it is."""
    creep = idle_creep_mps()
    bow_up = await drift_row("0,0", "0,0", "0", 1, 0.0)
    assert bow_up.down_current_mps == pytest.approx(-creep, abs=0.05)
    assert bow_up.across_mps == pytest.approx(0.0, abs=0.05)
    across = await drift_row("0,0", "0,0", "0", 1, 90.0)
    assert across.across_mps == pytest.approx(-creep, abs=0.05)  # bow 90 deg clockwise of south: west
    off = await drift_row("0,0", "0,0", "0", 1, 0.0, engine_on=False)
    assert abs(off.down_current_mps) < 0.02 and abs(off.across_mps) < 0.02 and off.heading_error_deg is None


async def test_with_the_wind_against_a_weak_current_the_bow_into_the_wind_drifts_least() -> None:
    """0.5 m/s toward E with 6 m/s of wind from E and Hs 0.3 m: bow upstream the idling boat creeps
    up the current (the keeper cannot hold there), bow into the wind it drifts far slower."""
    up = await drift_row("0.5,90", "6,90", "0.3", 5, 0.0)
    into_wind = await drift_row("0.5,90", "6,90", "0.3", 5, 180.0)
    assert up.down_current_mps < -0.5
    assert abs(into_wind.down_current_mps) < 0.3 and abs(into_wind.across_mps) < 0.1


@pytest.mark.parametrize("main", [idle_drift.main, turn_capability.main],
                         ids=["idle_drift", "turn_capability"])
@pytest.mark.parametrize("argv", [["--current", "abc"], ["--current", "1,abc"], ["--wind=-3,90"],
                                  ["--waves", "nan"], ["--waves", "inf"]])
def test_bad_conditions_get_a_usage_error(main: Callable[[list[str]], int], argv: list[str],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """Both plant-only tools (``benchmarks.idle_drift``, ``benchmarks.turn_capability``) check their
    conditions as ``usv sitl`` does."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert "wants" in capsys.readouterr().err
