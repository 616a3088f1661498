"""A small campaign for the integration tests: the sampling mission on short legs in weak currents."""

from __future__ import annotations

from pathlib import Path

import pytest

TINY_CAMPAIGN = """
[campaign]
name = "tiny_sampling"
seed = 11
description = "the sampling mission on 8 m legs, for tests"

[mission]
script = "water_sampling"
options = { points = ["8,0", "8,8", "0,8", "-4,4"], volume = 50.0, speed = 2.0, timeout = 300 }

[distributions]
current_speed_mps = { uniform = [0.0, 0.4] }
current_toward_deg = { uniform = [0.0, 360.0] }
wind_speed_mps = { uniform = [0.0, 3.0] }
wind_from_deg = { uniform = [0.0, 360.0] }
"""


@pytest.fixture
def tiny_campaign(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_CAMPAIGN, encoding="utf-8")
    return path
