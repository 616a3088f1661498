"""The real vehicle killed with SIGKILL during parameter sets and mission uploads, then restarted.

``usv sitl`` runs as a subprocess; a pymavlink station sets parameters (acknowledged by the
PARAM_VALUE the vehicle sends after saving) and uploads missions (MISSION_ACK after saving) as
fast as it can while the process is killed at a random moment.  After every restart on the same
state directory (the state-directory lock of the killed process is gone with it) the station
reads back every parameter and the mission: each holds its last acknowledged value or a value
sent after it whose acknowledgement the kill cut off, never a corrupt or older one.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from companion.link.dialect import mav
from tests.conftest import usv_command
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import write_config
from tests.security.station import Station

pytestmark = pytest.mark.integration

KILL_POINTS = 5
NAMES = ("LOIT_RADIUS", "WP_RADIUS")


def start(cfg: Path, env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
    out = open(log, "ab")  # noqa: SIM115 - the child keeps it; closed when the test's process ends
    proc = subprocess.Popen([*usv_command(), "sitl", "-c", str(cfg), "--realtime"], stdout=out,
                            stderr=subprocess.STDOUT, env=env)
    deadline = time.monotonic() + 60
    while log.read_bytes().count(b" ready") < start.count + 1:  # type: ignore[attr-defined]
        assert proc.poll() is None and time.monotonic() < deadline, log.read_text(errors="replace")
        time.sleep(0.1)
    start.count += 1  # type: ignore[attr-defined]
    return proc


DEAD_GRACE_S = 0.5
"""After the vehicle process has died, how long an answer it sent before dying may still take to be
read from the TCP socket (loopback: milliseconds; the station's reader polls every 0.2 s)."""


def dead_for_a_while(proc: subprocess.Popen[bytes]) -> Callable[[], bool]:
    """True once ``proc`` has been dead for :data:`DEAD_GRACE_S`: nothing more can be answered, so
    waiting out the station's 2 s timeouts after the kill is only wall time."""
    died_at: list[float] = []

    def check() -> bool:
        if proc.poll() is None:
            return False
        if not died_at:
            died_at.append(time.monotonic())
        return time.monotonic() - died_at[0] > DEAD_GRACE_S

    return check


def test_sigkill_during_param_sets_and_uploads_loses_nothing_acknowledged(tmp_path: Path) -> None:
    start.count = 0  # type: ignore[attr-defined]
    port = free_port()
    cfg = write_config(tmp_path / "sitl.toml", tmp_path / "state", [free_port()], port)
    env = dict(os.environ, XDG_STATE_HOME=str(tmp_path / "xdg"), PYTHONUNBUFFERED="1")
    log = tmp_path / "sitl.log"
    rng = random.Random(7)
    acked: dict[str, float] = {}
    later: dict[str, list[float]] = {name: [] for name in NAMES}
    """Values sent after the last acknowledged one, unacknowledged: the kill may have cut their answer."""
    acked_plan: list[tuple[float, float]] | None = None
    later_plans: list[list[tuple[float, float]]] = []
    n, in_flight_seen = 0, 0
    for kill_point in range(KILL_POINTS + 1):
        proc = start(cfg, env, log)  # on the state directory of the process just killed
        try:
            with Station(port) as gcs:
                for name, value in acked.items():  # every acknowledged write survived
                    found = gcs.param(name)
                    if abs(found - value) > 1e-4:
                        assert any(abs(found - v) < 1e-4 for v in later[name]), (kill_point, name, found)
                        in_flight_seen += 1
                        acked[name] = found
                    later[name] = []
                if acked_plan is not None:
                    plan_found = gcs.download()[1:]
                    if plan_found != acked_plan[1:]:
                        assert any(plan_found == p[1:] for p in later_plans), (kill_point, plan_found)
                        in_flight_seen += 1
                        acked_plan = [acked_plan[0], *plan_found]
                    later_plans = []
                if kill_point == KILL_POINTS:
                    break
                killer = threading.Timer(rng.uniform(0.3, 2.0), lambda p=proc: p.send_signal(signal.SIGKILL))
                killer.start()
                gone = dead_for_a_while(proc)
                while proc.poll() is None:
                    n += 1
                    name, value = NAMES[n % 2], 1.0 + (n % 400) * 0.1
                    since = gcs.mark()
                    gcs.param_set(name, value)
                    if gcs.wait("PARAM_VALUE", lambda m, nm=name, v=value: m.param_id == nm
                                and abs(m.param_value - v) < 1e-4, since=since, timeout_s=2.0, give_up=gone):
                        acked[name], later[name] = value, []
                    else:
                        later[name].append(value)
                    if n % 5 == 0 and proc.poll() is None:
                        plan = [(41.77, 123.43)] + [(round(41.77 + n * 1e-6, 6), round(123.43 + i * 1e-5, 6))
                                                    for i in range(3)]
                        if gcs.upload(plan, timeout_s=2.0, give_up=gone) == mav.MAV_MISSION_ACCEPTED:
                            acked_plan, later_plans = plan, []
                        else:
                            later_plans.append(plan)
                killer.join()
        finally:
            if proc.poll() is None:
                proc.kill()
            proc.wait(10)
        assert proc.returncode == -signal.SIGKILL or kill_point == KILL_POINTS
    print(f"\n{KILL_POINTS} SIGKILLs of usv sitl, {n} parameter sets, {len(acked)} parameters and "
          f"{'a' if acked_plan else 'no'} mission checked after every restart, "
          f"{in_flight_seen} unacknowledged writes found saved")
    assert acked and acked_plan is not None
