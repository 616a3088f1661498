"""The sample log survives SIGKILL at any moment, and ``usv samples export`` writes CSV/GeoJSON."""

from __future__ import annotations

import csv
import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

from companion.payloads.samplelog import SampleLog

from ..conftest import usv_command

WRITER = r"""
import sys, time
from companion.payloads.samplelog import SampleLog
log = SampleLog(sys.argv[1])
i = 0
while True:
    bottle = i % 4 + 1
    sid = log.begin_sample(t_unix_s=1.7e9 + i, bottle=bottle, lat_deg=41.77 + i * 1e-6, lon_deg=123.43,
                           mission_seq=i, target_lat_deg=41.77, target_lon_deg=123.43, distance_m=0.5,
                           bottle_state=1)
    log.finish_sample(sid, status="complete", volume_ml=100.0 + i, duration_s=20.0, distance_m=1.0,
                      bottle=bottle, bottle_state=2)
    print(sid, flush=True)
    i += 1
"""


def _kill_writer_after(db: Path, n_lines: int, extra_delay_s: float) -> list[int]:
    """Run a writer subprocess, SIGKILL it, and return the ids it reported as committed."""
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(db)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    committed = [int(proc.stdout.readline()) for _ in range(n_lines)]
    time.sleep(extra_delay_s)  # let it write more, then kill at an arbitrary moment
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(10)
    committed += [int(line) for line in proc.stdout.read().split()]
    return committed


def test_sigkill_during_writes_loses_no_committed_sample(tmp_path: Path) -> None:
    db = tmp_path / "samples.sqlite"
    seen_before = 0
    for round_no, delay in enumerate((0.0, 0.013, 0.037, 0.1)):
        committed = _kill_writer_after(db, 5, delay)
        con = sqlite3.connect(str(db))
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        con.close()
        log = SampleLog(db)  # reopening recovers the WAL and marks a cut-short sample interrupted
        assert log.integrity_ok()
        rows = log.samples()
        ids = {r.id for r in rows}
        assert set(committed) <= ids, f"round {round_no}: committed samples lost"
        complete = log.samples("complete")
        assert {r.id for r in complete} >= set(committed)
        assert all(r.status in ("complete", "interrupted") for r in rows)
        assert all(r.volume_ml >= 100.0 for r in complete)
        assert len(rows) > seen_before
        seen_before = len(rows)
        log.close()


def _fill_log(path: Path) -> None:
    log = SampleLog(path)
    for i, dist in enumerate((0.4, 1.1)):
        sid = log.begin_sample(
            t_unix_s=1.7e9 + i,
            bottle=i + 1,
            lat_deg=41.77,
            lon_deg=123.43 + i * 1e-5,
            mission_seq=3 + i,
            target_lat_deg=41.77,
            target_lon_deg=123.43,
            distance_m=dist,
            bottle_state=1,
        )
        log.finish_sample(
            sid,
            status="complete",
            volume_ml=480.0,
            duration_s=19.5,
            distance_m=dist,
            bottle=i + 1,
            bottle_state=2,
        )
    sid = log.begin_sample(
        t_unix_s=1.7e9 + 9,
        bottle=3,
        lat_deg=None,
        lon_deg=None,
        mission_seq=None,
        target_lat_deg=None,
        target_lon_deg=None,
        distance_m=None,
        bottle_state=1,
    )
    log.finish_sample(
        sid, status="aborted", volume_ml=10.0, duration_s=1.0, distance_m=None, bottle=3, bottle_state=3
    )
    log.close()


def test_export_csv_and_geojson(tmp_path: Path, usv_env: dict[str, str]) -> None:
    db = tmp_path / "state" / "samples.sqlite"
    _fill_log(db)
    out = subprocess.run(
        [*usv_command(), "samples", "export", "--format", "csv", "--state-dir", str(tmp_path / "state")],
        capture_output=True,
        text=True,
        env=usv_env,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    rows = list(csv.DictReader(io.StringIO(out.stdout)))
    assert [r["bottle"] for r in rows] == ["1", "2"]  # complete samples only by default
    assert float(rows[1]["distance_m"]) == 1.1 and rows[0]["mission_seq"] == "3"
    geo_file = tmp_path / "s.geojson"
    out = subprocess.run(
        [
            *usv_command(),
            "samples",
            "export",
            "--format",
            "geojson",
            "--db",
            str(db),
            "--status",
            "all",
            "-o",
            str(geo_file),
        ],
        capture_output=True,
        text=True,
        env=usv_env,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    geo = json.loads(geo_file.read_text())
    assert geo["type"] == "FeatureCollection" and len(geo["features"]) == 3
    first = geo["features"][0]
    assert first["geometry"] == {"type": "Point", "coordinates": [123.43, 41.77]}
    assert first["properties"]["volume_ml"] == 480.0 and geo["features"][2]["geometry"] is None


def test_export_missing_or_bad_log_is_a_clear_error(tmp_path: Path, usv_env: dict[str, str]) -> None:
    out = subprocess.run(
        [*usv_command(), "samples", "export", "--db", str(tmp_path / "nope.sqlite")],
        capture_output=True,
        text=True,
        env=usv_env,
        timeout=60,
    )
    assert out.returncode == 2 and "no sample log" in out.stderr and "Traceback" not in out.stderr
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database" * 100)
    out = subprocess.run(
        [*usv_command(), "samples", "export", "--db", str(junk)],
        capture_output=True,
        text=True,
        env=usv_env,
        timeout=60,
    )
    assert out.returncode == 2 and "cannot read sample log" in out.stderr and "Traceback" not in out.stderr
