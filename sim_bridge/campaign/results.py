"""A campaign's output directory: results saved as each run finishes, so a rerun resumes.

``DIR/campaign.toml``   the campaign file the results belong to (a rerun with another file is refused)
``DIR/results.csv``     one row per finished run (:data:`COLUMNS`), appended and flushed to disk
                        when the run's result arrives; a row cut short by a kill is dropped on the
                        next start, and that run is done again
``DIR/tracks/NNNNN.json``  the run's track (metres north/east of home) for the report's plots

A run is finished when its row is in ``results.csv``; a rerun of the campaign skips those runs.
A run whose worker was lost (no result) writes no row and is done again by the next rerun.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from companion.config import ConfigError
from sim_bridge.campaign.spec import SAMPLE_COLUMNS

RESULTS = "results.csv"
CAMPAIGN_COPY = "campaign.toml"
TRACKS = "tracks"

FIGURE_COLUMNS = (
    "mission_complete", "mission_time_s", "sim_time_s",
    "loiter_error_max_m", "circle_error_max_m", "circle_error_rms_m", "path_deviation_max_m",
    "mid_leg_cross_track_rms_m", "mid_leg_cross_track_max_m", "fill_distance_max_m", "samples_taken",
    "samples_within_tol",
    "launches", "launches_within_tol", "launch_distance_error_m", "launch_bearing_error_deg",
    "home_distance_m", "max_yaw_rate_degps", "mean_sog_mps", "path_extent_m", "displacement_m",
    "heading_change_deg", "failsafe_events", "warnings",
)
"""Per-run figures (empty where a figure does not apply to the mission)."""
COLUMNS = ("index", *[c for c in SAMPLE_COLUMNS if c != "index"], "success", "failures", *FIGURE_COLUMNS,
           "wall_s", "cpu_s", "worker", "error", "messages", "finished_unix_s")


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return "" if not math.isfinite(value) else repr(round(value, 6))
    return str(value).replace("\n", " ")


class ResultsDir:
    """The output directory of one campaign."""

    def __init__(self, path: Path, campaign_text: str) -> None:
        self.path = Path(path)
        self.path.mkdir(parents=True, exist_ok=True)
        (self.path / TRACKS).mkdir(exist_ok=True)
        copy = self.path / CAMPAIGN_COPY
        if copy.exists():
            if copy.read_text(encoding="utf-8") != campaign_text:
                raise ConfigError(f"{self.path} holds the results of another campaign file ({copy} differs): "
                                  "choose another --out directory")
        else:
            copy.write_text(campaign_text, encoding="utf-8")
        self.csv = self.path / RESULTS
        self._repair()

    def _repair(self) -> None:
        """Drop a last row cut short by a kill (no newline at the end of the file)."""
        if not self.csv.exists():
            return
        data = self.csv.read_bytes()
        if data and not data.endswith(b"\n"):
            with self.csv.open("r+b") as fh:
                fh.truncate(data.rfind(b"\n") + 1)

    def finished(self) -> set[int]:
        """Indices of the runs with a row."""
        return {int(r["index"]) for r in read_rows(self.path)}

    def append(self, rows: Iterable[dict[str, Any]]) -> None:
        """Append rows (and their tracks) and make them durable before returning."""
        rows = list(rows)
        for row in rows:
            track = row.pop("track", None)
            if track is not None:
                (self.path / TRACKS / f"{int(row['index']):05d}.json").write_text(json.dumps(track),
                                                                                  encoding="utf-8")
        new = not self.csv.exists() or self.csv.stat().st_size == 0
        with self.csv.open("a", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            if new:
                writer.writerow(COLUMNS)
            for row in rows:
                writer.writerow([_cell(row.get(c)) for c in COLUMNS])
            fh.flush()
            os.fsync(fh.fileno())


def read_rows(path: Path) -> list[dict[str, str]]:
    """The complete rows of ``path/results.csv`` (none if there is no file)."""
    f = Path(path) / RESULTS
    if not f.exists():
        return []
    with f.open(newline="", encoding="utf-8") as fh:
        text = fh.read()
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    rows = list(csv.DictReader(text.splitlines()))
    return [r for r in rows if r.get("index", "").isdigit() and r.get("finished_unix_s")]


def read_track(path: Path, index: int) -> dict[str, Any] | None:
    f = Path(path) / TRACKS / f"{index:05d}.json"
    if not f.exists():
        return None
    data: dict[str, Any] = json.loads(f.read_text(encoding="utf-8"))
    return data
