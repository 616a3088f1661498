"""Campaign files: distributions drawn reproducibly per run, bad files refused with a clear reason."""

from __future__ import annotations

from pathlib import Path

import pytest

from companion.config import ConfigError
from sim_bridge.campaign.spec import load_campaign, parse_campaign

REPO = Path(__file__).resolve().parents[2]

BASE = {"campaign": {"name": "t", "seed": 7},
        "mission": {"script": "water_sampling", "options": {"points": ["8,0", "8,8", "0,8", "-4,4"]}},
        "distributions": {"current_speed_mps": {"uniform": [0.0, 1.2]}, "payload_kg": {"choice": [0, 35, 70]},
                          "wind_speed_mps": {"normal": [3.0, 10.0]}, "wave_hs_m": 0.2}}


def test_the_shipped_campaigns_load() -> None:
    for name in ("sampling_in_current", "rescue_in_current"):
        spec = load_campaign(REPO / "campaigns" / f"{name}.toml")
        assert spec.name == name and spec.kind == "mission"
        assert "current_speed_mps" in spec.varying()


def test_a_run_draws_the_same_sample_whatever_the_campaign_size_and_runs_differ() -> None:
    spec = parse_campaign(BASE)
    again = parse_campaign(BASE)
    samples = [spec.sample(i) for i in range(50)]
    assert samples[17] == again.sample(17)
    speeds = [s.current_speed_mps for s in samples]
    assert 0.0 <= min(speeds) < 0.3 and 0.9 < max(speeds) <= 1.2
    assert {s.payload_kg for s in samples} == {0.0, 35.0, 70.0}
    assert all(0.0 <= s.wind_speed_mps <= 40.0 for s in samples)  # the normal is clipped to the range
    assert {s.wave_hs_m for s in samples} == {0.2} and samples[0].waves == "0.2"
    assert len({s.seed for s in samples}) == 50
    # changing one distribution leaves the others' draws alone
    other = parse_campaign({**BASE, "distributions": {**BASE["distributions"], "payload_kg": 10.0}})
    assert [other.sample(i).current_speed_mps for i in range(5)] == speeds[:5]


@pytest.mark.parametrize(("change", "message"), [
    ({"distributions": {"current_speed_mps": {"uniform": [0.0, 9.0]}}},
     "current_speed_mps: 9 outside [0, 5]"),
    ({"distributions": {"tide": 1.0}}, "tide: unknown variable"),
    ({"distributions": {"wind_speed_mps": {"gamma": [1, 2]}}}, "accepted: a number or one of"),
    ({"mission": {"script": "water_sampling", "options": {"volume": -5}}}, "--volume"),
    ({"mission": {"script": "fishing"}}, "script: 'fishing' unknown"),
    ({"mission": {"maneuver": "turn", "options": {"speed": 3}}}, "unknown manoeuvre option 'speed'"),
    ({"params": {"USV_CTRL_TYPE": 7}}, "USV_CTRL_TYPE"),
    ({"params": {"NO_SUCH": 1}}, "unknown parameter 'NO_SUCH'"),
    ({"config": {"sim.seed": 3}}, "set per run by the campaign"),
])
def test_bad_campaign_files_are_refused_naming_the_key(change: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        parse_campaign({**BASE, **change})
