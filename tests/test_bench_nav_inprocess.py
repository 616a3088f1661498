"""The in-process tuning rig of the nav bench (``python -m benchmarks.nav_inprocess``): deterministic,
and its comparison and command line behave."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

import pytest

from benchmarks.nav_flight import Cell
from benchmarks.nav_inprocess import FIGURES, compare, fly, main, summary


def test_a_cell_flown_twice_gives_the_same_figures_and_the_boat_holds_its_points() -> None:
    calm = Cell(0.0, 0.0, 0.0, 0.0, 0.0, 1)
    first, second = asyncio.run(fly(calm)), asyncio.run(fly(calm))
    assert first == second  # what the rig is for: a change's effect, not the flight's noise
    assert first.goto_s < 30.0 and first.rtl_s < 30.0
    # slack water: the boat orbits its points at USV_TURN_RAD (2 m); the square is flown
    assert first.loiter_max_m < 5.0 and first.arrival_max_m < 6.0
    assert first.square_side_max_m < 3.0
    # calm water, mid-leg: on the line (the bench's mid-leg cross-track, flown straight)
    assert 0.0 <= first.square_mid_leg_rms_m < 0.3 and first.square_mid_leg_max_m < 0.6


def _row(name: str, **figures: float) -> dict[str, object]:
    base = {k: 1.0 for k in FIGURES}
    return {"name": name, "figures": {**base, **figures}}


def test_compare_counts_cells_better_and_worse_beyond_the_tolerance() -> None:
    base = [_row("a"), _row("b"), _row("c"), {"name": "d", "error": "boom"}]
    new = [_row("a", loiter_max_m=0.5), _row("b", loiter_max_m=1.2), _row("c", loiter_max_m=2.0),
           _row("d", loiter_max_m=9.0)]
    out = compare(base, new, tolerance_m=0.3)
    assert out["loiter_max_m"] == {"better": 1, "worse": 1}  # b within tolerance; d has no base
    assert out["goto_s"] == {"better": 0, "worse": 0}


def test_compare_judges_the_mid_leg_figures_on_their_own_scale_and_skips_figures_the_base_lacks() -> None:
    base = [_row("a"), _row("b")]
    del base[1]["figures"]["square_mid_leg_rms_m"]  # type: ignore[index]
    new = [_row("a", square_mid_leg_rms_m=1.1), _row("b", square_mid_leg_rms_m=0.2)]
    out = compare(base, new, tolerance_m=0.3)
    assert out["square_mid_leg_rms_m"] == {"better": 0, "worse": 1}  # 0.1 m matters on a 0.15 m target


def test_summary_keeps_timed_out_phases_apart_from_the_mean() -> None:
    rows = [_row("a", rtl_s=10.0), _row("b", rtl_s=math.inf), {"name": "c", "error": "boom"}]
    out = summary(rows)
    assert out["rtl_s"] == {"worst": math.inf, "mean": 10.0, "timed_out": 1}


@pytest.mark.parametrize("bad", ["USV_TURN_RAD=nan", "USV_TURN_RAD", "=2", "USV_TURN_RAD=two"])
def test_a_bad_param_is_refused_with_a_usage_error(bad: str, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--out", str(tmp_path / "out.json"), "--param", bad])
    assert exc.value.code == 2
    assert "NAME=NUMBER" in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()
