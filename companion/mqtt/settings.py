"""The ``[mqtt]`` configuration as one validated record (:class:`MqttSettings`).

The keys themselves are in :data:`companion.config.SETTINGS` (``mqtt.*``); this module turns them
into what the client needs: host, port, TLS context, credentials read from their files, the
command allowlist.  Secrets live in files readable by their owner only (as the MAVLink signing
key): any other mode is a :class:`~companion.config.ConfigError` naming the key, so a mistake
is one line and exit status 2, never a half-secured boat.
"""

from __future__ import annotations

import enum
import ssl
import stat
from dataclasses import dataclass
from pathlib import Path

from companion.config import Config, ConfigError, check_mqtt_url

DEFAULT_PORT = {"mqtt": 1883, "mqtts": 8883}
"""The IANA ports of MQTT and MQTT over TLS."""
MIN_TOKEN_CHARS = 16


class MqttCommand(enum.StrEnum):
    """Commands an operator may send over MQTT (when ``mqtt.commands`` is on and allowlisted)."""

    RTL = "RTL"
    HOLD = "HOLD"
    STOP_PUMP = "STOP_PUMP"


@dataclass(frozen=True)
class MqttSettings:
    """Everything the MQTT service needs from the configuration."""

    host: str
    port: int
    tls: bool
    vehicle_id: str
    username: str | None = None
    password: str | None = None
    tls_ca_file: str = ""
    tls_cert_file: str = ""
    tls_key_file: str = ""
    tls_insecure: bool = False
    reconnect_max_s: float = 30.0
    commands_enabled: bool = False
    command_token: str | None = None
    command_allowlist: frozenset[MqttCommand] = frozenset()

    @property
    def url(self) -> str:
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"

    def tls_context(self) -> ssl.SSLContext | None:
        """The TLS context of an ``mqtts://`` URL (``None`` for plain ``mqtt://``)."""
        if not self.tls:
            return None
        context = ssl.create_default_context(cafile=self.tls_ca_file or None)
        if self.tls_cert_file:
            context.load_cert_chain(self.tls_cert_file, self.tls_key_file or None)
        if self.tls_insecure:
            context.check_hostname = False
        return context


def parse_url(url: str) -> tuple[str, int, bool]:
    """``mqtt://HOST[:PORT]`` -> (host, port, tls).  Raises ValueError naming the problem."""
    if (problem := check_mqtt_url(url)) is not None:
        raise ValueError(problem)
    scheme, _, rest = url.partition("://")
    rest = rest.rstrip("/")
    host, colon, port = rest.rpartition(":")
    if not colon:
        host, port = rest, ""
    return host, int(port) if port else DEFAULT_PORT[scheme], scheme == "mqtts"


def read_secret(path_text: str, key: str) -> str:
    """The first line of a file only its owner may read (mode 0600 or 0400)."""
    path = Path(path_text).expanduser()
    try:
        mode = path.stat().st_mode
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{key}: cannot read {path}: {exc.strerror or exc}") from None
    if mode & (stat.S_IRWXG | stat.S_IRWXO):
        raise ConfigError(f"{key}: {path} must be readable by its owner only (chmod 600), "
                          f"not {stat.filemode(mode)}")
    secret = text.splitlines()[0].strip() if text.strip() else ""
    if not secret:
        raise ConfigError(f"{key}: {path} is empty")
    return secret


def mqtt_settings(config: Config, system_id: int) -> MqttSettings | None:
    """The validated settings, or ``None`` when ``mqtt.url`` is empty (no MQTT at all)."""
    url = str(config["mqtt.url"])
    if not url:
        return None
    try:
        host, port, tls = parse_url(url)
    except ValueError as exc:
        raise ConfigError(f"mqtt.url: invalid value {url!r} ({exc})") from None
    username = str(config["mqtt.username"]) or None
    password = read_secret(config["mqtt.password_file"], "mqtt.password_file") \
        if config["mqtt.password_file"] else None
    if password is not None and username is None:
        raise ConfigError("mqtt.password_file: a password needs mqtt.username")
    commands = bool(config["mqtt.commands"])
    token = None
    if commands:
        if not config["mqtt.command_token_file"]:
            raise ConfigError("mqtt.commands: commands over MQTT need mqtt.command_token_file (a secret "
                              "every command carries)")
        if username is None:
            raise ConfigError("mqtt.commands: commands over MQTT need an authenticated broker "
                              "(mqtt.username and mqtt.password_file)")
        token = read_secret(config["mqtt.command_token_file"], "mqtt.command_token_file")
        if len(token) < MIN_TOKEN_CHARS:
            raise ConfigError(f"mqtt.command_token_file: the token must have at least {MIN_TOKEN_CHARS} "
                              "characters")
    for key in ("mqtt.tls_ca_file", "mqtt.tls_cert_file", "mqtt.tls_key_file"):
        if config[key] and not Path(config[key]).expanduser().is_file():
            raise ConfigError(f"{key}: no such file {config[key]!r}")
    return MqttSettings(
        host=host, port=port, tls=tls,
        vehicle_id=str(config["mqtt.vehicle_id"]) or f"usv{system_id}",
        username=username, password=password,
        tls_ca_file=str(config["mqtt.tls_ca_file"]), tls_cert_file=str(config["mqtt.tls_cert_file"]),
        tls_key_file=str(config["mqtt.tls_key_file"]), tls_insecure=bool(config["mqtt.tls_insecure"]),
        reconnect_max_s=float(config["mqtt.reconnect_max_s"]),
        commands_enabled=commands, command_token=token,
        command_allowlist=frozenset(MqttCommand(c) for c in config["mqtt.command_allowlist"]),
    )
