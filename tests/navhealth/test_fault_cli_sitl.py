"""``usv sitl --fault``: a scheduled GPS outage in the real ``usv sitl`` process, seen by a pymavlink
ground station on its TCP port (STATUSTEXT and SYS_STATUS health, on simulated time)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from tests.conftest import usv_command
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config
from tests.security.station import Station

pytestmark = pytest.mark.integration

GPS_BIT = 32  # MAV_SYS_STATUS_SENSOR_GPS


def test_scheduled_gps_outage_is_reported_and_recovers(tmp_path: Path) -> None:
    port = free_port()
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [free_port()], port)
    env = dict(os.environ, XDG_STATE_HOME=str(tmp_path / "xdg"), PYTHONUNBUFFERED="1")
    with sitl(cfg, env, speedup=10.0, extra_args=["--fault", "gps_outage@6-16"], log=tmp_path / "sitl.log"), \
            Station(port) as station:
        lost = station.wait("STATUSTEXT", lambda m: "GPS lost: dead reckoning 30 s" in m.text, since=0,
                            timeout_s=30)
        assert lost is not None, (tmp_path / "sitl.log").read_text()
        unhealthy = station.wait("SYS_STATUS", lambda m: not m.onboard_control_sensors_health & GPS_BIT,
                                 since=0, timeout_s=10)
        assert unhealthy is not None and unhealthy.onboard_control_sensors_present & GPS_BIT
        back = station.wait("STATUSTEXT", lambda m: "GPS recovered after" in m.text, timeout_s=30)
        assert back is not None and "after 10.0 s" in back.text  # 6 s to 16 s of simulated time
        healthy = station.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_health & GPS_BIT,
                               timeout_s=10)
        assert healthy is not None


def test_a_bad_fault_schedule_is_refused_before_start(tmp_path: Path) -> None:
    env = dict(os.environ, XDG_STATE_HOME=str(tmp_path / "xdg"))
    done = subprocess.run([*usv_command(), "sitl", "--state-dir", str(tmp_path / "s"), "--fault", "gps@5-1"],
                          capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 2
    assert "--fault: invalid value 'gps@5-1'" in done.stderr and "gps_outage" in done.stderr
