"""One instance per state directory, and honest ready banners (two real ``usv sitl`` processes)."""

from __future__ import annotations

import socket
import subprocess
from pathlib import Path

import pytest

from companion.statelock import StateDirBusy, StateDirLock
from tests.conftest import usv_command
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = pytest.mark.integration


def test_second_sitl_on_same_state_dir_exits_2_naming_dir_and_pid(tmp_path: Path,
                                                                   usv_env: dict[str, str]) -> None:
    state = tmp_path / "state"
    first_cfg = write_config(tmp_path / "first.toml", state, [free_port()], free_port())
    second_cfg = write_config(tmp_path / "second.toml", state, [free_port()], free_port())
    with sitl(first_cfg, usv_env) as first:
        second = subprocess.run([*usv_command(), "sitl", "-c", str(second_cfg)], capture_output=True,
                                text=True, env=usv_env, timeout=60)
        assert first.poll() is None, "the first instance must keep running"
    assert second.returncode == 2, second
    lines = second.stderr.strip().splitlines()
    assert len(lines) == 1, second.stderr
    assert str(state) in lines[0] and f"PID {first.pid}" in lines[0], lines[0]
    assert "ready" not in second.stdout
    # The first instance is gone: the same directory can be used again (a stale lock file is harmless).
    assert (state / "usv.lock").exists()
    with StateDirLock(state):
        pass


def test_lock_is_exclusive_and_released(tmp_path: Path) -> None:
    with StateDirLock(tmp_path) as held:
        with pytest.raises(StateDirBusy) as busy:
            StateDirLock(tmp_path).acquire()
        assert busy.value.pid is not None and str(tmp_path) in str(busy.value)
        assert held.path.read_text().strip().isdigit()
    with StateDirLock(tmp_path):
        pass


def test_port_that_cannot_be_bound_is_not_announced(tmp_path: Path, usv_env: dict[str, str]) -> None:
    with socket.socket() as squatter:
        squatter.bind(("127.0.0.1", 0))
        squatter.listen()
        port = squatter.getsockname()[1]
        cfg = write_config(tmp_path / "c.toml", tmp_path / "state", [free_port()], port)
        cfg.write_text(cfg.read_text() + f'serial = ["{tmp_path}/no-such-radio:57600"]\n')
        log = tmp_path / "sitl.log"
        with sitl(cfg, usv_env, log=log):
            pass
    text = log.read_text(errors="replace")
    banner = text[text.index("ready"):]
    assert f"MAVLink TCP server 127.0.0.1:{port} NOT AVAILABLE (cannot bind" in banner, banner
    assert f"mavproxy.py --master=tcp:127.0.0.1:{port}" not in text
    assert "cannot bind" in text[:text.index("ready")]  # logged when it happened too
    assert f"MAVLink serial {tmp_path}/no-such-radio:57600 NOT OPEN" in banner
