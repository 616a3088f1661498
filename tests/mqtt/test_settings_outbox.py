"""Unit tests of the MQTT configuration and the persistent outbox (no broker)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from companion.config import ConfigError, default_config
from companion.mqtt.outbox import Outbox
from companion.mqtt.settings import MqttCommand, mqtt_settings, parse_url


def _secret(tmp_path: Path, name: str, text: str, mode: int = 0o600) -> str:
    path = tmp_path / name
    path.write_text(text + "\n")
    os.chmod(path, mode)
    return str(path)


def test_no_url_means_no_mqtt() -> None:
    assert mqtt_settings(default_config(), 1) is None


@pytest.mark.parametrize(("url", "expected"), [
    ("mqtt://127.0.0.1:1884", ("127.0.0.1", 1884, False)),
    ("mqtt://broker.example", ("broker.example", 1883, False)),
    ("mqtts://broker.example", ("broker.example", 8883, True)),
])
def test_urls(url: str, expected: tuple[str, int, bool]) -> None:
    assert parse_url(url) == expected


@pytest.mark.parametrize("url", ["http://x:1883", "mqtt://", "mqtt://h:0", "mqtt://u:p@h:1883", "h:1883"])
def test_bad_url_is_a_config_error_naming_the_key(url: str) -> None:
    with pytest.raises(ConfigError, match=r"mqtt\.url"):
        default_config().with_overrides({"mqtt.url": url})


def test_settings_vehicle_id_and_credentials(tmp_path: Path) -> None:
    config = default_config().with_overrides({
        "mqtt.url": "mqtt://127.0.0.1:1883", "mqtt.username": "boat",
        "mqtt.password_file": _secret(tmp_path, "pw", "s3cret")})
    settings = mqtt_settings(config, 7)
    assert settings is not None
    assert (settings.vehicle_id, settings.username, settings.password) == ("usv7", "boat", "s3cret")
    assert not settings.commands_enabled and settings.tls_context() is None


def test_a_password_file_others_can_read_is_refused(tmp_path: Path) -> None:
    config = default_config().with_overrides({
        "mqtt.url": "mqtt://h", "mqtt.username": "boat",
        "mqtt.password_file": _secret(tmp_path, "pw", "x", 0o644)})
    with pytest.raises(ConfigError, match="chmod 600"):
        mqtt_settings(config, 1)


def test_commands_need_a_token_and_an_authenticated_broker(tmp_path: Path) -> None:
    base = default_config().with_overrides({"mqtt.url": "mqtt://h", "mqtt.commands": True})
    with pytest.raises(ConfigError, match=r"command_token_file"):
        mqtt_settings(base, 1)
    token = _secret(tmp_path, "token", "0123456789abcdef0123")
    with pytest.raises(ConfigError, match="authenticated broker"):
        mqtt_settings(base.with_overrides({"mqtt.command_token_file": token}), 1)
    short = _secret(tmp_path, "short", "abc")
    authed = base.with_overrides({"mqtt.username": "boat",
                                  "mqtt.password_file": _secret(tmp_path, "pw", "pw")})
    with pytest.raises(ConfigError, match="at least 16"):
        mqtt_settings(authed.with_overrides({"mqtt.command_token_file": short}), 1)
    settings = mqtt_settings(authed.with_overrides({"mqtt.command_token_file": token,
                                                    "mqtt.command_allowlist": ["HOLD"]}), 1)
    assert settings is not None and settings.commands_enabled
    assert settings.command_allowlist == {MqttCommand.HOLD}
    with pytest.raises(ConfigError, match="command_allowlist"):
        authed.with_overrides({"mqtt.command_allowlist": ["DISARM"]})


def test_outbox_keeps_each_record_once_until_acknowledged_across_restarts(tmp_path: Path) -> None:
    path = tmp_path / "outbox.sqlite"
    box = Outbox(path)
    assert box.add("sample", 1, b"{1}", 0.0) and box.add("sample", 2, b"{2}", 0.0)
    assert not box.add("sample", 1, b"{1 again}", 0.0)  # the record id is the key
    assert [e.record_id for e in box.pending()] == ["sample-1", "sample-2"]
    box.mark_delivered("sample-1", 1.0)
    box.close()
    box = Outbox(path)  # a restarted companion
    assert [(e.record_id, e.payload) for e in box.pending()] == [("sample-2", b"{2}")]
    assert box.delivered("sample-1") and not box.delivered("sample-2")
    assert box.last_source_id("sample") == 2 and box.last_source_id("launch") == 0
    assert not box.add("sample", 1, b"{1}", 0.0)  # found again in the sample log: not resent
    assert box.pending_count() == 1
    box.close()
