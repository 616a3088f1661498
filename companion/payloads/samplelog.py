"""Durable log of water samples and rope launches (SQLite, WAL journal, synchronous=FULL).

Why SQLite in WAL mode: every sample is one transaction; a transaction is durable once
``commit()`` returns (with ``synchronous=FULL`` the WAL is fsync'd at every commit, so even
a power cut keeps it), and a process killed with SIGKILL at any moment leaves the database
consistent: an uncommitted transaction simply never happened.  ``tests/payloads`` kills a
writer with SIGKILL and then runs ``PRAGMA integrity_check``.

A sample is written twice: a ``filling`` row when the pump starts and the final state
(``complete``, ``failed`` or ``aborted``) when it stops.  A ``filling`` row found when the
log is opened belongs to a sample cut short by a crash and is marked ``interrupted``.
Bottle states are kept in their own table so a restarted companion knows which bottles
are full, and the rope launcher's shot counter in the ``launcher`` table, written in the same
transaction as the launch it follows, so a restart neither forgets a shot nor counts one twice.
"""

from __future__ import annotations

import csv
import io
import json
import math
import sqlite3
from dataclasses import asdict, dataclass
from pathlib import Path

from companion.messages import BOTTLE_COUNT

SCHEMA = """
CREATE TABLE IF NOT EXISTS samples (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    t_unix_s REAL NOT NULL,
    bottle INTEGER NOT NULL,
    status TEXT NOT NULL,
    lat_deg REAL,
    lon_deg REAL,
    volume_ml REAL NOT NULL DEFAULT 0,
    duration_s REAL NOT NULL DEFAULT 0,
    mission_seq INTEGER,
    target_lat_deg REAL,
    target_lon_deg REAL,
    distance_m REAL
);
CREATE TABLE IF NOT EXISTS bottles (
    bottle INTEGER PRIMARY KEY,
    state INTEGER NOT NULL,
    volume_ml REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS launches (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    t_unix_s REAL NOT NULL,
    lat_deg REAL,
    lon_deg REAL,
    heading_deg REAL,
    pressure_mpa REAL,
    mission_seq INTEGER
);
CREATE TABLE IF NOT EXISTS launcher (
    id INTEGER PRIMARY KEY CHECK (id = 1),
    shots_left INTEGER NOT NULL
);
"""

SAMPLE_LOG_NAME = "samples.sqlite"
"""File name of the log inside the companion's state directory."""

SAMPLE_COLUMNS = (
    "id",
    "t_unix_s",
    "bottle",
    "status",
    "lat_deg",
    "lon_deg",
    "volume_ml",
    "duration_s",
    "mission_seq",
    "target_lat_deg",
    "target_lon_deg",
    "distance_m",
)


@dataclass(frozen=True, slots=True)
class SampleRecord:
    """One row of the sample log (``distance_m``: from the commanded point, None without one)."""

    id: int
    t_unix_s: float
    bottle: int
    status: str
    lat_deg: float | None
    lon_deg: float | None
    volume_ml: float
    duration_s: float
    mission_seq: int | None
    target_lat_deg: float | None
    target_lon_deg: float | None
    distance_m: float | None


@dataclass(frozen=True, slots=True)
class LaunchRecord:
    """One rope launch: when, where and in which direction."""

    id: int
    t_unix_s: float
    lat_deg: float | None
    lon_deg: float | None
    heading_deg: float | None
    pressure_mpa: float | None
    mission_seq: int | None


def _num(x: float | None) -> float | None:
    """SQLite stores NaN as NULL anyway; make that explicit."""
    return None if x is None or not math.isfinite(x) else float(x)


class SampleLog:
    """The sample and launch log in one SQLite file; every write is a committed transaction."""

    def __init__(self, path: Path, *, readonly: bool = False) -> None:
        """Open (and create) the log; ``readonly`` only reads, e.g. while the companion runs."""
        self.path = Path(path)
        if readonly:
            if not self.path.exists():
                raise FileNotFoundError(f"no sample log at {self.path}")
            self._db = sqlite3.connect(
                f"file:{self.path}?mode=ro", uri=True, isolation_level=None, timeout=5.0
            )
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(str(self.path), isolation_level=None, timeout=5.0)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.executescript(SCHEMA)
        with self._tx():
            self._db.execute("UPDATE samples SET status='interrupted' WHERE status='filling'")
            for bottle in range(1, BOTTLE_COUNT + 1):
                self._db.execute(
                    "INSERT OR IGNORE INTO bottles(bottle, state, volume_ml) VALUES (?, 0, 0)", (bottle,)
                )

    def _tx(self) -> _Transaction:
        """``with self._tx():`` runs the block as one BEGIN IMMEDIATE ... COMMIT transaction."""
        return _Transaction(self._db)

    def close(self) -> None:
        self._db.close()

    # -- samples ----------------------------------------------------------------------------
    def begin_sample(
        self,
        *,
        t_unix_s: float,
        bottle: int,
        lat_deg: float | None,
        lon_deg: float | None,
        mission_seq: int | None,
        target_lat_deg: float | None,
        target_lon_deg: float | None,
        distance_m: float | None,
        bottle_state: int,
    ) -> int:
        """Record a sample that starts now; returns its id."""
        with self._tx():
            cur = self._db.execute(
                "INSERT INTO samples(t_unix_s, bottle, status, lat_deg, lon_deg, mission_seq, target_lat_deg,"
                " target_lon_deg, distance_m) VALUES (?, ?, 'filling', ?, ?, ?, ?, ?, ?)",
                (
                    t_unix_s,
                    bottle,
                    _num(lat_deg),
                    _num(lon_deg),
                    mission_seq,
                    _num(target_lat_deg),
                    _num(target_lon_deg),
                    _num(distance_m),
                ),
            )
            self._db.execute("UPDATE bottles SET state=? WHERE bottle=?", (bottle_state, bottle))
            return int(cur.lastrowid or 0)

    def finish_sample(
        self,
        sample_id: int,
        *,
        status: str,
        volume_ml: float,
        duration_s: float,
        distance_m: float | None,
        bottle: int,
        bottle_state: int,
    ) -> None:
        """Record the outcome of a sample and the new state of its bottle, atomically.

        Time and position stay those of the moment the pump started.
        """
        with self._tx():
            self._db.execute(
                "UPDATE samples SET status=?, volume_ml=?, duration_s=?, distance_m=? WHERE id=?",
                (status, volume_ml, duration_s, _num(distance_m), sample_id),
            )
            self._db.execute(
                "UPDATE bottles SET state=?, volume_ml=? WHERE bottle=?", (bottle_state, volume_ml, bottle)
            )

    def samples(self, status: str | None = None) -> list[SampleRecord]:
        sql = f"SELECT {', '.join(SAMPLE_COLUMNS)} FROM samples"
        rows = (
            self._db.execute(sql + " WHERE status=? ORDER BY id", (status,))
            if status
            else self._db.execute(sql + " ORDER BY id")
        )
        return [SampleRecord(*row) for row in rows]

    def bottles(self) -> list[tuple[int, float]]:
        """(state, volume_ml) of bottles 1..4, as last recorded."""
        rows = self._db.execute("SELECT state, volume_ml FROM bottles ORDER BY bottle").fetchall()
        return [(int(s), float(v)) for s, v in rows]

    def set_bottle(self, bottle: int, state: int, volume_ml: float) -> None:
        with self._tx():
            self._db.execute(
                "UPDATE bottles SET state=?, volume_ml=? WHERE bottle=?", (state, volume_ml, bottle)
            )

    # -- launches ---------------------------------------------------------------------------
    def add_launch(
        self,
        *,
        t_unix_s: float,
        lat_deg: float | None,
        lon_deg: float | None,
        heading_deg: float | None,
        pressure_mpa: float | None,
        mission_seq: int | None,
        shots_left: int | None = None,
    ) -> int:
        """Record a launch and (``shots_left``) the launcher's new shot count, atomically."""
        with self._tx():
            cur = self._db.execute(
                "INSERT INTO launches(t_unix_s, lat_deg, lon_deg, heading_deg, pressure_mpa, mission_seq)"
                " VALUES (?, ?, ?, ?, ?, ?)",
                (t_unix_s, _num(lat_deg), _num(lon_deg), _num(heading_deg), _num(pressure_mpa), mission_seq),
            )
            if shots_left is not None:
                self._put_shots_left(shots_left)
            return int(cur.lastrowid or 0)

    def _put_shots_left(self, shots_left: int) -> None:
        self._db.execute("INSERT INTO launcher(id, shots_left) VALUES (1, ?) "
                         "ON CONFLICT(id) DO UPDATE SET shots_left=excluded.shots_left", (int(shots_left),))

    def set_shots_left(self, shots_left: int) -> None:
        """Record the launcher's shot count (after a reload)."""
        with self._tx():
            self._put_shots_left(shots_left)

    def shots_left(self) -> int | None:
        """The launcher's shot count as last recorded (``None``: never recorded)."""
        try:
            row = self._db.execute("SELECT shots_left FROM launcher WHERE id=1").fetchone()
        except sqlite3.OperationalError:  # a read-only log written before the table existed
            return None
        return None if row is None else int(row[0])

    def launches(self) -> list[LaunchRecord]:
        rows = self._db.execute(
            "SELECT id, t_unix_s, lat_deg, lon_deg, heading_deg, pressure_mpa, mission_seq"
            " FROM launches ORDER BY id"
        )
        return [LaunchRecord(*row) for row in rows]

    def integrity_ok(self) -> bool:
        return bool(self._db.execute("PRAGMA integrity_check").fetchone()[0] == "ok")


class _Transaction:
    def __init__(self, db: sqlite3.Connection) -> None:
        self.db = db

    def __enter__(self) -> sqlite3.Connection:
        self.db.execute("BEGIN IMMEDIATE")
        return self.db

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        self.db.execute("COMMIT" if exc_type is None else "ROLLBACK")


# -- export ----------------------------------------------------------------------------------
def export_csv(records: list[SampleRecord]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(SAMPLE_COLUMNS)
    for rec in records:
        writer.writerow(["" if v is None else v for v in asdict(rec).values()])
    return out.getvalue()


def export_geojson(records: list[SampleRecord]) -> str:
    """A GeoJSON FeatureCollection: one Point per sample (coordinates lon, lat; RFC 7946)."""
    features = []
    for rec in records:
        props = {k: v for k, v in asdict(rec).items() if k not in ("lat_deg", "lon_deg")}
        geometry = (
            None
            if rec.lat_deg is None or rec.lon_deg is None
            else {"type": "Point", "coordinates": [rec.lon_deg, rec.lat_deg]}
        )
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    return json.dumps({"type": "FeatureCollection", "features": features}, indent=1) + "\n"
