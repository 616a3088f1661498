"""The results directory (resume bookkeeping), the batch path of the runner, and one rescue run."""

from __future__ import annotations

from pathlib import Path

import pytest

from companion.config import ConfigError
from sim_bridge.campaign.results import RESULTS, ResultsDir, read_rows
from sim_bridge.campaign.runner import execute, run_campaign
from sim_bridge.campaign.spec import parse_campaign

MANEUVER = """
[campaign]
name = "turns"
seed = 9
[mission]
maneuver = "turn"
options = { duration_s = 15.0, warmup_s = 5.0, amplitude_rad = 0.6 }
[distributions]
current_speed_mps = { uniform = [0.0, 1.0] }
current_toward_deg = { uniform = [0.0, 360.0] }
"""


def test_a_row_cut_short_by_a_kill_is_dropped_and_another_campaign_is_refused(tmp_path: Path) -> None:
    out = ResultsDir(tmp_path, "A")
    out.append([{"index": 0, "success": True, "finished_unix_s": 1.0, "track": {"north_m": [0.0]}}])
    with (tmp_path / RESULTS).open("a", encoding="utf-8") as fh:
        fh.write("1,12345,0.3")  # the kill came while the next row was being written
    assert [r["index"] for r in read_rows(tmp_path)] == ["0"]
    again = ResultsDir(tmp_path, "A")
    assert again.finished() == {0}
    again.append([{"index": 1, "success": False, "finished_unix_s": 2.0}])
    assert [r["index"] for r in read_rows(tmp_path)] == ["0", "1"]
    assert (tmp_path / "tracks" / "00000.json").exists()
    with pytest.raises(ConfigError, match="another campaign file"):
        ResultsDir(tmp_path, "B")


def test_a_manoeuvre_campaign_runs_in_the_batch_plant_and_resumes(tmp_path: Path) -> None:
    spec_file = tmp_path / "turns.toml"
    spec_file.write_text(MANEUVER, encoding="utf-8")
    first = run_campaign(spec_file, 3, tmp_path / "out", progress=False)
    assert first.batch and first.ran == 3 and first.already_done == 0
    more = run_campaign(spec_file, 5, tmp_path / "out", progress=False)
    assert more.ran == 2 and more.already_done == 3
    rows = read_rows(tmp_path / "out")
    assert [r["index"] for r in rows] == ["0", "1", "2", "3", "4"]
    assert {r["worker"] for r in rows} == {"batch"}
    assert all(float(r["max_yaw_rate_degps"]) > 5.0 and float(r["heading_change_deg"]) > 90.0 for r in rows)


@pytest.mark.integration
def test_a_rescue_run_in_calm_water_fires_within_tolerance_and_comes_home() -> None:
    spec = parse_campaign({"campaign": {"name": "calm_rescue", "seed": 1},
                           "mission": {"script": "rescue", "options": {"casualty": "60,20", "hold": 10.0}},
                           "distributions": {"seed": 5}})
    row = execute(spec, 0)
    assert not row.get("error"), row.get("error")
    assert row["success"], row["failures"]
    assert row["launches"] == 1 and row["launches_within_tol"] == 1
    assert row["launch_distance_error_m"] <= 8.0 and row["launch_bearing_error_deg"] <= 10.0
    assert row["home_distance_m"] <= 2.0 and row["mission_complete"]
    assert row["loiter_error_max_m"] is not None and row["path_deviation_max_m"] >= 0.0
    assert row["failsafe_events"] == 0 and row["sim_time_s"] > 30.0
