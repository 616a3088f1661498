"""A real ``usv sitl`` behind a lossy radio (30 % of datagrams dropped each way, 5 % duplicated,
5 % reordered, 10-30 ms delay; :class:`benchmarks.lossy_link.LossyProxy`), driven by real clients
in their own processes: a pymavlink script (:mod:`benchmarks.lossy_gcs`) and a MAVSDK-Python
script (:mod:`benchmarks.lossy_mavsdk`), at the same time on two links.  Parameter sets, mission
and rally upload and download and commands complete; the rope launcher, fired until its ACK
arrives, fires exactly once.
The highest loss rate at which uploads still complete is measured by ``usv bench --only lossy_link``.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks.fuzz_target import free_port
from benchmarks.lossy_link import Impairment, LossyProxy
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = pytest.mark.integration

RADIO = Impairment(loss=0.3, duplicate=0.05, reorder=0.05, delay_s=0.01, jitter_s=0.02)


def start_client(module: str, port: int, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", module, "--port", str(port), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def result(proc: subprocess.Popen[str], timeout_s: float = 240.0) -> dict[str, object]:
    out, err = proc.communicate(timeout=timeout_s)
    lines = [line for line in out.splitlines() if line.startswith("{")]
    assert lines, f"{proc.args} printed no result:\n{out}\n{err[-3000:]}"
    return dict(json.loads(lines[-1]))


def test_clients_complete_their_work_over_a_30_percent_lossy_link(tmp_path: Path,
                                                                  usv_env: dict[str, str]) -> None:
    pym_vehicle, pym_client = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM)
    sdk_vehicle, sdk_client = free_port(socket.SOCK_DGRAM), free_port(socket.SOCK_DGRAM)
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [pym_vehicle, sdk_vehicle])
    with (LossyProxy(pym_vehicle, pym_client, RADIO, seed=11) as pym_radio,
          LossyProxy(sdk_vehicle, sdk_client, RADIO, seed=12) as sdk_radio, sitl(cfg, usv_env)):
        # at once, on their own links: pymavlink sets 3 parameters, uploads and downloads the
        # mission and fires the launcher; MAVSDK sets 2 others and uploads/downloads rally points
        pym_proc = start_client("benchmarks.lossy_gcs", pym_client, "--items", "8", "--params", "3",
                                "--fire", "--retry", "0.3")
        sdk_proc = start_client("benchmarks.lossy_mavsdk", sdk_client, "--items", "4", "--plan", "rally",
                                "--no-arm")
        pym, sdk = result(pym_proc), result(sdk_proc)
    assert pym["ok"], json.dumps(pym)  # a string: pytest does not shorten it
    fire = pym["fire"]
    assert isinstance(fire, dict)
    assert fire["fire_result"] == 0  # ACCEPTED, also when the first ACK was lost and FIRE was resent
    assert fire["shots_after"] == fire["shots_before"] - 1  # fired exactly once
    assert sdk["ok"], json.dumps(sdk)
    for radio in (pym_radio, sdk_radio):  # the link really was lossy in both directions
        stats = radio.stats
        assert stats.to_client.dropped > 0.2 * stats.to_client.datagrams
        assert stats.to_vehicle.dropped > 0
