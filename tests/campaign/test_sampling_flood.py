"""The water-sampling script's plan in the flood of the ``tests/missions`` suite, flown in-process
(:func:`sim_bridge.campaign.mission_run.fly`) on seeds that suite never flies."""

from __future__ import annotations

from pathlib import Path

import pytest

from sim_bridge.campaign.mission_run import fly
from sim_bridge.campaign.spec import Sample, parse_campaign

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("seed", [1030, 1037])
async def test_the_boat_stays_on_each_sampling_circle_from_the_first_time_it_is_there(
        tmp_path: Path, seed: int) -> None:
    """``missions/water_sampling.py``'s four points with its defaults in 0.5 m/s toward east, 5 m/s
    of wind from SSW and Hs 0.3 m, armed after a minute adrift as that suite's boat is.  Fig. 13's
    figure (distance from the commanded circle, from the first time within 2.5 m of each point until
    its item is done) stays within the script's 1.2 m.  When the approach still braked toward the
    centre, the boat came to the hand-over 15 m out at 3.4 m/s, the hold's sharp first turn cut the
    throttle, and the jet coasted on through the sampling circle and looped back: 20.1 / 14.9 m at
    the second point on these seeds (24.65 m over MAVLink in one CI run)."""
    spec = parse_campaign({"campaign": {"name": "flood", "seed": 1},
                           "mission": {"script": "water_sampling"}, "distributions": {}})
    sample = Sample(index=0, seed=seed, current_speed_mps=0.5, current_toward_deg=90.0,
                    wind_speed_mps=5.0, wind_from_deg=200.0, wave_hs_m=0.3)
    row = await fly(spec, sample, tmp_path, settle_s=60.0)
    assert row["mission_complete"] and row["samples_within_tol"] == 4, row["failures"]
    assert row["circle_error_max_m"] <= 1.2, row["failures"]
