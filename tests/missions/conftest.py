"""One ``usv sitl --speedup 10`` in moving water for the SITL tests of this package (package scope).

The simulator runs with a current, wind and waves (:data:`FLOOD`), sends MAVLink to two UDP
ports (MAVSDK scripts and clients on one, an external pymavlink ground station on the other)
and serves TCP for MAVProxy.  Tests share it and run in file order; each leaves the boat
disarmed near home.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config
from tests.missions.pymavlink_gcs import PymavlinkGcs

SPEEDUP = 10.0
FLOOD = ("--current", "0.5,90", "--wind", "5,200", "--waves", "0.3", "--seed", "3")
"""A flood: 0.5 m/s current flowing east, 5 m/s wind from SSW, 0.3 m significant wave height."""


@dataclass(frozen=True)
class FloodSitl:
    mavsdk_port: int
    gcs_port: int
    tcp_port: int
    state_dir: Path
    work_dir: Path
    env: dict[str, str]

    @property
    def url(self) -> str:
        return f"udpin://0.0.0.0:{self.mavsdk_port}"


@pytest.fixture(scope="package")
def flood_sitl(tmp_path_factory: pytest.TempPathFactory) -> Iterator[FloodSitl]:
    root = tmp_path_factory.mktemp("flood")
    env = {**os.environ, "XDG_STATE_HOME": str(root / "xdg-state"), "PYTHONUNBUFFERED": "1"}
    mavsdk_port, gcs_port, tcp_port = free_port(), free_port(), free_port(kind=1)
    cfg = write_config(root / "sitl.toml", root / "state", [mavsdk_port, gcs_port], tcp_port=tcp_port)
    with sitl(cfg, env, speedup=SPEEDUP, extra_args=FLOOD):
        yield FloodSitl(mavsdk_port, gcs_port, tcp_port, root / "state", root, env)


@pytest.fixture
def gcs(flood_sitl: FloodSitl) -> Iterator[PymavlinkGcs]:
    """A silent observer on the second port; afterwards it brings the boat home and disarms it."""
    station = PymavlinkGcs(flood_sitl.gcs_port, heartbeats=False)
    station.wait(lambda: station.seen.position is not None and station.seen.home is not None, 30, "telemetry")
    yield station
    try:
        station.settle()
    finally:
        station.close()
