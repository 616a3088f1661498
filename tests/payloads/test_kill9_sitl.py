"""Issue 7: kill -9 of the companion while it samples, then restart (``usv sitl`` subprocess).

A ground station (pymavlink over loopback UDP) takes one sample to completion and starts a
second; while the pump runs the process gets SIGKILL.  After a restart on the same state
directory, ``usv samples export --format csv`` still lists the completed sample, the one in
progress is marked ``interrupted``, and SQLite's ``PRAGMA integrity_check`` says ``ok``.
"""

from __future__ import annotations

import asyncio
import csv
import io
import signal
import sqlite3
import subprocess
from pathlib import Path

import pytest

from companion.link.dialect import mav
from companion.payloads.samplelog import SAMPLE_LOG_NAME
from mavlink_dialect import UsvCmd
from tests.conftest import usv_command
from tests.mavlink.gcs import AsyncGcs, free_port
from tests.mavlink.sitl_process import sitl, write_config

pytestmark = [pytest.mark.integration, pytest.mark.slow]

SPEEDUP = 4.0


def _export(cfg: Path, env: dict[str, str]) -> list[dict[str, str]]:
    out = subprocess.run([*usv_command(), "samples", "export", "--format", "csv", "--status", "all",
                          "-c", str(cfg)], env=env, capture_output=True, text=True, timeout=60, check=True)
    return list(csv.DictReader(io.StringIO(out.stdout)))


async def test_kill9_during_sampling_keeps_completed_samples_and_marks_interrupted(
        tmp_path: Path, usv_env: dict[str, str]) -> None:
    port = free_port()
    state = tmp_path / "state"
    cfg = write_config(tmp_path / "sitl.toml", state, [port])
    with sitl(cfg, usv_env, speedup=SPEEDUP) as proc:
        async with AsyncGcs(port) as gcs:
            await gcs.connect(timeout_s=20.0)
            await asyncio.sleep(1.0)  # a few navigation samples for the log's position
            ack = await gcs.command(UsvCmd.SAMPLE, 1, 0, 100, timeout_s=30.0)
            assert ack.result == mav.MAV_RESULT_ACCEPTED
            progress = asyncio.ensure_future(gcs.wait(
                "COMMAND_ACK", lambda m: m.command == UsvCmd.SAMPLE and m.result == mav.MAV_RESULT_IN_PROGRESS
                and m.progress >= 20, timeout_s=30.0))
            await asyncio.sleep(0)
            gcs.send(mav.MAVLink_command_long_message(1, 1, UsvCmd.SAMPLE, 0, 2, 0, 450, 0, 0, 0, 0))
            await progress
            proc.send_signal(signal.SIGKILL)
            assert proc.wait(10) == -signal.SIGKILL

    before = _export(cfg, usv_env)  # as the crash left it (read-only export)
    assert [(r["bottle"], r["status"]) for r in before] == [("1", "complete"), ("2", "filling")]

    with sitl(cfg, usv_env, speedup=SPEEDUP):
        pass  # the restarted companion opens the log: a sample cut short is marked interrupted

    rows = _export(cfg, usv_env)
    assert [(r["bottle"], r["status"]) for r in rows] == [("1", "complete"), ("2", "interrupted")]
    assert float(rows[0]["volume_ml"]) == pytest.approx(100.0, abs=10.0)
    assert rows[0]["lat_deg"] and rows[0]["lon_deg"]
    db = sqlite3.connect(f"file:{state / SAMPLE_LOG_NAME}?mode=ro", uri=True)
    try:
        assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    finally:
        db.close()
