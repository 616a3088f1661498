"""The simulator (plant, disturbances, GPS-INS noise and sentences, servo frames, the
companion's sentence parser) produces bit-identical output to the recorded fingerprints
(see :mod:`tests.sim.golden`): speed work must not move a single float."""

from __future__ import annotations

import json

import pytest

from .golden import GOLDEN_PATH, PLATFORM_KEY, SETTINGS, fingerprint, platform_key


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_simulated_boat_output_is_bit_identical_to_the_recorded_fingerprint(name: str) -> None:
    golden = json.loads(GOLDEN_PATH.read_text(encoding="utf-8"))
    here = platform_key()
    if golden.get(PLATFORM_KEY) != here:
        pytest.skip(f"fingerprints recorded on {golden.get(PLATFORM_KEY)}, this is {here}: floats may differ "
                    "in the last bit; regenerate here (`python -m tests.sim.golden --write`) to compare")
    assert fingerprint(name) == golden[name], (
        f"setting {name!r}: the simulator's output changed (plant floats, noise, sentences or parsing); "
        "if that is intended, regenerate with `python -m tests.sim.golden --write` and say why")
