"""The figures of ``usv bench nav`` on made-up tracks whose answers are known by construction."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks.nav_metrics import Truth, arrival, loiter, sampling, square
from companion.guidance.geo import LocalFrame

HOME = (41.77, 123.43)
STEP_S = 0.05


def truth(tmp_path: Path, track: list[tuple[float, float]], pump: list[int] | None = None,
          valve: list[int] | None = None) -> Truth:
    """A truth log of ``track`` (north, east metres from HOME), one point per 0.05 s from t = 0."""
    frame = LocalFrame(*HOME)
    path = tmp_path / "truth.csv"
    lines = ["t_s,lat_deg,lon_deg,north_m,east_m,heading_deg,sog_mps,pump_on,valve"]
    for i, (n, e) in enumerate(track):
        lat, lon = frame.to_lat_lon(n, e)
        lines.append(f"{i * STEP_S:.2f},{lat:.10f},{lon:.10f},{n},{e},0,0,{(pump or [0] * len(track))[i]},"
                     f"{(valve or [0] * len(track))[i]}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return Truth(path, HOME)


def line(a: tuple[float, float], b: tuple[float, float], n: int) -> list[tuple[float, float]]:
    return [(a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n) for k in range(n)]


def test_loiter_max_and_rms_from_the_entry_point(tmp_path: Path) -> None:
    # enters at (10, 10), then circles it at 1.5 m for the rest of the window
    track = [(10.0, 10.0)] + [(10.0 + 1.5 * math.cos(a), 10.0 + 1.5 * math.sin(a))
                              for a in np.linspace(0.0, 12.0, 400)]
    fig = loiter(truth(tmp_path, track), 0.0, 20.0)
    assert fig["max_m"] == pytest.approx(1.5, abs=1e-3)
    assert fig["rms_m"] == pytest.approx(1.5, abs=0.01)
    assert fig["entry_ne"] == pytest.approx([10.0, 10.0], abs=1e-3)


def test_arrival_overshoot_is_how_far_the_boat_ran_past_the_point(tmp_path: Path) -> None:
    # from home north-east to (30, 30), 3 m past it along the approach, back to it
    past = (30.0 + 3.0 / math.sqrt(2), 30.0 + 3.0 / math.sqrt(2))
    track = line((0.0, 0.0), (30.0, 30.0), 200) + line((30.0, 30.0), past, 20) + line(past, (30.0, 30.0), 20)
    track += [(30.0, 30.0)] * 40
    fig = arrival(truth(tmp_path, track), 0.0, 100.0, (30.0, 30.0), radius_m=2.0)
    assert fig["overshoot_m"] == pytest.approx(3.0, abs=0.01)
    assert fig["after_arrival_max_m"] == pytest.approx(3.0, abs=0.01)
    assert fig["time_to_radius_s"] == pytest.approx(200 * (1 - 2.0 / math.hypot(30, 30)) * STEP_S, abs=0.06)
    short = arrival(truth(tmp_path, line((0.0, 0.0), (27.0, 27.0), 200)), 0.0, 10.0, (30.0, 30.0), 2.0)
    assert short["overshoot_m"] == 0.0 and math.isinf(short["after_arrival_max_m"])


def test_square_side_distance_and_mid_leg_cross_track(tmp_path: Path) -> None:
    corners = [(50.0, 0.0), (50.0, 50.0), (0.0, 50.0), (0.0, 0.0)]
    # AUTO entered at home; leg 1 flown 0.3 m east of its line; a swing 4 m out past the first corner
    # (2 m along the second leg); legs 2-4 on their lines
    track = [(0.0, 0.0), *line((0.0, 0.3), (50.0, 0.3), 199), (54.0, 2.0)]
    track += line((50.0, 0.0), (50.0, 50.0), 200)
    track += line((50.0, 50.0), (0.0, 50.0), 200) + line((0.0, 50.0), (0.0, 0.0), 200) + [(0.0, 0.0)]
    reached = {1: 200 * STEP_S, 2: 401 * STEP_S, 3: 601 * STEP_S, 4: 801 * STEP_S}
    fig = square(truth(tmp_path, track), 0.0, 801 * STEP_S, corners, reached)
    assert fig["side_max_m"] == pytest.approx(4.0, abs=0.01)  # from the second leg's line
    assert fig["side_max_at_ne"] == pytest.approx([54.0, 2.0], abs=1e-3)
    assert fig["mid_leg_max_m"] == pytest.approx(0.3, abs=1e-3)
    assert fig["mid_leg_rms_m"] < 0.3 and fig["legs_completed"] == 4


def test_square_entered_on_an_orbit_counts_the_wait_and_the_leg_from_where_it_joined(tmp_path: Path) -> None:
    corners = [(50.0, 0.0), (50.0, 50.0), (0.0, 50.0), (0.0, 0.0)]
    # AUTO entered on a 2 m orbit round home at its east point heading south; half an orbit
    # clockwise (bearing 90 -> 270 deg: south, then west) to the west point, heading north; the
    # first leg from there, drifting to 0.5 m west of its line at the corner
    arc = [(2.0 * math.cos(a), 2.0 * math.sin(a)) for a in np.linspace(0.5 * math.pi, 1.5 * math.pi, 200)]
    track = arc[:-1] + line((0.0, -2.0), (50.0, -0.5), 400) + line((50.0, 0.0), (50.0, 50.0), 200)
    t_join = 199 * STEP_S
    reached = {1: (199 + 400) * STEP_S, 2: (199 + 600) * STEP_S}
    fig = square(truth(tmp_path, track), 0.0, (199 + 600) * STEP_S, corners, reached, leg_start_s=t_join)
    assert fig["join_s"] == pytest.approx(t_join)
    assert fig["side_max_m"] == pytest.approx(2.0, abs=0.02)  # the orbit's far side, 2 m from home
    assert fig["first_15s_max_m"] == pytest.approx(2.0, abs=0.02)
    assert fig["side_max_after_join_m"] == pytest.approx(0.5, abs=0.02)  # at the first corner
    assert fig["mid_leg_max_m"] == pytest.approx(0.4, abs=0.02)  # 40 m along the leg from the join
    plain = square(truth(tmp_path, track), 0.0, (199 + 600) * STEP_S, corners, reached)  # from the entry
    assert plain["join_s"] == 0.0 and plain["side_max_after_join_m"] == plain["side_max_m"]
    assert plain["side_max_m"] > 3.5  # the leg from the join runs 4 m beside the one from the entry


def test_sampling_circle_error_and_each_samples_distance(tmp_path: Path) -> None:
    point = (20.0, 0.0)
    approach = line((0.0, 0.0), (17.7, 0.0), 100)  # to 2.3 m short of the point
    circle = [(20.0 - 2.3 * math.cos(a), 2.3 * math.sin(a)) for a in np.linspace(0.0, 4 * math.pi, 300)]
    wide = [(20.0 - 2.8, 0.0)]  # one sample 2.8 m out
    track = approach + circle + wide + [(20.0 - 2.3, 0.0)] * 19
    pump = [0] * 100 + [0] * 100 + [1] * 200 + [1] + [0] * 19
    valve = [0] * 200 + [1] * 201 + [0] * 19
    end_s = len(track) * STEP_S
    fig = sampling(truth(tmp_path, track, pump, valve), 0.0, end_s, [point], {1: end_s}, 2.0, [[1, 2.3]])
    assert fig["circle_error_max_m"] == pytest.approx(0.8, abs=1e-3)  # the 2.8 m excursion
    assert fig["circle_error_rms_m"] == pytest.approx(0.3, abs=0.02)
    assert fig["fill_distance_max_m"] == pytest.approx(2.8, abs=1e-3)
    assert fig["sample_distance_max_m"] == pytest.approx(2.8, abs=1e-3)  # it stopped filling out there
    assert fig["samples_taken"] == 1
    assert fig["samples"][0]["pump_s"] == pytest.approx(201 * STEP_S)
    assert fig["companion_reported_distance_m"] == [[1, 2.3]]
