"""MAVProxy (the optional ``mavproxy`` extra) drives ``usv sitl`` over the TCP server.

It must see the vehicle, change modes (Rover mode names), arm, complete ``param fetch``
and ``wp list``, exactly as an operator types them.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = [pytest.mark.integration]


def mavproxy_exe() -> str:
    pytest.importorskip("MAVProxy", reason="MAVProxy is the optional 'mavproxy' extra")
    exe = Path(sys.executable).with_name("mavproxy.py")
    return str(exe) if exe.exists() else (shutil.which("mavproxy.py") or "mavproxy.py")


def test_mavproxy_modes_arm_params_waypoints(tmp_path: Path, usv_env: dict[str, str]) -> None:
    tcp_port = free_port(kind=1)  # SOCK_STREAM
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [free_port()], tcp_port=tcp_port)
    with sitl(cfg, usv_env):
        proc = subprocess.Popen([mavproxy_exe(), f"--master=tcp:127.0.0.1:{tcp_port}",
                                 f"--state-basedir={tmp_path / 'mavproxy'}"],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, bufsize=1, env=usv_env)
        lines: list[str] = []
        threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")),  # type: ignore[union-attr]
                         daemon=True).start()

        def expect(text: str, timeout_s: float = 15.0) -> None:
            deadline = time.monotonic() + timeout_s
            while not any(text in line for line in lines):
                assert time.monotonic() < deadline, f"MAVProxy never printed {text!r}:\n{''.join(lines)}"
                time.sleep(0.05)

        def send(cmd: str) -> None:
            assert proc.stdin is not None
            proc.stdin.write(cmd + "\n")
            proc.stdin.flush()

        try:
            expect("online system 1")
            expect("Mode HOLD")
            send("mode MANUAL")
            expect("DO_SET_MODE: ACCEPTED")
            expect("AP: Mode MANUAL")
            send("arm throttle")
            expect("COMPONENT_ARM_DISARM: ACCEPTED")
            expect("parameters", 20)  # MAVProxy's own fetch at connect ("Received N parameters")
            mark = len(lines)
            send("param fetch")
            expect("Requested parameter list")
            deadline = time.monotonic() + 15
            while not any("Received" in line and "parameters" in line for line in lines[mark:]):
                assert time.monotonic() < deadline, "".join(lines)
                time.sleep(0.05)
            send("wp list")
            expect("Saved 1 waypoints")
            send("mode HOLD")
            expect("AP: Mode HOLD")
        finally:
            proc.kill()
            proc.wait(10)
