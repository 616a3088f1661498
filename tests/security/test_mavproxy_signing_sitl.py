"""MAVProxy against ``usv sitl`` requiring signatures: refused until it has the key, obeyed after.

MAVProxy's ``signing key PASSPHRASE`` signs with the SHA-256 of the passphrase, so the vehicle's
key file holds that digest in hex (as the README shows).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import threading
import time
from pathlib import Path

import pytest

from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config
from tests.mavlink.test_mavproxy_sitl import mavproxy_exe

pytestmark = [pytest.mark.integration]

PASSPHRASE = "rescue-boat-2026"


def test_mavproxy_arms_only_with_the_key(tmp_path: Path, usv_env: dict[str, str]) -> None:
    exe = mavproxy_exe()
    key_file = tmp_path / "usv.key"
    key_file.write_text(hashlib.sha256(PASSPHRASE.encode("ascii")).hexdigest() + "\n")
    os.chmod(key_file, 0o600)
    tcp_port = free_port(kind=1)
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [free_port()], tcp_port=tcp_port)
    cfg.write_text(cfg.read_text() + "[security]\nrequire_signing = true\n")
    with sitl(cfg, usv_env, extra_args=["--signing-key", str(key_file)]):
        proc = subprocess.Popen([exe, f"--master=tcp:127.0.0.1:{tcp_port}", "--mav20",
                                 f"--state-basedir={tmp_path / 'mavproxy'}"],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, bufsize=1, env=usv_env)
        lines: list[str] = []
        threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")),  # type: ignore[union-attr]
                         daemon=True).start()

        def expect(text: str, since: int = 0, timeout_s: float = 15.0) -> None:
            deadline = time.monotonic() + timeout_s
            while not any(text in line for line in lines[since:]):
                assert time.monotonic() < deadline, f"MAVProxy never printed {text!r}:\n{''.join(lines)}"
                time.sleep(0.05)

        def send(cmd: str) -> int:
            assert proc.stdin is not None
            mark = len(lines)
            proc.stdin.write(cmd + "\n")
            proc.stdin.flush()
            return mark

        try:
            expect("online system 1")  # telemetry reaches a station without the key
            mark = send("arm throttle")
            expect("Signing: dropped COMMAND_LONG", mark)
            time.sleep(2.0)
            assert not any("ARM_DISARM: ACCEPTED" in line for line in lines[mark:]), "".join(lines[mark:])
            send("module load signing")
            time.sleep(1.0)
            send(f"signing key {PASSPHRASE}")
            time.sleep(1.0)
            mark = send("arm throttle")
            expect("COMPONENT_ARM_DISARM: ACCEPTED", mark)
        finally:
            proc.kill()
            proc.wait(10)
