"""Bounded telemetry logs: no file for a silent connection, rotation, total size and count caps."""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import all as mavlink2

from companion.link.tlog import TlogDirectory
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config

MAX_FILES = 20
MAX_MB = 1.0
FILE_MB = 0.1


def gcs_frames(codec: mavlink2.MAVLink, *msgs: mavlink2.MAVLink_message) -> bytes:
    out = b""
    for msg in msgs:
        out += bytes(msg.pack(codec))
        codec.seq = (codec.seq + 1) % 256
    return out


@pytest.mark.integration
def test_200_quick_tcp_connections_leave_no_pile_and_the_cap_holds(tmp_path: Path) -> None:
    port = free_port()
    state = tmp_path / "state"
    cfg = write_config(tmp_path / "sitl.toml", state, [free_port()], port)
    cfg.write_text(cfg.read_text() + f"tlog_max_files = {MAX_FILES}\n[params]\nUSV_TLOG_MAX_MB = {MAX_MB}\n"
                   f"USV_TLOG_FILE_MB = {FILE_MB}\n")
    env = dict(os.environ, XDG_STATE_HOME=str(tmp_path / "xdg"), PYTHONUNBUFFERED="1")
    codec = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
    heartbeat = codec.heartbeat_encode(6, 8, 0, 0, 0)
    with sitl(cfg, env, log=tmp_path / "sitl.log"):
        # a ground station that talks a lot: its log is rotated into parts
        with socket.create_connection(("127.0.0.1", port)) as talker:
            talker.settimeout(0.05)
            talker_port = talker.getsockname()[1]
            deadline = time.monotonic() + 60.0
            while not list((state / "logs").glob("*-part2.tlog")) and time.monotonic() < deadline:
                talker.sendall(gcs_frames(codec, heartbeat, codec.param_request_list_encode(1, 1)))
                end = time.monotonic() + 0.3  # let the parameter list go out before asking again
                while time.monotonic() < end:
                    with contextlib.suppress(TimeoutError):
                        talker.recv(65536)
        time.sleep(1.0)
        parts = sorted((state / "logs").glob("*-part*.tlog"))
        assert parts, "the talking station's log was not rotated"
        assert all(p.stat().st_size <= FILE_MB * 1e6 + 300 for p in parts)  # a part ends past the size
        # the session's first file holds the parameter list; a rotated part starts on a whole frame
        # (part 2 may hold only the few frames sent after the rotation, before the station hung up)
        first = sorted((state / "logs").glob(f"*_{talker_port}.tlog"))
        assert first, "the talking station's first log file is gone"
        dump = subprocess.run([sys.executable, "-m", "pymavlink.tools.mavlogdump", "--types", "PARAM_VALUE",
                               str(first[0])], capture_output=True, text=True, timeout=60)
        assert dump.returncode == 0 and "PARAM_VALUE" in dump.stdout
        dump = subprocess.run([sys.executable, "-m", "pymavlink.tools.mavlogdump", str(parts[0])],
                              capture_output=True, text=True, timeout=60)
        assert dump.returncode == 0 and dump.stdout.strip(), f"{parts[0].name} does not parse"
        # 200 quick connections: silent, cut mid-frame, or one heartbeat and gone
        for i in range(200):
            with socket.create_connection(("127.0.0.1", port)) as quick:
                if i % 3 == 1:
                    quick.sendall(gcs_frames(codec, heartbeat)[:7])
                elif i % 3 == 2:
                    quick.sendall(gcs_frames(codec, heartbeat))
        time.sleep(3.0)  # the vehicle notices the closed connections and enforces the caps
    logs = sorted((state / "logs").glob("*.tlog"))
    sizes = [p.stat().st_size for p in logs]
    assert 0 < len(logs) <= MAX_FILES, [p.name for p in logs]
    assert sum(sizes) <= MAX_MB * 1e6 + FILE_MB * 1e6, sizes  # closed files within the cap (+ one open part)
    assert all(size > 0 for size in sizes)
    assert not any("udp" in p.name for p in logs), "a link nobody answered on must leave no log"
    assert len(logs) < 200 // 3  # the 67 one-heartbeat connections did not all stay
    session = [p for p in logs if f"_{talker_port}" in p.name and p.stat().st_size >= 16_000]
    assert session, "the flood pushed out the real session's log"
    print(f"\n200 quick TCP connections: {len(logs)} .tlog files, {sum(sizes)} bytes kept")


def test_directory_caps_by_size_and_count_and_keeps_open_files(tmp_path: Path) -> None:
    d = TlogDirectory(tmp_path, max_total_bytes=lambda: 10_000, file_bytes=lambda: 4_000, max_files=5)
    silent = d.writer("silent")
    for _ in range(100):
        silent.write(time.time(), b"x" * 40)  # the vehicle talking to nobody
    silent.close()
    assert list(tmp_path.iterdir()) == []
    live = d.writer("live")
    live.write(time.time(), b"\xfd" + b"y" * 99, received=True)
    for _ in range(200):
        live.write(time.time(), b"z" * 100)  # 21.6 kB: six parts of 4 kB
    files = sorted(tmp_path.glob("*.tlog"))
    assert len(files) <= 5 and sum(p.stat().st_size for p in files) <= 10_000 + 4_000
    assert live.is_open and live.path.exists() and live.part >= 5
    for _ in range(10):
        w = d.writer(f"c{_}")
        w.write(time.time(), b"hb", received=True)
        w.close()
    assert len(list(tmp_path.glob("*.tlog"))) <= 5 and live.path.exists()


def test_many_open_connections_do_not_push_out_a_real_sessions_log(tmp_path: Path) -> None:
    d = TlogDirectory(tmp_path, max_total_bytes=lambda: 1e6, file_bytes=lambda: 1e5, max_files=5)
    session = d.writer("session")
    session.write(time.time(), b"s" * 100, received=True)
    for _ in range(500):
        session.write(time.time(), b"t" * 100)  # 50 kB: a real conversation
    session.close()
    flood = [d.writer(f"flood{i}") for i in range(30)]
    for w in flood:
        w.write(time.time(), b"hb", received=True)  # 30 connections open at once
    for w in flood:
        w.close()
    names = {p.name for p in tmp_path.glob("*.tlog")}
    assert "session.tlog" in names and len(names) <= 5
