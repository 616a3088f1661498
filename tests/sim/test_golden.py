"""The simulator (plant, disturbances, GPS-INS noise and sentences, servo frames, the
companion's sentence parser) produces bit-identical output to the recorded fingerprints
(see :mod:`tests.sim.golden`): speed work must not move a single float."""

from __future__ import annotations

import json

import pytest

from .golden import GOLDEN_PATH, SETTINGS, fingerprint


@pytest.mark.parametrize("name", sorted(SETTINGS))
def test_simulated_boat_output_is_bit_identical_to_the_recorded_fingerprint(name: str) -> None:
    golden = json.loads(GOLDEN_PATH.read_text(encoding="utf-8"))
    assert fingerprint(name) == golden[name], (
        f"setting {name!r}: the simulator's output changed (plant floats, noise, sentences or parsing); "
        "if that is intended, regenerate with `python -m tests.sim.golden --write` and say why")
