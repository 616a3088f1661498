"""The README documents the JSON Schema of every MQTT topic, identical to the shipped ones that
the end-to-end test validates real payloads against."""

from __future__ import annotations

import json
import re

from companion.mqtt.topics import RecordTopic, StateTopic, schemas
from tests.conftest import REPO_ROOT

BLOCK = re.compile(r"<!-- mqtt-schema (\S+) -->\s*```json\n(.*?)\n```", re.DOTALL)


def test_every_topic_schema_is_in_the_readme_as_shipped() -> None:
    readme = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    documented = {name: json.loads(text) for name, text in BLOCK.findall(readme)}
    shipped = schemas()
    assert documented == shipped
    topics = {t.value for t in StateTopic} | {t.value for t in RecordTopic} | {"online", "cmd", "cmd/reply"}
    assert set(shipped) == topics
