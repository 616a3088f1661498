"""The topic scheme ``usv/<vehicle_id>/<topic>`` and the JSON each topic carries.

State topics (:class:`StateTopic`) are published at their rate (:mod:`.params`) with QoS 0 and
the *retain* flag, so a dashboard that subscribes gets the last state at once.  Records and
events (:class:`RecordTopic`: sample, launch, failsafe) go out with QoS 1 on one sub-topic per
record, ``usv/<vehicle_id>/sample/<id>``, also retained: a dashboard that connects late (or a
broker restarted meanwhile that got them from the outbox) still receives every record, once per
record id.  ``online`` is retained ``{"online": true}`` while connected and the broker's
last will ``{"online": false}`` otherwise.  Commands arrive on ``cmd`` and are answered on
``cmd/reply``.  Every document's JSON Schema is in ``schemas.json`` (and the README).
"""

from __future__ import annotations

import enum
import json
import math
from functools import cache
from importlib import resources
from typing import Any

TOPIC_ROOT = "usv"
SCHEMA_FILE = "schemas.json"


class StateTopic(enum.StrEnum):
    """Latest-value topics (retained, QoS 0); the value is the rate parameter's name."""

    POSITION = "position"
    STATUS = "status"
    LINK = "link"
    ENGINE = "engine"
    CURRENT = "current"
    LAUNCHER = "launcher"
    SAMPLER = "sampler"


RATE_PARAM: dict[StateTopic, str] = {
    StateTopic.POSITION: "USV_MQTT_POS_HZ",
    StateTopic.STATUS: "USV_MQTT_STAT_HZ",
    StateTopic.LINK: "USV_MQTT_LINK_HZ",
    StateTopic.ENGINE: "USV_MQTT_ENG_HZ",
    StateTopic.CURRENT: "USV_MQTT_CUR_HZ",
    StateTopic.LAUNCHER: "USV_MQTT_LNCH_HZ",
    StateTopic.SAMPLER: "USV_MQTT_SMPL_HZ",
}
"""The parameter holding each state topic's rate in Hz."""


class RecordTopic(enum.StrEnum):
    """Records and events: QoS 1, one retained sub-topic per record, through the outbox."""

    SAMPLE = "sample"
    LAUNCH = "launch"
    FAILSAFE = "failsafe"


ONLINE_TOPIC = "online"
COMMAND_TOPIC = "cmd"
REPLY_TOPIC = "cmd/reply"

STATE_QOS = 0
RECORD_QOS = 1


def topic(vehicle_id: str, name: str) -> str:
    """``usv/<vehicle_id>/<name>``."""
    return f"{TOPIC_ROOT}/{vehicle_id}/{name}"


def record_topic(vehicle_id: str, kind: RecordTopic, record_id: str) -> str:
    """``usv/<vehicle_id>/<kind>/<record_id>`` (``record_id`` as in the document)."""
    return f"{TOPIC_ROOT}/{vehicle_id}/{kind.value}/{record_id}"


def clean(value: Any) -> Any:
    """JSON-safe copy: non-finite floats become ``null`` (JSON has no NaN), tuples lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [clean(v) for v in value]
    return value


def encode(document: dict[str, Any]) -> bytes:
    """Compact UTF-8 JSON of ``document`` (never NaN/Infinity)."""
    return json.dumps(clean(document), separators=(",", ":"), allow_nan=False).encode()


@cache
def schemas() -> dict[str, Any]:
    """Topic name (``position``, ..., ``sample``, ``cmd/reply``) -> its JSON Schema."""
    text = resources.files(__package__).joinpath(SCHEMA_FILE).read_text(encoding="utf-8")
    loaded: dict[str, Any] = json.loads(text)
    return loaded


def schema_name(topic_name: str) -> str | None:
    """The schema key of a full topic name ``usv/<vehicle_id>/...`` (None: not one of ours)."""
    parts = topic_name.split("/")
    if len(parts) < 3 or parts[0] != TOPIC_ROOT:
        return None
    rest = "/".join(parts[2:])
    if parts[2] in {k.value for k in RecordTopic} and len(parts) == 4:
        return parts[2]
    return rest if rest in schemas() else None
