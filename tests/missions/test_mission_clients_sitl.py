"""Both mission conventions against ``usv sitl --speedup 10`` in moving water, with real clients:

* MAVSDK's Mission plugin (no home placeholder): 20 waypoints uploaded, downloaded back
  identical, every one flown through within its acceptance radius, progress reaching 20/20 and
  ``is_mission_finished``, then RTL that stays RTL until home although MAVSDK's heartbeats come
  once per wall second (ten simulated seconds);
* QGroundControl's upload for ArduPilot (home placeholder in MAV_FRAME_GLOBAL at item 0, waypoints
  relative) from a pymavlink ground station, and MAVProxy loading a ``.waypoints`` file: the
  boat flies the first real waypoint.
"""

from __future__ import annotations

import asyncio
import math
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from companion.guidance.geo import LocalFrame
from companion.mission import items as mi
from companion.mission.items import MissionItem
from tests.missions.conftest import FloodSitl
from tests.missions.pymavlink_gcs import CMD_ARM_DISARM, PymavlinkGcs, min_distance_m

pytestmark = [pytest.mark.integration, pytest.mark.slow]

MODE_AUTO, MODE_RTL = 10, 11
ACCEPT_M = 3.0
WP_RADIUS_M = 2.0
"""The vehicle's default."""


def _track_ne(station: PymavlinkGcs, frame: LocalFrame, since_s: float) -> list[tuple[float, float]]:
    return [frame.to_ne(lat, lon) for t, lat, lon in list(station.seen.track) if t >= since_s]


def _same(a: float, b: float, tol: float = 0.0) -> bool:
    return (math.isnan(a) and math.isnan(b)) or abs(a - b) <= tol


async def _until(cond: Any, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not await cond():
        assert time.monotonic() < deadline, what
        await asyncio.sleep(0.2)


@dataclass
class Flight:
    """What a MAVSDK user saw flying 20 waypoints with the Mission plugin, then RTL."""

    uploaded: list[Any]
    downloaded: list[Any]
    points_ne: list[tuple[float, float]]
    track_ne: list[tuple[float, float]]
    progress: list[tuple[int, int]]
    finished: bool
    rtl_modes: list[int]
    mode_at_home: int
    failsafe_texts: list[str]


@pytest.fixture(scope="module")
def mavsdk_flight(flood_sitl: FloodSitl) -> Iterator[Flight]:
    """The flight is flown once; the protocol and the accuracy are judged by separate tests."""
    station = PymavlinkGcs(flood_sitl.gcs_port, heartbeats=False)  # a silent observer
    try:
        station.wait(lambda: station.seen.home is not None, 30, "telemetry")
        try:
            yield asyncio.run(_fly_20_waypoints(flood_sitl, station))
        finally:
            station.settle()
    finally:
        station.close()


async def _fly_20_waypoints(sim: FloodSitl, station: PymavlinkGcs) -> Flight:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission import MissionAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.mission import MissionItem as MavsdkItem
    from mavsdk.plugins.mission import MissionPlan

    mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    await mav.add_any_connection(sim.url)
    system = await mav.first_autopilot(30)
    assert system is not None
    try:
        tel, action, mission = TelemetryAsync(system), ActionAsync(system), MissionAsync(system)
        await _until(lambda: _armable(tel), 60, "armable")
        await action.arm()
        station.wait(lambda: station.seen.armed, 10, "armed")
        here = station.seen.position
        assert here is not None
        frame = LocalFrame(*here)  # the pattern starts where the boat is: the same corners every run
        # a survey: 20 m lines 8 m apart, right-angle corners, fly-through at 4 m/s
        points_ne = [(15.0 + 8.0 * (i // 2), (0.0 if i % 4 in (0, 3) else 20.0)) for i in range(20)]
        uploaded = [MavsdkItem(*frame.to_lat_lon(n, e), 0.0, 4.0, True, None, None, None, None, None,
                               ACCEPT_M) for n, e in points_ne]
        await mission.upload_mission(MissionPlan(uploaded))
        downloaded = (await mission.download_mission()).mission_items
        progress: list[tuple[int, int]] = []

        async def follow() -> None:
            async for p in mission.subscribe_mission_progress():
                progress.append((p.current, p.total))

        follower = asyncio.ensure_future(follow())
        start_s = station.seen.t_s
        await mission.start_mission()
        await _until(mission.is_mission_finished, 180, f"mission finished; progress {progress[-3:]}")
        finished = await mission.is_mission_finished()
        await _until(lambda: _true((20, 20) in progress), 10, f"progress 20/20; got {progress[-3:]}")
        follower.cancel()
        track_ne = _track_ne(station, frame, start_s)

        rtl_s = station.seen.t_s
        await action.return_to_launch()
        station.wait(lambda: "RTL: home reached, keeping station" in station.texts_since(rtl_s), 60, "home")
        home_s = station.seen.t_s
        station.wait(lambda: station.seen.t_s > home_s + 20.0, 30, "20 s at home")
        flight = Flight(uploaded, downloaded, points_ne, track_ne, progress, finished,
                        [m for t, m in station.seen.modes if t >= rtl_s], station.seen.mode,
                        [t for t in station.texts_since(start_s) if "failsafe" in t])
        await action.disarm()
        station.wait(lambda: not station.seen.armed, 10, "disarmed")
        return flight
    finally:
        mav.destroy()


def test_mavsdk_mission_plugin_round_trip_progress_finish_and_rtl_until_home(mavsdk_flight: Flight) -> None:
    f = mavsdk_flight
    assert len(f.downloaded) == 20
    for up, down in zip(f.uploaded, f.downloaded, strict=True):  # identical at MAVLink's 1e-7 degree
        assert _same(up.latitude_deg, down.latitude_deg, 0.6e-7)
        assert _same(up.longitude_deg, down.longitude_deg, 0.6e-7)
        for name in ("relative_altitude_m", "speed_m_s", "acceptance_radius_m", "yaw_deg", "loiter_time_s",
                     "gimbal_pitch_deg", "gimbal_yaw_deg"):
            assert _same(getattr(up, name), getattr(down, name)), name
        assert (up.is_fly_through, up.camera_action) == (down.is_fly_through, down.camera_action)
    assert f.finished and (20, 20) in f.progress
    currents = [c for c, _ in f.progress]
    assert {t for _, t in f.progress} == {20} and currents == sorted(currents) and currents[0] == 0
    assert f.rtl_modes and set(f.rtl_modes) == {MODE_RTL} and f.mode_at_home == MODE_RTL, f.rtl_modes
    assert not f.failsafe_texts


def test_mavsdk_mission_plugin_passes_every_waypoint_within_its_acceptance_radius(
        mavsdk_flight: Flight) -> None:
    misses = {i + 1: round(d, 2) for i, p in enumerate(mavsdk_flight.points_ne)
              if (d := min_distance_m(mavsdk_flight.track_ne, p)) > ACCEPT_M}
    assert not misses, f"waypoints passed farther than {ACCEPT_M} m: {misses}"


async def _armable(tel: Any) -> bool:
    h = await tel.health()
    return bool(h.is_armable and h.is_home_position_ok)


async def _true(value: bool) -> bool:
    return value


def _placeholder_plan(home: tuple[float, float], points: list[tuple[float, float]]) -> list[MissionItem]:
    """QGC for ArduPilot: the planned home (NAV_WAYPOINT, MAV_FRAME_GLOBAL, not current) at item 0."""
    items = [MissionItem(seq=0, frame=mi.FRAME_GLOBAL, command=mi.CMD_NAV_WAYPOINT, x=round(home[0] * 1e7),
                         y=round(home[1] * 1e7), z=15.0)]
    return items + [MissionItem(seq=i, frame=mi.FRAME_GLOBAL_RELATIVE_ALT, command=mi.CMD_NAV_WAYPOINT,
                                x=round(lat * 1e7), y=round(lon * 1e7), z=0.0)
                    for i, (lat, lon) in enumerate(points, start=1)]


FIRST_NE, SECOND_NE = (22.0, -12.0), (40.0, -12.0)


def _flew_first_waypoint(station: PymavlinkGcs, frame: LocalFrame, since_s: float) -> None:
    station.wait(lambda: 2 in station.seen.reached and station.seen.reached[2] >= since_s, 120,
                 "second waypoint reached")
    assert station.seen.reached.get(1, -1.0) >= since_s  # the first real waypoint, item 1
    track = _track_ne(station, frame, since_s)
    assert min_distance_m(track, FIRST_NE) <= WP_RADIUS_M + 1.0, "did not go to the first waypoint"


def test_qgc_home_placeholder_upload_flies_the_first_real_waypoint(
        flood_sitl: FloodSitl, gcs: PymavlinkGcs) -> None:
    home, here = gcs.seen.home, gcs.seen.position
    assert home is not None and here is not None
    frame = LocalFrame(*here)
    plan = _placeholder_plan(home, [frame.to_lat_lon(*FIRST_NE), frame.to_lat_lon(*SECOND_NE)])
    gcs.heartbeats = True  # QGC's 1 Hz heartbeat, connected for a while
    gcs.wait(lambda: gcs.last_heartbeat_t_s is not None, 5, "first heartbeat")
    start_s = gcs.seen.t_s
    assert gcs.upload(plan) == 0  # MAV_MISSION_ACCEPTED
    gcs.wait(lambda: "Mission received: 3 items (item 0 = home)" in gcs.texts_since(start_s), 10, "text")
    assert gcs.command(CMD_ARM_DISARM, 1) == 0
    assert gcs.set_mode(MODE_AUTO) == 0
    _flew_first_waypoint(gcs, frame, start_s)


def test_mavproxy_waypoints_file_flies_the_first_real_waypoint(
        flood_sitl: FloodSitl, gcs: PymavlinkGcs, tmp_path: Path) -> None:
    pytest.importorskip("MAVProxy", reason="MAVProxy is the optional 'mavproxy' extra")
    exe = Path(sys.executable).with_name("mavproxy.py")
    home, here = gcs.seen.home, gcs.seen.position
    assert home is not None and here is not None
    frame = LocalFrame(*here)
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{home[0]:.7f}\t{home[1]:.7f}\t12.000000\t1"]
    for seq, ne in enumerate((FIRST_NE, SECOND_NE), start=1):
        lat, lon = frame.to_lat_lon(*ne)
        lines.append(f"{seq}\t0\t3\t16\t0\t0\t0\t0\t{lat:.7f}\t{lon:.7f}\t0.000000\t1")
    (tmp_path / "mission.waypoints").write_text("\n".join(lines) + "\n", encoding="utf-8")
    command = str(exe) if exe.exists() else (shutil.which("mavproxy.py") or "mavproxy.py")
    proc = subprocess.Popen([command, f"--master=tcp:127.0.0.1:{flood_sitl.tcp_port}",
                             f"--state-basedir={tmp_path}"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, bufsize=1, env=flood_sitl.env, cwd=tmp_path)
    out: list[str] = []
    threading.Thread(target=lambda: out.extend(iter(proc.stdout.readline, "")), daemon=True).start()  # type: ignore[union-attr]

    def send(cmd: str, expect: str, timeout_s: float = 30.0) -> None:
        assert proc.stdin is not None
        mark = len(out)
        proc.stdin.write(cmd + "\n")
        proc.stdin.flush()
        gcs.wait(lambda: any(expect in line for line in out[mark:]), timeout_s,
                 f"MAVProxy {cmd!r}: {out[-5:]}")

    try:
        gcs.wait(lambda: any("online system 1" in line for line in out), 60, f"MAVProxy online: {out[-5:]}")
        start_s = gcs.seen.t_s
        send("wp load mission.waypoints", "Sent all 3 waypoints")
        gcs.wait(lambda: "Mission received: 3 items (item 0 = home)" in gcs.texts_since(start_s), 10, "text")
        send("arm throttle", "ARM_DISARM: ACCEPTED")
        send("mode AUTO", "Mode AUTO")
        _flew_first_waypoint(gcs, frame, start_s)
    finally:
        proc.kill()
        proc.wait(10)
