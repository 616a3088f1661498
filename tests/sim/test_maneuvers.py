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


def test_velocity_error_meets_table_2_and_is_time_correlated_like_an_ins_output() -> None:
    log = run_maneuver("sine", throttle=0.3, amplitude_rad=math.pi / 3, period_s=10.0, duration_s=120.0,
                       seed=3)
    err_u = np.asarray(log["u"] - log["u_true"])
    err_v = np.asarray(log["v"] - log["v_true"])
    speed_err = np.hypot(err_u, err_v)
    assert 0.05 < float(np.sqrt(np.mean(speed_err**2))) < 0.15  # Table 2: speed 0.1 m/s
    # an INS-propagated velocity wanders slowly: consecutive 10 ms errors are almost equal
    lag1 = float(np.corrcoef(err_u[:-1], err_u[1:])[0, 1])
    assert lag1 > 0.9
    dpsi = np.asarray(log["psi"]) - np.asarray(log["psi_true"])
    heading_err_deg = np.degrees(np.angle(np.exp(1j * dpsi)))
    assert 0.05 < float(np.std(heading_err_deg)) < 0.4  # Table 2: heading 0.2 deg
