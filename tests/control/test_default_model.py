"""The shipped default model is what ``usv sim maneuver`` + ``usv identify`` make, not a hand edit.

The control benchmark and the closed-loop tests fly that file (bench == product), so this is
what makes their figures figures of the shipped boat."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.control_ident import DEFAULT_MODEL_PROTOCOL, identify_default_model, shipped_model
from companion.models.params_file import DEFAULT_PARAMS_PATH, load_model_params, load_ukf_settings

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]  # minutes of identification: slow on a busy machine


def test_shipped_default_model_is_reproduced_by_the_identification_commands(tmp_path: Path) -> None:
    made_path = identify_default_model(tmp_path)
    made, shipped = load_model_params(made_path), shipped_model()
    assert shipped.meta["path"] == str(DEFAULT_PARAMS_PATH)
    # the CSV logs hold 6 significant digits, so libraries may round the last bits differently
    np.testing.assert_allclose(made.theta, shipped.theta, rtol=1e-4, atol=1e-9)
    assert np.isclose(made.thrust_speed_coeff, shipped.thrust_speed_coeff, rtol=1e-4)
    assert load_ukf_settings(made_path) is not None
    for name, _ in DEFAULT_MODEL_PROTOCOL:  # the training logs were written and kept beside the report
        assert (tmp_path / name).stat().st_size > 0
    # what the commands wrote carries its provenance into the shipped file
    shipped_text = DEFAULT_PARAMS_PATH.read_text(encoding="utf-8")
    assert "usv identify random50.csv random75.csv sine30.csv" in shipped_text
