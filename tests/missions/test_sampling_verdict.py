"""What ``missions/water_sampling.py`` reports as failures (no vehicle needed)."""

from __future__ import annotations

import math

from missions import water_sampling


def test_a_point_without_a_sample_is_one_failure_that_points_to_the_vehicles_messages() -> None:
    """A sample the vehicle refused (a bottle its level sensor reads full) or skipped leaves no
    record: that is the failure to report, not also an infinite tracking error from a circle that
    was never flown.  A sample without a distance is reported, not a crash."""
    args = water_sampling.parse_args([])
    points = [
        {"point": 1, "max_track_error_m": math.inf, "sample": None},
        {"point": 2, "max_track_error_m": 0.5, "sample": {"bottle": 2, "full": True, "max_distance_m": 2.31}},
        {"point": 3, "max_track_error_m": 1.5, "sample": {"bottle": 3, "full": True, "max_distance_m": None}},
        {"point": 4, "max_track_error_m": 0.4, "sample": {"bottle": 4, "full": False, "max_distance_m": 2.2}},
    ]
    assert water_sampling.judge(points, args) == [
        "P1: no sample (the vehicle refused or skipped it; see its messages)",
        "P3: the vehicle recorded no distance from the point for its sample",
        "P3: tracking error 1.5 m (limit 1.2 m)",
        "P4: bottle 4 not full",
    ]
