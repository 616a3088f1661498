"""``usv campaign`` as a user runs it: real processes.

* the distributed path: a ``dask scheduler`` and a ``dask worker`` started as separate processes on
  loopback, and ``usv campaign run --scheduler`` submitting to them; the runs are done by that
  worker (its address is in every row) and the report is written from the results;
* resuming: a campaign killed with SIGKILL (its whole process group: the client and its local
  cluster) part-way keeps the runs it finished, and a rerun does only the others.
"""

from __future__ import annotations

import csv
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import usv_command

pytestmark = pytest.mark.integration

GUARD_S = 240.0
"""Wall-clock guard only (nothing here depends on speed)."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _rows(out: Path) -> list[dict[str, str]]:
    f = out / "results.csv"
    if not f.exists():
        return []
    text = f.read_text(encoding="utf-8")
    return list(csv.DictReader(text[: text.rfind("\n") + 1].splitlines()))


def _dask() -> str:
    script = Path(sys.executable).with_name("dask")
    return str(script) if script.exists() else "dask"


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


@pytest.fixture
def dask_cluster(tmp_path: Path, usv_env: dict[str, str]) -> Iterator[tuple[str, str]]:
    """``dask scheduler`` and one single-threaded ``dask worker``: (scheduler address, worker address)."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = {name: (tmp_path / f"{name}.log").open("wb") for name in ("scheduler", "worker")}
    scheduler = subprocess.Popen([_dask(), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                  "--no-dashboard"], stdout=logs["scheduler"], stderr=subprocess.STDOUT,
                                 env=usv_env)
    worker = subprocess.Popen([_dask(), "worker", address, "--host", "127.0.0.1", "--nthreads", "1",
                               "--nworkers", "1", "--no-dashboard", "--name", "campaign-test-worker"],
                              stdout=logs["worker"], stderr=subprocess.STDOUT, env=usv_env)
    try:
        deadline = time.monotonic() + GUARD_S
        worker_address = None
        while worker_address is None:
            assert time.monotonic() < deadline, (tmp_path / "worker.log").read_text()
            assert scheduler.poll() is None and worker.poll() is None, (tmp_path / "worker.log").read_text()
            found = re.search(r"Start worker at:\s+(tcp://\S+)", (tmp_path / "worker.log").read_text())
            worker_address = found.group(1) if found else None
            time.sleep(0.2)
        yield address, worker_address
    finally:
        _stop(worker)
        _stop(scheduler)
        for fh in logs.values():
            fh.close()


def test_a_campaign_runs_on_a_separate_dask_scheduler_and_worker_and_is_reported(
        tiny_campaign: Path, tmp_path: Path, usv_env: dict[str, str], dask_cluster: tuple[str, str]) -> None:
    scheduler, worker = dask_cluster
    out = tmp_path / "out"
    proc = subprocess.run([*usv_command(), "campaign", "run", str(tiny_campaign), "--runs", "2", "--out",
                           str(out), "--scheduler", scheduler, "--no-progress"], env=usv_env,
                          capture_output=True, text=True, timeout=GUARD_S)
    assert proc.returncode == 0, proc.stderr
    rows = _rows(out)
    assert sorted(int(r["index"]) for r in rows) == [0, 1]
    for r in rows:
        assert r["worker"] == worker, r  # done by the separately started worker, not in this process
        assert r["error"] == "" and r["mission_complete"] == "1", r
        assert float(r["sim_time_s"]) > 20.0 and float(r["wall_s"]) > 0.0
        assert int(r["samples_taken"]) == 4 and float(r["circle_error_max_m"]) >= 0.0
        assert (r["success"] == "1") == (r["failures"] == ""), r
        assert 0.0 <= float(r["current_speed_mps"]) <= 0.4
    assert (out / "tracks" / "00000.json").exists()

    report = tmp_path / "report" / "tiny.md"
    proc = subprocess.run([*usv_command(), "campaign", "report", str(out), "--out", str(report)],
                          env=usv_env, capture_output=True, text=True, timeout=GUARD_S)
    assert proc.returncode == 0, proc.stderr
    text = report.read_text(encoding="utf-8")
    successes = sum(r["success"] == "1" for r in rows)
    assert f"success: **{successes} / 2 = {50.0 * successes:.1f} %**" in text
    assert "| circle_error_max_m | 2 |" in text
    for png in ("tiny_success_vs_current.png", "tiny_figures_vs_current_speed_mps.png",
                "tiny_worst_tracks.png"):
        data = (report.parent / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000, png
        assert f"({png})" in text


def test_a_killed_campaign_resumes_without_redoing_finished_runs(
        tiny_campaign: Path, tmp_path: Path, usv_env: dict[str, str]) -> None:
    out = tmp_path / "out"
    runs = 3  # killed after its first finished run (about 2 s a run): at least one is left to resume
    cmd = [*usv_command(), "campaign", "run", str(tiny_campaign), "--runs", str(runs), "--out", str(out),
           "--workers", "1", "--no-progress"]
    first = subprocess.Popen(cmd, env=usv_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
    try:
        deadline = time.monotonic() + GUARD_S
        while len(_rows(out)) < 1:
            assert first.poll() is None, "the campaign ended before it could be interrupted"
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        with_group = first.poll() is None
        if with_group:
            os.killpg(first.pid, signal.SIGKILL)  # the client and its local cluster, as a power cut would
        first.wait(30)
    assert first.returncode == -signal.SIGKILL
    before = {r["index"]: r for r in _rows(out)}
    assert 1 <= len(before) < runs, "kill the campaign part-way"

    proc = subprocess.run(cmd, env=usv_env, capture_output=True, text=True, timeout=GUARD_S)
    assert proc.returncode == 0, proc.stderr
    assert f"{len(before)} of {runs} runs already in" in proc.stderr
    assert f"{runs - len(before)} run(s) done now" in proc.stderr
    after = _rows(out)
    indices = [r["index"] for r in after]
    assert sorted(indices, key=int) == [str(i) for i in range(runs)]  # each run once
    for index, row in before.items():
        assert next(r for r in after if r["index"] == index) == row  # a finished run is not redone
    # a third run of the same campaign has nothing left to do
    proc = subprocess.run(cmd, env=usv_env, capture_output=True, text=True, timeout=GUARD_S)
    assert proc.returncode == 0 and f"{runs} of {runs} runs already in" in proc.stderr, proc.stderr
    assert len(_rows(out)) == runs
