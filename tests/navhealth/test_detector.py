"""Unit tests of the GPS-INS fault detector (one part, synthetic samples)."""

from __future__ import annotations

import math

from companion.messages import FixType, NavState
from companion.navhealth.detector import FROZEN_S, SILENT_S, NavFaultDetector


def sample(t_s: float, *, north_mps: float = 2.0, heading_rad: float = 0.0, r_radps: float = 0.0,
           fix: FixType = FixType.FIX_3D, attitude_valid: bool = True,
           frozen_at: float | None = None) -> NavState:
    t_pos = t_s if frozen_at is None else frozen_at
    return NavState(t_s, 41.77 + 2.0 * t_pos / 111_000.0, 123.43, 0.0, heading_rad, 0.0, 0.0, north_mps, 0.0,
                    north_mps, 0.0, r_radps, fix, 12, fix >= FixType.FIX_3D, attitude_valid)


def test_healthy_moving_boat_and_a_boat_lying_still_without_noise() -> None:
    d = NavFaultDetector()
    assert all(d.assess(sample(0.01 * i)).fault == "" for i in range(300))
    still = NavFaultDetector()  # noiseless and still: identical samples are not a frozen unit
    assert all(still.assess(sample(0.01 * i, north_mps=0.0, frozen_at=0.0)).fault == "" for i in range(300))


def test_gps_loss_keeps_the_ins_usable() -> None:
    v = NavFaultDetector().assess(sample(1.0, fix=FixType.NO_FIX))
    assert (v.gps_ok, v.ins_ok, v.fault) == (False, True, "GPS lost")


def test_frozen_solution_is_found_after_frozen_s() -> None:
    d = NavFaultDetector()
    verdicts = [d.assess(sample(0.01 * i, frozen_at=0.5 if i >= 50 else None)) for i in range(200)]
    first = next(i for i, v in enumerate(verdicts) if v.fault)
    assert verdicts[first].fault == "GPS-INS frozen" and not verdicts[first].ins_ok
    assert math.isclose(0.01 * first - 0.5, FROZEN_S, abs_tol=0.02)


def test_stale_imu_and_stuck_gyro() -> None:
    assert NavFaultDetector().assess(sample(1.0, attitude_valid=False)).fault == "IMU stale"
    d = NavFaultDetector()
    # a steady turn at 0.2 rad/s with a noiseless gyro is consistent ...
    assert all(d.assess(sample(0.01 * i, heading_rad=0.002 * i, r_radps=0.2)).fault == "" for i in range(500))
    # ... a gyro stuck at 0 while the heading turns is not
    stuck = NavFaultDetector()
    faults = {stuck.assess(sample(0.01 * i, heading_rad=0.002 * i, r_radps=0.0)).fault for i in range(300)}
    assert "gyro stuck" in faults


def test_silence() -> None:
    d = NavFaultDetector()
    assert not d.silent(100.0)  # nothing heard yet: nothing lost
    d.assess(sample(1.0))
    assert not d.silent(1.0 + SILENT_S - 0.01) and d.silent(1.0 + SILENT_S)
