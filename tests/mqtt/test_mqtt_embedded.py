"""``usv sitl --mqtt-embedded PORT``: the boat brings its own broker; a separate subscriber sees
the retained state, and the process still stops by itself (``--duration``) with status 0 --
stopping must never hang on the MQTT client or the broker."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT, usv_command

from .test_mqtt_sitl import _free_port

pytestmark = pytest.mark.integration


def test_embedded_broker_serves_the_boats_topics_and_the_run_ends_cleanly(tmp_path: Path) -> None:
    port = _free_port()
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "XDG_STATE_HOME": str(tmp_path / "xdg")}
    log = tmp_path / "sitl.log"
    with open(log, "wb") as out:
        boat = subprocess.Popen([*usv_command(), "sitl", "--speedup", "10", "--duration", "30",
                                 "--mqtt-embedded", str(port)], stdout=out, stderr=subprocess.STDOUT, env=env)
    received = tmp_path / "dashboard.jsonl"
    dashboard = subprocess.Popen([sys.executable, "-m", "tests.mqtt.subscriber", str(port), str(received)],
                                 cwd=REPO_ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        topics: set[str] = set()
        while not {"usv/usv1/status", "usv/usv1/position", "usv/usv1/online"} <= topics:
            assert boat.poll() is None and time.monotonic() < deadline, log.read_text(errors="replace")
            time.sleep(0.2)
            if received.exists():
                topics = {json.loads(line).get("topic", "") for line in received.read_text().splitlines()
                          if line.endswith("}")}
        assert boat.wait(60) == 0, log.read_text(errors="replace")  # 30 simulated seconds, then a clean stop
    finally:
        dashboard.terminate()
        dashboard.wait(10)
        if boat.poll() is None:
            boat.kill()
            boat.wait(10)
