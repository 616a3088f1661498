"""Crash safety: SIGKILL at 100 random points while the companion's stores write, then restart.

A writer process (forked, so each start costs milliseconds) uses the companion's own store
classes on one state directory -- :class:`~companion.params.ParamStore` (params.toml),
:class:`~companion.mission.store.MissionStore` (mission, fence and rally plans) and
:class:`~companion.payloads.samplelog.SampleLog` (a launch and the launcher's shot counter in
one transaction) -- and acknowledges each write on a pipe once the store call has returned,
as the vehicle answers PARAM_VALUE / MISSION_ACK only after saving.  The test kills it with
SIGKILL after its first acknowledged write and a random delay, reopens every store as a
restarted companion would, and checks: nothing is corrupt (no load warning, SQLite integrity ok)
and every acknowledged write is there (each target holds its last acknowledged value, or the one
write in flight at the kill).
"""

from __future__ import annotations

import os
import random
import signal
import time
from pathlib import Path
from typing import Any

from companion.mission.items import MissionItem, MissionType
from companion.mission.store import MissionStore
from companion.param_table import all_param_defs
from companion.params import ParamStore
from companion.payloads.samplelog import SampleLog

KILL_POINTS = 100
MAX_DELAY_S = 0.06
DEFS = all_param_defs()
PARAM_NAMES = [d.name for d in DEFS if not d.is_int and not d.choices and d.max - d.min >= 1.0][:3]
PLANS = (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY)
TARGETS: list[tuple[str, Any]] = ([("param", n) for n in PARAM_NAMES] + [("plan", t) for t in PLANS]
                                  + [("launch", None)])


def target_of(n: int) -> tuple[str, Any]:
    return TARGETS[n % len(TARGETS)]


def param_value(name: str, n: int) -> float:
    d = next(d for d in DEFS if d.name == name)
    return d.min + (d.max - d.min) * ((n % 99_991) + 1) / 99_993


def plan_of(mtype: MissionType, n: int) -> list[MissionItem]:
    return [MissionItem.waypoint(i, 41.77 + n * 1e-7, 123.43 + i * 1e-5).with_seq(i)
            for i in range(n % 4 + 1)]


def expected_value(n: int) -> Any:
    kind, what = target_of(n)
    if kind == "param":
        return param_value(what, n)
    if kind == "plan":
        return [item.to_dict() for item in plan_of(what, n)]
    return (float(n), n % 5)  # the launch's time and the shot counter written with it


def write(stores: tuple[ParamStore, MissionStore, SampleLog], n: int) -> None:
    params, missions, log = stores
    kind, what = target_of(n)
    if kind == "param":
        params.set(what, param_value(what, n))
    elif kind == "plan":
        missions.replace(what, plan_of(what, n), home_item=False)
    else:
        log.add_launch(t_unix_s=float(n), lat_deg=41.77, lon_deg=123.43, heading_deg=90.0, pressure_mpa=30.0,
                       mission_seq=None, shots_left=n % 5)


def open_stores(state: Path) -> tuple[ParamStore, MissionStore, SampleLog]:
    return (ParamStore(DEFS, state / "params.toml"), MissionStore(state / "missions"),
            SampleLog(state / "samples.sqlite"))


def persisted(state: Path) -> tuple[dict[tuple[str, Any], Any], list[str]]:
    """What a restarted companion finds, and every sign of corruption."""
    params, missions, log = open_stores(state)
    try:
        problems = list(params.load_warnings) + list(missions.load_warnings)
        if not log.integrity_ok():
            problems.append("sample log integrity check failed")
        found: dict[tuple[str, Any], Any] = {}
        for name in PARAM_NAMES:
            found[("param", name)] = params.get(name)
        for mtype in PLANS:
            found[("plan", mtype)] = [item.to_dict() for item in missions.items(mtype)]
        launches = log.launches()
        found[("launch", None)] = (launches[-1].t_unix_s, log.shots_left()) if launches else None
        return found, problems
    finally:
        log.close()


def run_writer(state: Path, first_n: int) -> tuple[int, int]:
    """Fork a writer from ``first_n`` on; returns (pid, read end of its acknowledgement pipe)."""
    read_fd, write_fd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the writer: never returns into pytest
        code = 1
        try:
            os.close(read_fd)
            stores = open_stores(state)
            n = first_n
            while True:
                write(stores, n)
                os.write(write_fd, f"{n}\n".encode())
                n += 1
        finally:
            os._exit(code)
    os.close(write_fd)
    return pid, read_fd


def first_ack(fd: int) -> bytes:
    """Block until the writer has acknowledged its first write (it has opened the stores and is
    writing); what was read, to be passed on to :func:`read_acks`."""
    data = b""
    while b"\n" not in data and (chunk := os.read(fd, 65536)):
        data += chunk
    return data


def read_acks(fd: int, data: bytes = b"") -> list[int]:
    while chunk := os.read(fd, 65536):
        data += chunk
    os.close(fd)
    return [int(line) for line in data.decode().splitlines() if line.strip()]


def test_sigkill_at_100_random_points_loses_no_acknowledged_write(tmp_path: Path) -> None:
    state = tmp_path / "state"
    state.mkdir()
    rng = random.Random(16)
    baseline, problems = persisted(state)  # an empty state directory: defaults, no plans, no launch
    assert problems == []
    committed = dict(baseline)
    next_n, in_flight_found, mid_write_kills, losses = 0, 0, 0, []
    temp_files: set[Path] = set()
    for kill_point in range(KILL_POINTS):
        pid, fd = run_writer(state, next_n)
        started = first_ack(fd)  # kill while writes go on, not while a loaded machine starts the writer
        time.sleep(rng.uniform(0.0, MAX_DELAY_S))
        os.kill(pid, signal.SIGKILL)
        _, status = os.waitpid(pid, 0)
        assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
        acks = read_acks(fd, started)
        assert acks == list(range(next_n, next_n + len(acks)))
        for n in acks:
            committed[target_of(n)] = expected_value(n)
        in_flight = next_n + len(acks)  # the write that may have completed without its acknowledgement
        left = set(state.rglob(".*"))
        if left - temp_files:
            mid_write_kills += 1  # killed inside an atomic file replacement (its temporary file is left)
        temp_files |= left
        found, problems = persisted(state)
        assert problems == [], f"kill point {kill_point}: {problems}"
        for target, value in found.items():
            if value == committed[target]:
                continue
            if target == target_of(in_flight) and value == expected_value(in_flight):
                committed[target] = value
                in_flight_found += 1
                continue
            losses.append((kill_point, target, value, committed[target]))
        next_n = in_flight + 1
    print(f"\n{KILL_POINTS} kill points, {next_n} writes, {mid_write_kills} kills inside a file replacement, "
          f"{in_flight_found} unacknowledged in-flight writes found complete, losses: {len(losses)}")
    assert losses == []
    assert next_n > 2 * KILL_POINTS  # the kills landed while writes were going on
    assert all(committed[t] != baseline[t] for t in TARGETS)


def test_temporary_files_of_a_killed_writer_are_removed_on_restart(tmp_path: Path) -> None:
    path = tmp_path / "params.toml"
    stale, fresh = tmp_path / ".params.toml.abc123", tmp_path / ".params.toml.def456"
    stale.write_text("half")
    fresh.write_text("being written")
    old = time.time() - 3600
    os.utime(stale, (old, old))
    ParamStore(DEFS, path)
    assert not stale.exists() and fresh.exists()  # a file being written right now is left alone
