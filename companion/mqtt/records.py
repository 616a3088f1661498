"""Feeds the outbox: sample records, launch records and failsafe events.

* **Samples and launches** are read from the durable sample log (``samples.sqlite``, read-only
  connection), newer than the last one queued: a sample once it has its final state (complete,
  failed, aborted, interrupted; a ``filling`` row waits), a launch as soon as it is logged.  The
  log is the source of truth, so a record committed just before a crash is found and queued at
  the next start, and one already queued is not queued again (the outbox's cursor).
* **Failsafe events** come from the operator messages on the bus (``status_text``): the GCS
  failsafe and its clearing, the engine stop (disarm after ``USV_FS_ENG_STOP``), and every
  message of severity CRITICAL or worse.  Each gets the next number ``failsafe-<n>``.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from companion.app import Context
from companion.messages import STATUS_TEXT_TOPIC, Severity, StatusText
from companion.mqtt.outbox import Outbox, record_id
from companion.mqtt.topics import RecordTopic, encode
from companion.payloads.samplelog import SAMPLE_COLUMNS, LaunchRecord, SampleRecord

LAUNCH_COLUMNS = ("id", "t_unix_s", "lat_deg", "lon_deg", "heading_deg", "pressure_mpa", "mission_seq")


def failsafe_kind(event: StatusText) -> str | None:
    """The failsafe event an operator message is (``None``: not one)."""
    if event.text.startswith("GCS failsafe cleared"):
        return "gcs_cleared"
    if event.text.startswith("GCS failsafe"):
        return "gcs"
    if "engine stop" in event.text:
        return "engine_stop"
    if event.severity <= Severity.CRITICAL:
        return "critical"
    return None


def sample_document(record: SampleRecord) -> dict[str, Any]:
    return {"record_id": record_id(RecordTopic.SAMPLE, record.id), **asdict(record)}


def launch_document(record: LaunchRecord) -> dict[str, Any]:
    return {"record_id": record_id(RecordTopic.LAUNCH, record.id), **asdict(record)}


class RecordFeed:
    """Puts every new record and failsafe event into the :class:`Outbox`."""

    def __init__(self, ctx: Context, outbox: Outbox, samplelog_path: Path) -> None:
        self.ctx = ctx
        self.outbox = outbox
        self.samplelog_path = samplelog_path
        self._db: sqlite3.Connection | None = None
        self.queued = 0
        """Records queued by this feed since it started."""
        self.on_added: Callable[[], None] | None = None
        """Called after a record was queued (the service wakes its publisher)."""
        self._remove = ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(self._on_status_text)

    def close(self) -> None:
        self._remove()
        if self._db is not None:
            self._db.close()
            self._db = None

    def _log(self) -> sqlite3.Connection | None:
        if self._db is None and self.samplelog_path.exists():
            self._db = sqlite3.connect(f"file:{self.samplelog_path}?mode=ro", uri=True, isolation_level=None,
                                       timeout=5.0)
        return self._db

    def poll(self) -> int:
        """Queue the sample log's new final samples and new launches; returns how many."""
        db = self._log()
        if db is None:
            return 0
        added = 0
        after = self.outbox.last_source_id(RecordTopic.SAMPLE)
        for row in db.execute(f"SELECT {', '.join(SAMPLE_COLUMNS)} FROM samples WHERE id > ? ORDER BY id",
                              (after,)):
            sample = SampleRecord(*row)
            if sample.status == "filling":
                break  # still pumping: its final state comes later (one sample at a time)
            added += self._add(RecordTopic.SAMPLE, sample.id, sample_document(sample), sample.t_unix_s)
        after = self.outbox.last_source_id(RecordTopic.LAUNCH)
        for row in db.execute(f"SELECT {', '.join(LAUNCH_COLUMNS)} FROM launches WHERE id > ? ORDER BY id",
                              (after,)):
            launch = LaunchRecord(*row)
            added += self._add(RecordTopic.LAUNCH, launch.id, launch_document(launch), launch.t_unix_s)
        return added

    def _on_status_text(self, event: StatusText) -> None:
        kind = failsafe_kind(event)
        if kind is None:
            return
        number = self.outbox.last_source_id(RecordTopic.FAILSAFE) + 1
        unix_s = self.ctx.clock.unix_time_s()
        document = {"record_id": record_id(RecordTopic.FAILSAFE, number), "t_s": round(event.t_s, 3),
                    "t_unix_s": round(unix_s, 3), "kind": kind, "severity": Severity(event.severity).name,
                    "text": event.text}
        self._add(RecordTopic.FAILSAFE, number, document, unix_s)

    def _add(self, kind: RecordTopic, source_id: int, document: dict[str, Any], unix_s: float) -> int:
        if self.outbox.add(kind, source_id, encode(document), unix_s):
            self.queued += 1
            if self.on_added is not None:
                self.on_added()
            return 1
        return 0
