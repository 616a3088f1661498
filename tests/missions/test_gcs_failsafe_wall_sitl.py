"""An external pymavlink ground station sending HEARTBEAT at 1 Hz of *wall* time, as every ground
station does, against ``usv sitl --speedup 10``: one heartbeat per ten simulated seconds, twice
FS_GCS_TIMEOUT.  For 300 simulated seconds the boat stays armed in LOITER without a failsafe;
when the station really falls silent, the GCS failsafe acts (HOLD, FS_ACTION's default) after
three missed heartbeats, and the chapter's engine stop disarms the boat 120 +- 5 simulated
seconds after the last heartbeat.
"""

from __future__ import annotations

import time

import pytest

from tests.missions.conftest import FloodSitl
from tests.missions.pymavlink_gcs import CMD_ARM_DISARM, PymavlinkGcs

pytestmark = [pytest.mark.integration, pytest.mark.slow]

MODE_HOLD, MODE_LOITER = 4, 5
MAV_STATE_CRITICAL = 5
FS_GCS_TIMEOUT_S, ENG_STOP_S = 5.0, 120.0


def test_wall_clock_heartbeats_keep_fast_sitl_out_of_failsafe_and_silence_still_stops_the_engine(
        flood_sitl: FloodSitl) -> None:
    station = PymavlinkGcs(flood_sitl.gcs_port, heartbeats=True)
    try:
        station.wait(lambda: station.last_heartbeat_t_s is not None and station.seen.position is not None, 30,
                     "link up")
        station.wait(lambda: not station.seen.armed, 30, "disarmed at the start")
        assert station.command(CMD_ARM_DISARM, 1) == 0
        assert station.set_mode(MODE_LOITER) == 0
        station.wait(lambda: station.seen.armed and station.seen.mode == MODE_LOITER, 10, "armed in LOITER")
        start_s = station.seen.t_s
        statuses: set[int] = set()
        while station.seen.t_s < start_s + 300.0:  # 30 wall seconds at 10x
            statuses.add(station.seen.system_status)
            assert station.seen.armed and station.seen.mode == MODE_LOITER, station.seen.texts[-5:]
            time.sleep(0.1)
        assert not [t for t in station.texts_since(start_s) if "failsafe" in t]
        assert MAV_STATE_CRITICAL not in statuses

        station.heartbeats = False  # the ground station falls silent
        time.sleep(1.2)  # a heartbeat being sent just now is the last one
        last_s = station.last_heartbeat_t_s
        assert last_s is not None
        station.wait(lambda: any("GCS failsafe" in t for t in station.texts_since(last_s)), 60, "failsafe")
        failsafe_s = next(t for t, text in station.seen.texts if t >= last_s and "GCS failsafe" in text)
        station.wait(lambda: station.seen.mode == MODE_HOLD, 10, "HOLD")
        assert FS_GCS_TIMEOUT_S < failsafe_s - last_s < 45.0  # 3 missed wall-clock heartbeats
        station.wait(lambda: not station.seen.armed, 60, "engine stop")
        stop_s = next(t for t, text in station.seen.texts if t >= last_s and "engine stop" in text)
        assert abs(stop_s - last_s - ENG_STOP_S) <= 5.0, (last_s, failsafe_s, stop_s)

        station.heartbeats = True  # back: the failsafe clears, the engine stays stopped
        station.wait(lambda: any("failsafe cleared" in t for t in station.texts_since(stop_s)), 15, "cleared")
        assert not station.seen.armed and station.seen.mode == MODE_HOLD
    finally:
        station.close()
