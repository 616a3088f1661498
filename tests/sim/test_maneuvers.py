"""Open-loop manoeuvre logs: the chapter's sine experiment and the CSV log format."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from companion.config import ConfigError
from sim_bridge.maneuvers import COLUMNS, read_log_csv, run_maneuver, write_log_csv


def test_sine_manoeuvre_log_has_noisy_measurements_and_truth_and_round_trips(tmp_path: Path) -> None:
    log = run_maneuver("sine", throttle=0.3, amplitude_rad=math.pi / 3, period_s=10.0, duration_s=30.0)
    assert len(log) == 4000
    assert np.max(np.abs(log["delta"])) == pytest.approx(math.pi / 3, rel=1e-3)
    assert (log["throttle"] == 0.3).all()
    # measured = truth + Table 2 noise (0.1 m/s speed, 0.2 deg heading)
    assert 0.05 < np.std(log["u"] - log["u_true"]) < 0.2
    assert np.max(log["r_true"]) > 0.1 and np.min(log["r_true"]) < -0.1
    path = tmp_path / "sine.csv"
    write_log_csv(log, path)
    header = path.read_text().splitlines()[0].split(",")
    assert header == list(COLUMNS)
    back = read_log_csv(path)
    assert np.allclose(back["r"], log["r"], rtol=1e-5, atol=1e-6)


def test_zigzag_turn_and_random_run_and_differ() -> None:
    zz = run_maneuver("zigzag", throttle=0.8, amplitude_rad=math.radians(20), duration_s=20.0)
    assert set(np.unique(np.sign(zz["delta"][zz["t"] > 11.0]))) == {-1.0, 1.0}
    turn = run_maneuver("turn", throttle=0.2, duration_s=20.0)
    assert turn["r_true"][-1] > 0.2
    rnd = run_maneuver("random", duration_s=20.0)
    assert len(np.unique(rnd["throttle"])) > 3


def test_bad_manoeuvre_arguments_are_refused_clearly(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="accepted"):
        run_maneuver("spiral")
    with pytest.raises(ConfigError, match="--throttle"):
        run_maneuver("sine", throttle=1.5)
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(ConfigError, match="missing columns"):
        read_log_csv(bad)
