"""The operator sees the estimated water current (issue 14): a ``usv sitl`` process with the default
configuration in a 0.8 m/s current toward 120 deg, flown by a pymavlink ground station in this
process (GUIDED to a point upstream, so the boat makes way and turns).  The ground station receives
USV_CURRENT_ESTIMATE and the NAMED_VALUE_FLOAT pair CUR_SPD / CUR_DIR at 1 Hz of vehicle time, both
saying what the simulator applies, and ``usv sitl``'s status line shows the same estimate."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest

from benchmarks.mavlink_gcs import free_port
from benchmarks.nav_gcs import GroundStation
from companion.guidance.geo import LocalFrame
from companion.messages import ModeNumber
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = [pytest.mark.integration, pytest.mark.timeout(240)]

CURRENT_MPS, CURRENT_TOWARD_DEG = 0.8, 120.0


class RecordingStation(GroundStation):
    """The bench's ground station, keeping every current report with its vehicle time."""

    def __init__(self, port: int) -> None:
        super().__init__(port)
        self.estimates: list[tuple[float, Any]] = []
        self.named: list[tuple[float, str, float]] = []

    def _observe(self, msg: Any) -> None:
        super()._observe(msg)
        kind = msg.get_type()
        if kind == "USV_CURRENT_ESTIMATE":
            self.estimates.append((msg.time_boot_ms / 1000.0, msg))
        elif kind == "NAMED_VALUE_FLOAT":
            name = msg.name if isinstance(msg.name, str) else msg.name.decode()
            self.named.append((msg.time_boot_ms / 1000.0, name.rstrip("\x00"), float(msg.value)))


def _direction_error_deg(a_deg: float, b_deg: float) -> float:
    return abs((a_deg - b_deg + 180.0) % 360.0 - 180.0)


def test_ground_station_and_status_line_show_the_estimated_current(tmp_path: Path,
                                                                   usv_env: dict[str, str]) -> None:
    port = free_port()
    config = write_config(tmp_path / "sitl.toml", tmp_path / "state", [port])
    log = tmp_path / "sitl.log"
    args = ["--current", f"{CURRENT_MPS},{CURRENT_TOWARD_DEG}", "--seed", "4", "--status-every", "20"]
    gcs = RecordingStation(port)
    try:
        with sitl(config, usv_env, speedup=20.0, log=log, extra_args=args):
            gcs.connect()
            assert gcs.home is not None
            gcs.arm()
            upstream = LocalFrame(*gcs.home).to_lat_lon(-150.0 * math.cos(math.radians(CURRENT_TOWARD_DEG)),
                                                        -150.0 * math.sin(math.radians(CURRENT_TOWARD_DEG)))
            gcs.goto(*upstream)
            gcs.sleep_vehicle(70.0)
    finally:
        gcs.close()

    late = [m for t, m in gcs.estimates if t >= 50.0]
    assert len(late) >= 10, f"{len(gcs.estimates)} USV_CURRENT_ESTIMATE in total"
    for m in late:
        assert m.speed == pytest.approx(CURRENT_MPS, abs=0.15)
        assert _direction_error_deg(m.direction, CURRENT_TOWARD_DEG) < 15.0
        assert math.hypot(m.current_north, m.current_east) == pytest.approx(m.speed, abs=1e-4)
        assert m.confidence > 0.9 and m.estimator == 1 and m.speed_std < 0.1
    # 1 Hz of vehicle time (the stream scheduler's default), the pair sent together
    window = [t for t, _ in gcs.estimates if 30.0 <= t < 60.0]
    assert 27 <= len(window) <= 33
    speeds = [(t, v) for t, n, v in gcs.named if n == "CUR_SPD" and 30.0 <= t < 60.0]
    directions = [(t, v) for t, n, v in gcs.named if n == "CUR_DIR" and 30.0 <= t < 60.0]
    assert 27 <= len(speeds) <= 33 and len(directions) == len(speeds)
    assert all(v == pytest.approx(CURRENT_MPS, abs=0.15) for t, v in speeds if t >= 50.0)
    assert all(_direction_error_deg(v, CURRENT_TOWARD_DEG) < 15.0 for t, v in directions if t >= 50.0)

    lines = [ln for ln in log.read_text(errors="replace").splitlines() if ln.startswith("usv sitl: t=")]
    assert len(lines) >= 3, log.read_text(errors="replace")
    last = re.search(r"sim ([\d.]+) m/s toward (\d+) deg, estimate ([\d.]+) m/s toward (\d+) deg "
                     r"\(confidence ([\d.]+)\)", lines[-1])
    assert last is not None, lines[-1]
    sim_speed, sim_dir, est_speed, est_dir, conf = (float(x) for x in last.groups())
    assert (sim_speed, sim_dir) == (CURRENT_MPS, CURRENT_TOWARD_DEG)
    assert est_speed == pytest.approx(CURRENT_MPS, abs=0.15)
    assert _direction_error_deg(est_dir, CURRENT_TOWARD_DEG) < 15.0 and conf > 0.9


@pytest.mark.parametrize(("seed", "speed_mps", "toward_deg"), [(1, 0.0, 0.0), (2, 0.3, 200.0)])
def test_ground_station_sees_the_water_from_the_start_of_a_go_to(tmp_path: Path, usv_env: dict[str, str],
                                                                 seed: int, speed_mps: float,
                                                                 toward_deg: float) -> None:
    """Armed, GUIDED and a go-to 30 m N / 30 m E at once, as the bench's ground station does: in
    calm water no report in the first 30 s claims a current (0.15 m/s or more at confidence 0.5
    or more); in 0.3 m/s every report from 5 s on is within 0.1 m/s and 15 deg of it.  Before the
    filter's transient process noise (``TRANSIENT_Q_S``) the start and the sprint were taken for a
    current: 0.19-0.29 m/s at confidence 1.00 for 15 s in calm water, 0.56-0.73 m/s in 0.3 m/s."""
    port = free_port()
    config = write_config(tmp_path / "sitl.toml", tmp_path / "state", [port])
    gcs = RecordingStation(port)
    try:
        with sitl(config, usv_env, speedup=20.0, log=tmp_path / "sitl.log",
                  extra_args=["--current", f"{speed_mps},{toward_deg}", "--seed", str(seed)]):
            gcs.connect()
            assert gcs.home is not None
            gcs.arm()
            gcs.set_mode(ModeNumber.GUIDED)
            gcs.goto(*LocalFrame(*gcs.home).to_lat_lon(30.0, 30.0))
            gcs.sleep_vehicle(30.0)
    finally:
        gcs.close()
    reports = [(t, m) for t, m in gcs.estimates if t <= 30.0]
    assert len(reports) >= 25, f"{len(gcs.estimates)} USV_CURRENT_ESTIMATE in total"
    if speed_mps == 0.0:
        claims = [(t, round(m.speed, 2)) for t, m in reports if m.confidence >= 0.5 and m.speed >= 0.15]
        assert not claims, f"a current claimed in calm water: {claims}"
        return
    for t, m in reports:
        if t >= 5.0:
            assert m.confidence > 0.9 and m.speed == pytest.approx(speed_mps, abs=0.1), (t, m)
            assert _direction_error_deg(m.direction, toward_deg) < 15.0, (t, m)
