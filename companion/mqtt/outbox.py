"""The persistent outbox of MQTT records and events (SQLite, a sibling of the sample log).

Sample records, launch records and failsafe events must reach the dashboards even when the
broker is away for the whole mission, or the companion restarts meanwhile.  Each becomes one
row here, keyed by its record id (``sample-12``, ``launch-3``, ``failsafe-7``: the primary key,
so adding the same record twice is a no-op), in a committed transaction (WAL,
``synchronous=FULL``, as the sample log).  The service publishes pending rows with QoS 1 and
marks a row delivered only after the broker acknowledged it (PUBACK), so a record is published
again after a reconnection or a restart until it is acknowledged, and never after.  A record
republished because its acknowledgement was lost carries the same record id (and topic), which
is how a subscriber sees each record once.

Memory stays bounded whatever the outage: rows wait on disk, the service reads them in batches
of :data:`BATCH`.  Delivered rows are kept (the newest :data:`KEEP_DELIVERED`) so that a record
found again in the sample log after a restart is recognised as already sent.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from pathlib import Path

OUTBOX_NAME = "mqtt_outbox.sqlite"
"""File name in the companion's state directory (beside ``samples.sqlite``)."""
BATCH = 32
"""Rows read from disk at a time."""
KEEP_DELIVERED = 10_000

SCHEMA = """
CREATE TABLE IF NOT EXISTS outbox (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    record_id TEXT NOT NULL UNIQUE,
    kind TEXT NOT NULL,
    source_id INTEGER NOT NULL,
    payload BLOB NOT NULL,
    created_unix_s REAL NOT NULL,
    delivered_unix_s REAL
);
CREATE INDEX IF NOT EXISTS outbox_pending ON outbox(delivered_unix_s, seq);
CREATE TABLE IF NOT EXISTS cursors (
    kind TEXT PRIMARY KEY,
    last_source_id INTEGER NOT NULL
);
"""


@dataclass(frozen=True, slots=True)
class OutboxEntry:
    """One record waiting for (or past) its QoS 1 publication."""

    seq: int
    record_id: str
    kind: str
    source_id: int
    payload: bytes


class Outbox:
    """Durable, deduplicated queue of records; every write is a committed transaction."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(str(self.path), isolation_level=None, timeout=5.0)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")
        self._db.executescript(SCHEMA)

    def close(self) -> None:
        self._db.close()

    def add(self, kind: str, source_id: int, payload: bytes, created_unix_s: float) -> bool:
        """Queue record ``<kind>-<source_id>``; ``False`` if that record id is already here."""
        db = self._db
        db.execute("BEGIN IMMEDIATE")
        try:
            cur = db.execute(
                "INSERT OR IGNORE INTO outbox(record_id, kind, source_id, payload, created_unix_s)"
                " VALUES (?, ?, ?, ?, ?)",
                (record_id(kind, source_id), kind, source_id, payload, created_unix_s))
            db.execute("INSERT INTO cursors(kind, last_source_id) VALUES (?, ?) ON CONFLICT(kind) DO UPDATE"
                       " SET last_source_id=MAX(last_source_id, excluded.last_source_id)", (kind, source_id))
        except BaseException:
            db.execute("ROLLBACK")
            raise
        db.execute("COMMIT")
        return cur.rowcount == 1

    def last_source_id(self, kind: str) -> int:
        """The highest ``source_id`` of ``kind`` ever queued (0: none; survives pruning)."""
        row = self._db.execute("SELECT last_source_id FROM cursors WHERE kind=?", (kind,)).fetchone()
        return int(row[0]) if row else 0

    def pending(self, limit: int = BATCH) -> list[OutboxEntry]:
        """The oldest undelivered records, in the order they were queued."""
        rows = self._db.execute(
            "SELECT seq, record_id, kind, source_id, payload FROM outbox WHERE delivered_unix_s IS NULL"
            " ORDER BY seq LIMIT ?", (limit,))
        return [OutboxEntry(int(s), str(r), str(k), int(i), bytes(p)) for s, r, k, i, p in rows]

    def pending_count(self) -> int:
        row = self._db.execute("SELECT COUNT(*) FROM outbox WHERE delivered_unix_s IS NULL").fetchone()
        return int(row[0])

    def mark_delivered(self, record: str, delivered_unix_s: float) -> None:
        """The broker acknowledged ``record`` (QoS 1 PUBACK): never publish it again."""
        self._db.execute("UPDATE outbox SET delivered_unix_s=? WHERE record_id=?", (delivered_unix_s, record))
        self._db.execute(
            "DELETE FROM outbox WHERE delivered_unix_s IS NOT NULL AND seq <= "
            "(SELECT seq FROM outbox WHERE delivered_unix_s IS NOT NULL ORDER BY seq DESC LIMIT 1 OFFSET ?)",
            (KEEP_DELIVERED,))

    def delivered(self, record: str) -> bool:
        row = self._db.execute("SELECT delivered_unix_s FROM outbox WHERE record_id=?", (record,)).fetchone()
        return row is not None and row[0] is not None


def record_id(kind: str, source_id: int) -> str:
    """``sample-12``: the record id of every document, unique per state directory."""
    return f"{kind}-{source_id}"
