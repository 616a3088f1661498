"""Replay of QGroundControl's connect sequence (from its source) against ``usv sitl``.

QGC cannot be installed here, so this client (pymavlink) performs what QGC does after the
first HEARTBEAT (``Vehicle``, ``InitialConnectStateMachine``, ``ParameterManager``,
``MissionManager``): request AUTOPILOT_VERSION (REQUEST_MESSAGE 148, then the legacy
REQUEST_AUTOPILOT_CAPABILITIES 520), PROTOCOL_VERSION (300), COMPONENT_INFORMATION /
COMPONENT_METADATA (395/397); try the parameter download over MAVLink FTP
(``@PARAM/param.pck``) and fall back to PARAM_REQUEST_LIST on the NAK; download mission,
fence and rally; request HOME_POSITION; set stream rates.  Every step must finish without a
timeout or a retry (QGC's own timeouts run on the wall clock; so do the step deadlines here).
The stream rate is checked in the vehicle's time stamps (``time_boot_ms``, simulation clock).
"""

from __future__ import annotations

import os
import struct
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil

from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = [pytest.mark.integration]

STEP_TIMEOUT_S = 5.0


class Qgc:
    """The connect sequence, step by step, each with a deadline."""

    def __init__(self, port: int) -> None:
        self._saved = (os.environ.get("MAVLINK20"), mavutil.current_dialect)
        os.environ["MAVLINK20"] = "1"  # QGC speaks MAVLink 2 (mission_type is a v2 extension field)
        mavutil.set_dialect("all")
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255,
                                               source_component=190, dialect="all")
        self.mav: Any = self.conn.mav
        self.steps: list[tuple[str, float]] = []
        self._stop = threading.Event()

    def heartbeats(self) -> None:
        while not self._stop.wait(1.0):
            self.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID,
                                    0, 0, 0)

    def recv(self, types: str | list[str], cond: Any = None, timeout_s: float = STEP_TIMEOUT_S) -> Any:
        deadline = time.monotonic() + timeout_s
        wanted = [types] if isinstance(types, str) else types
        seen: list[str] = []
        while time.monotonic() < deadline:
            msg = self.conn.recv_match(blocking=True, timeout=deadline - time.monotonic())
            if msg is None:
                continue
            seen.append(msg.get_type())
            if msg.get_type() in wanted and (cond is None or cond(msg)):
                return msg
        raise AssertionError(f"timed out waiting for {types}; received {sorted(set(seen))}")

    def command(self, cmd: int, *params: float) -> Any:
        p = list(params) + [0.0] * (7 - len(params))
        self.mav.command_long_send(1, 1, cmd, 0, *p)
        return self.recv("COMMAND_ACK", lambda m: m.command == cmd)

    def close(self) -> None:
        self._stop.set()
        self.conn.close()
        env, dialect = self._saved
        if env is None:
            os.environ.pop("MAVLINK20", None)
        else:
            os.environ["MAVLINK20"] = env
        mavutil.set_dialect(dialect)

    def step(self, name: str, started: float) -> None:
        self.steps.append((name, time.monotonic() - started))


def ftp_open_param_pck() -> list[int]:
    path = b"@PARAM/param.pck"
    header = struct.pack("<HBBBBBBI", 1, 0, 4, len(path), 0, 0, 0, 0)  # seq 1, OpenFileRO
    return list((header + path).ljust(251, b"\0"))


def test_qgc_connect_sequence(tmp_path: Path, usv_env: dict[str, str]) -> None:
    port = free_port()
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [port])
    with sitl(cfg, usv_env):
        q = Qgc(port)
        hb_thread = threading.Thread(target=q.heartbeats, daemon=True)
        try:
            t = time.monotonic()
            hb = q.recv("HEARTBEAT", timeout_s=15)
            assert hb.autopilot == mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA and hb.type == 11
            q.conn.target_system = 1
            hb_thread.start()
            q.step("heartbeat", t)

            t = time.monotonic()
            assert q.command(mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE,
                             mavutil.mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION).result == 0
            ver = q.recv("AUTOPILOT_VERSION")
            assert ver.capabilities & mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
            assert q.command(mavutil.mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1).result == 0
            q.recv("AUTOPILOT_VERSION")
            q.step("autopilot_version", t)

            t = time.monotonic()
            # PROTOCOL_VERSION, COMPONENT_INFORMATION/METADATA (not in pymavlink's set): clean NACK
            for msg_id in (300, 395, 397):
                ack = q.command(mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE, msg_id)
                assert ack.result == mavutil.mavlink.MAV_RESULT_UNSUPPORTED
            q.step("protocol_version+component_metadata", t)

            t = time.monotonic()
            q.mav.file_transfer_protocol_send(0, 1, 1, ftp_open_param_pck())
            reply = q.recv("FILE_TRANSFER_PROTOCOL")
            payload = bytes(reply.payload)
            assert payload[3] == 129 and payload[5] == 4  # NAK of OpenFileRO -> fall back
            q.mav.param_request_list_send(1, 1)
            first = q.recv("PARAM_VALUE")
            seen = {first.param_index}
            while len(seen) < first.param_count:
                seen.add(q.recv("PARAM_VALUE").param_index)
            q.step(f"parameters ({first.param_count}, FTP NAK then list)", t)

            for mission_type in (0, 1, 2):
                t = time.monotonic()
                q.mav.mission_request_list_send(1, 1, mission_type)
                count = q.recv("MISSION_COUNT", lambda m, mt=mission_type: m.mission_type == mt).count
                for seq in range(count):
                    q.mav.mission_request_int_send(1, 1, seq, mission_type)
                    q.recv("MISSION_ITEM_INT", lambda m, s=seq: m.seq == s)
                q.mav.mission_ack_send(1, 1, 0, mission_type)
                q.step(f"mission type {mission_type} ({count} items)", t)

            t = time.monotonic()
            assert q.command(mavutil.mavlink.MAV_CMD_GET_HOME_POSITION).result == 0
            home = q.recv("HOME_POSITION")
            assert home.latitude != 0
            assert q.command(mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE,
                             mavutil.mavlink.MAVLINK_MSG_ID_HOME_POSITION).result == 0
            q.step("home_position", t)

            t = time.monotonic()
            q.mav.request_data_stream_send(1, 1, mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)
            assert q.command(mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                             mavutil.mavlink.MAVLINK_MSG_ID_ATTITUDE, 100_000).result == 0
            first_ms = q.recv("ATTITUDE").time_boot_ms
            stamps = [first_ms]
            while stamps[-1] < first_ms + 1000:
                stamps.append(q.recv("ATTITUDE").time_boot_ms)
            assert 9 <= sum(s < first_ms + 1000 for s in stamps) <= 11  # 10 Hz in vehicle time
            q.step("stream rates", t)
        finally:
            q.close()
    assert all(d < STEP_TIMEOUT_S for _, d in q.steps), q.steps
