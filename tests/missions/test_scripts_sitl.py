"""The mission scripts as a user runs them: separate processes against ``usv sitl --speedup 10`` in
moving water (current, wind, waves: :data:`tests.missions.conftest.FLOOD`), each judged on the
outcome the issue names, from its JSON summary and, for the samples, from the vehicle's own
durable sample log (``usv samples export``).

Figures measured on this SITL (seed 3, the flood of the conftest; vehicle seconds) are in the
docstrings.
"""

from __future__ import annotations

import csv
import io
import json
import math
import subprocess
import sys
from typing import Any

import pytest

from companion.guidance.geo import LocalFrame
from tests.conftest import REPO_ROOT, usv_command
from tests.missions.conftest import FloodSitl
from tests.missions.pymavlink_gcs import PymavlinkGcs

pytestmark = [pytest.mark.integration, pytest.mark.slow]

SCRIPT_TIMEOUT_S = 420.0


def run_script(sim: FloodSitl, name: str, *args: str) -> tuple[int, dict[str, Any] | None, str]:
    """``python missions/<name>.py --url ... --json ARGS``: exit status, JSON summary, stderr."""
    proc = subprocess.run([sys.executable, str(REPO_ROOT / "missions" / f"{name}.py"), "--url", sim.url,
                           "--json", *args], cwd=sim.work_dir, env=sim.env, capture_output=True, text=True,
                          timeout=SCRIPT_TIMEOUT_S)
    lines = proc.stdout.strip().splitlines()
    summary = json.loads(lines[-1]) if lines and lines[-1].startswith("{") else None
    print(f"{name} summary: {json.dumps(summary)}")  # shown by pytest when a test fails
    return proc.returncode, summary, proc.stdout + proc.stderr


def test_rescue_launches_within_tolerance_and_tows_home(flood_sitl: FloodSitl, gcs: PymavlinkGcs) -> None:
    """The default casualty (100 m N, 30 m E) lies across the 0.5 m/s current: the script reads the
    vehicle's current estimate and stops downstream of them, bow into the current.  (Stopping on
    the direct line, bow across the current, fired in 48 % of a campaign's runs; see the README.)"""
    status, s, output = run_script(flood_sitl, "rescue")
    assert s is not None, output
    assert s["approach"] == "upstream" and 60.0 <= s["current_toward_deg"] <= 120.0, s
    assert s.get("launched"), s
    assert s["distance_error_m"] <= 8.0 and s["bearing_error_deg"] <= 10.0, s  # the script's tolerances
    assert s["home_distance_at_disarm_m"] <= s["wp_radius_m"] and not gcs.seen.armed, s
    assert status == 0 and s["ok"], output


def test_water_sampling_fills_four_bottles_inside_the_circles(flood_sitl: FloodSitl,
                                                              gcs: PymavlinkGcs) -> None:
    """Fig. 13 in the flood, default parameters: the boat holds on each circle bow into the 0.5 m/s
    current (``USV_CIRC_HOLD_C`` 0.4, below the idle creep), 0.42-0.70 m from the circle in two runs
    of this sequence over MAVLink; circling (the default before) gave 1.47-4.48 m: a 2 m circle is
    out of the hull's reach on its downstream side in 0.5 m/s (``docs/tuning.md``)."""
    status, s, output = run_script(flood_sitl, "water_sampling", "--figure", "fig13.png")
    assert s is not None, output
    assert (flood_sitl.work_dir / "fig13.png").stat().st_size > 10_000  # the chapter's Fig. 13
    logged = list(csv.DictReader(io.StringIO(subprocess.run(
        [*usv_command(), "samples", "export", "--format", "csv", "--state-dir", str(flood_sitl.state_dir)],
        capture_output=True, text=True, check=True, env=flood_sitl.env).stdout)))
    assert sorted(int(r["bottle"]) for r in logged) == [1, 2, 3, 4], logged  # the vehicle's own log
    assert all(float(r["distance_m"]) <= 2.5 for r in logged), logged
    for point in s["points"]:
        assert point["sample"] is not None and point["sample"]["full"], s
        assert point["sample"]["max_distance_m"] <= 2.5, s
    assert s["home_distance_at_disarm_m"] <= s["wp_radius_m"] and not gcs.seen.armed, s
    errors = [p["max_track_error_m"] for p in s["points"]]
    assert max(errors) <= 1.2, f"Fig. 13 tracking errors {errors} m"
    assert status == 0 and s["ok"], output


def test_search_covers_its_polygon(flood_sitl: FloodSitl, gcs: PymavlinkGcs) -> None:
    home = gcs.seen.home
    assert home is not None
    frame = LocalFrame(*home)
    ring = [frame.to_lat_lon(n, e) for n, e in ((25.0, -25.0), (25.0, 25.0), (60.0, 35.0), (65.0, -20.0))]
    area = flood_sitl.work_dir / "area.geojson"
    area.write_text(json.dumps({"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [
        [[lon, lat] for lat, lon in [*ring, ring[0]]]]}}), encoding="utf-8")
    status, s, output = run_script(flood_sitl, "search", "--area", str(area), "--sweep-width", "10")
    assert s is not None, output
    assert s["coverage"] >= 0.95, s
    assert s["home_distance_at_disarm_m"] <= s["wp_radius_m"] and not gcs.seen.armed, s
    assert status == 0 and s["ok"], output
    assert math.isclose(s["area_m2"], 1987.5, rel_tol=0.02)  # the file's polygon, not the default box
