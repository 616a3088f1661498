"""MAVLink 2 signing end to end: ``usv sitl --signing-key`` with ``require_signing`` and pymavlink
ground stations on its TCP port (real processes, wall-clock SITL).

The signed station commands the boat (arm, parameter set, mission upload); an unsigned station,
a station with the wrong key, a replayed signed frame (on the same and on a new connection) and a
signed station outside ``gcs_sysids`` change nothing: not the arm state, not a parameter, not the
mission.  Telemetry reaches every station; the vehicle's own frames are signed.
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from companion.link.dialect import mav
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config
from tests.security.station import Station

pytestmark = pytest.mark.integration

KEY = bytes(range(1, 33))
WRONG_KEY = bytes(range(101, 133))
ARM_DISARM = mav.MAV_CMD_COMPONENT_ARM_DISARM
PLAN_A = [(41.7700, 123.4300), (41.7710, 123.4300), (41.7710, 123.4315)]
PLAN_B = [(41.7700, 123.4300), (41.7690, 123.4290), (41.7685, 123.4310), (41.7695, 123.4320)]
QUIET_S = 3.0
"""How long a refused request is given to (not) take effect."""


@pytest.fixture(scope="module")
def vehicle(tmp_path_factory: pytest.TempPathFactory) -> Iterator[int]:
    """A ``usv sitl`` requiring signatures, allowing ground-station systems 255 and 250; its TCP port."""
    tmp = tmp_path_factory.mktemp("signing")
    key_file = tmp / "usv.key"
    key_file.write_text(KEY.hex() + "\n")
    os.chmod(key_file, 0o600)
    port = free_port()
    cfg = write_config(tmp / "sitl.toml", tmp / "state", [free_port()], port)
    cfg.write_text(cfg.read_text() + "[security]\nrequire_signing = true\ngcs_sysids = [255, 250]\n")
    env = dict(os.environ, XDG_STATE_HOME=str(tmp / "xdg"), PYTHONUNBUFFERED="1")
    with sitl(cfg, env, extra_args=["--signing-key", str(key_file)], log=tmp / "sitl.log"):
        yield port


@pytest.fixture
def signed(vehicle: int) -> Iterator[Station]:
    with Station(vehicle, key=KEY) as station:
        yield station


def arm(station: Station, value: int) -> None:
    """Arm (1) or disarm (0) as the signed station; retried while the vehicle is still starting."""
    for _ in range(20):
        since = station.mark()
        station.command(ARM_DISARM, value)
        ack = station.wait("COMMAND_ACK", lambda m: m.command == ARM_DISARM, since=since, timeout_s=3.0)
        if ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED:
            return
        time.sleep(0.5)
    raise AssertionError(f"arm={value} not accepted")


def set_param(station: Station, name: str, value: float) -> None:
    since = station.mark()
    station.param_set(name, value)
    pv = station.wait("PARAM_VALUE", lambda m: m.param_id == name, since=since, timeout_s=5.0)
    assert pv is not None and pv.param_value == pytest.approx(value), pv


def known_state(signed: Station) -> None:
    """Armed, LOIT_RADIUS 12, plan A: set by the signed station (the positive control)."""
    arm(signed, 1)
    set_param(signed, "LOIT_RADIUS", 12.0)
    assert signed.upload(PLAN_A) == mav.MAV_MISSION_ACCEPTED
    assert_state(signed)


def assert_state(signed: Station) -> None:
    assert signed.armed()
    assert signed.param("LOIT_RADIUS") == pytest.approx(12.0)
    assert signed.download()[1:] == PLAN_A[1:]


def attack(station: Station) -> None:
    """Everything an intruder would try: disarm, a parameter, a new mission, a mission clear."""
    station.command(ARM_DISARM, 0, 21196)  # 21196: forced disarm
    station.param_set("LOIT_RADIUS", 7.0)
    station.send(station.mav.mission_count_encode(1, 1, len(PLAN_B), 0))
    station.send(station.mav.mission_clear_all_encode(1, 1, 0))
    station.send(station.mav.manual_control_encode(1, 1000, 0, 1000, 0, 0))
    time.sleep(QUIET_S)


def test_signed_station_commands_the_boat_and_telemetry_is_signed(signed: Station) -> None:
    known_state(signed)
    hb = signed.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1)
    assert hb is not None and hb.get_signed()
    set_param(signed, "LOIT_RADIUS", 15.0)
    assert signed.param("LOIT_RADIUS") == pytest.approx(15.0)
    assert signed.upload(PLAN_B) == mav.MAV_MISSION_ACCEPTED
    assert signed.download()[1:] == PLAN_B[1:]
    arm(signed, 0)
    assert not signed.armed()


@pytest.mark.parametrize(("key", "system_id"), [(None, 255), (WRONG_KEY, 250)], ids=["unsigned", "wrong-key"])
def test_unauthenticated_station_changes_nothing(vehicle: int, signed: Station, key: bytes | None,
                                                 system_id: int) -> None:
    """(The stations are allowed system ids: the signature alone keeps them out.  The drop report is
    rate-limited per sending system, hence two ids.)"""
    known_state(signed)
    with Station(vehicle, key=key, system_id=system_id) as intruder:
        if key is None:  # telemetry flows to a listener without a key (it ignores the signatures)
            assert intruder.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1) is not None
        else:  # it arrives at the wrong-key station too, which rightly rejects its signatures
            time.sleep(2.0)
            assert intruder.mav.signing.badsig_count > 0
        since, seen_since = intruder.mark(), signed.mark()
        attack(intruder)
        assert intruder.messages("COMMAND_ACK", since) == []  # dropped, as the signing spec says
        assert intruder.messages("MISSION_REQUEST_INT", since) == []
        assert intruder.messages("MISSION_ACK", since) == []
        texts = [m.text for m in signed.messages("STATUSTEXT", seen_since)]
        assert any("Signing: dropped" in t for t in texts), texts  # the operator is told
        if key is None:
            assert intruder.param("LOIT_RADIUS") == pytest.approx(12.0)  # reading stays open
    assert_state(signed)


def test_replayed_signed_frames_change_nothing(vehicle: int, signed: Station) -> None:
    known_state(signed)
    since = signed.mark()
    disarm_frame = signed.command(ARM_DISARM, 0)
    assert signed.wait("COMMAND_ACK", lambda m: m.command == ARM_DISARM and m.result == 0, since=since)
    param_frame = signed.param_set("LOIT_RADIUS", 7.0)
    assert signed.wait("PARAM_VALUE", lambda m: m.param_id == "LOIT_RADIUS" and m.param_value == 7.0)
    since = signed.mark()
    clear_frame = signed.send(signed.mav.mission_clear_all_encode(1, 1, 0))
    assert signed.wait("MISSION_ACK", since=since) is not None
    assert signed.download()[1:] == []
    known_state(signed)  # armed, 12, plan A again
    since = signed.mark()
    for frame in (disarm_frame, param_frame, clear_frame):
        signed.write(frame)  # the same connection
    with socket.create_connection(("127.0.0.1", vehicle)) as other:  # a new connection (a new link)
        for frame in (disarm_frame, param_frame, clear_frame):
            other.sendall(frame)
        time.sleep(QUIET_S)
    assert signed.messages("COMMAND_ACK", since) == []
    assert signed.messages("MISSION_ACK", since) == []
    assert_state(signed)


def test_signed_station_outside_gcs_sysids_is_denied_with_reason(vehicle: int, signed: Station) -> None:
    known_state(signed)
    with Station(vehicle, key=KEY, system_id=42, link_id=3) as stranger:
        since = stranger.mark()
        stranger.command(ARM_DISARM, 0)
        ack = stranger.wait("COMMAND_ACK", lambda m: m.command == ARM_DISARM, since=since)
        assert ack is not None and ack.result == mav.MAV_RESULT_DENIED
        text = stranger.wait("STATUSTEXT", lambda m: "gcs_sysids" in m.text, since=since)
        assert text is not None and "sys 42 not in gcs_sysids" in text.text
        since = stranger.mark()
        stranger.send(stranger.mav.mission_count_encode(1, 1, len(PLAN_B), 0))
        mack = stranger.wait("MISSION_ACK", since=since)
        assert mack is not None and mack.type == mav.MAV_MISSION_DENIED
        since = stranger.mark()
        stranger.param_set("LOIT_RADIUS", 7.0)
        pv = stranger.wait("PARAM_VALUE", lambda m: m.param_id == "LOIT_RADIUS", since=since)
        assert pv is not None and pv.param_value == pytest.approx(12.0)  # the unchanged value, as refused
        time.sleep(QUIET_S)
    assert_state(signed)


def test_key_file_readable_by_others_is_refused(tmp_path: Path, usv_env: dict[str, str]) -> None:
    import subprocess

    from tests.conftest import usv_command

    key_file = tmp_path / "k.key"
    key_file.write_text(KEY.hex())
    os.chmod(key_file, 0o644)
    proc = subprocess.run([*usv_command(), "sitl", "--state-dir", str(tmp_path / "s"), "--signing-key",
                           str(key_file), "--duration", "1"], capture_output=True, text=True, env=usv_env,
                          timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "chmod 600" in proc.stderr and "0644" in proc.stderr
