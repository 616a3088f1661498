"""Configuration from a TOML file, validated against one schema of settings.

Defaults work for SITL, so ``usv sitl`` needs no file.  A bad key or value raises
:class:`ConfigError` whose message names the key and the accepted range; the command
line turns it into a one-line error and a non-zero exit, never a traceback.

The ``[params]`` table sets initial values of MAVLink parameters (validated against
:mod:`companion.param_table`); every other table is described by :data:`SETTINGS`.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from companion.params import ParamDef, ParamError


class ConfigError(ValueError):
    """An invalid configuration file, key or value; the message names the key."""


Check = Callable[[Any], str | None]
"""Extra check on a value: returns an error text, or ``None`` when the value is fine."""


@dataclass(frozen=True, slots=True)
class Setting:
    """One configuration key: ``section.name``, type, default, accepted range, description."""

    key: str
    default: Any
    description: str
    kind: type = str
    min: float | None = None
    max: float | None = None
    choices: tuple[str, ...] = ()
    item_check: Check | None = None
    accepted: str = ""
    item_kind: type = str
    """Type of the entries of a ``list`` setting (``str`` or ``int``)."""

    def accepted_text(self) -> str:
        if self.accepted:
            return self.accepted
        if self.choices:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        if self.min is not None and self.max is not None:
            return f"{self.kind.__name__} in [{self.min:g}, {self.max:g}]"
        return {list: "a list of strings", bool: "true or false"}.get(self.kind, self.kind.__name__)

    def validate(self, value: Any) -> Any:
        bad = ConfigError(f"{self.key}: invalid value {value!r}; accepted: {self.accepted_text()}")
        if self.kind is bool:
            if not isinstance(value, bool):
                raise bad
            return value
        if self.kind in (int, float):
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise bad
            if self.kind is int and not float(value).is_integer():
                raise bad
            if not math.isfinite(float(value)):
                raise bad
            if (self.min is not None and value < self.min) or (self.max is not None and value > self.max):
                raise bad
            return self.kind(value)
        if self.kind is list:
            if not isinstance(value, list) or not all(
                    isinstance(v, self.item_kind) and not isinstance(v, bool) for v in value):
                raise bad
            for item in value:
                problem = self.item_check(item) if self.item_check else None
                if problem:
                    raise ConfigError(f"{self.key}: invalid entry {item!r} ({problem}); "
                                      f"accepted: {self.accepted_text()}")
            return list(value)
        if not isinstance(value, str):
            raise bad
        if self.choices and value not in self.choices:
            raise bad
        if self.item_check and (problem := self.item_check(value)):
            raise ConfigError(f"{self.key}: invalid value {value!r} ({problem}); "
                              f"accepted: {self.accepted_text()}")
        return value


def parse_host_port(text: str) -> tuple[str, int]:
    """``host:port`` with a port in 1..65535 -> (host, port): the one address parser (MAVLink
    links, hardware links, the simulator's ports).  Raises ValueError naming the problem."""
    host, sep, port = text.rpartition(":")
    if not sep or not host:
        raise ValueError("expected host:port")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ValueError("port must be 1..65535")
    return host, int(port)


def parse_serial(text: str, default_baud: int) -> tuple[str, int]:
    """``device[:baud]`` (e.g. ``/dev/ttyUSB0:57600``) -> (device, baud).  Raises ValueError."""
    device, sep, baud = text.partition(":")
    if not device:
        raise ValueError("expected device[:baud]")
    if sep and (not baud.isdigit() or int(baud) <= 0):
        raise ValueError("baud must be a positive integer")
    return device, int(baud) if sep else default_baud


def check_host_port(text: str) -> str | None:
    """Why ``text`` is not ``host:port``, or None."""
    try:
        parse_host_port(text)
    except ValueError as exc:
        return str(exc)
    return None


def check_serial(text: str) -> str | None:
    """Why ``text`` is not ``device[:baud]``, or None."""
    try:
        parse_serial(text, 1)
    except ValueError as exc:
        return str(exc)
    return None


def check_mqtt_url(text: str) -> str | None:
    """Why ``text`` is not ``mqtt://HOST[:PORT]`` / ``mqtts://HOST[:PORT]``, or None."""
    scheme, sep, rest = text.partition("://")
    if not sep or scheme not in ("mqtt", "mqtts"):
        return "expected mqtt://HOST[:PORT] or mqtts://HOST[:PORT]"
    if "@" in rest or "/" in rest.rstrip("/"):
        return "no credentials or path in the URL (use mqtt.username / mqtt.password_file)"
    host, colon, port = rest.rstrip("/").rpartition(":")
    if not colon:
        host, port = rest.rstrip("/"), ""
    if not host:
        return "missing host"
    if port and (not port.isdigit() or not 1 <= int(port) <= 65535):
        return "port must be 1..65535"
    return None


def default_state_dir() -> str:
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return str(Path(base) / "usv")


SETTINGS: tuple[Setting, ...] = (
    Setting("vehicle.profile", "ardurover",
            "MAVLink identity: 'ardurover' (ArduPilot autopilot id and Rover mode numbers, understood "
            "by QGroundControl and MAVSDK today) or 'generic' (MAVLink standard modes only).",
            choices=("ardurover", "generic")),
    Setting("vehicle.state_dir", "",
            "Directory for parameters, missions, logs and the sample log "
            "(empty: $XDG_STATE_HOME/usv or ~/.local/state/usv).",
            accepted="a directory path"),
    Setting("links.udp_targets", ["127.0.0.1:14550", "127.0.0.1:14540"],
            "UDP endpoints the vehicle sends to (QGroundControl listens on 14550, MAVSDK scripts "
            "on 14540).", kind=list, item_check=check_host_port, accepted="a list of 'host:port'"),
    Setting("links.tcp_listen", "127.0.0.1:5760",
            "TCP server address for MAVProxy and other TCP clients ('' disables).",
            item_check=lambda v: None if v == "" else check_host_port(v), accepted="'host:port' or ''"),
    Setting("links.serial", [],
            "Serial telemetry radios, each 'device[:baud]'; a vanished port is retried.",
            kind=list, item_check=check_serial, accepted="a list of 'device[:baud]'"),
    Setting("links.tlog", True, "Write a telemetry log (.tlog) of every link in state_dir/logs.",
            kind=bool),
    Setting("links.tlog_max_files", 50,
            "Most .tlog files kept in state_dir/logs (oldest closed ones deleted first); together with "
            "the USV_TLOG_MAX_MB parameter this bounds the logs a connection flood can leave.",
            kind=int, min=2, max=100_000),
    Setting("security.signing_key_file", "",
            "MAVLink 2 signing key: a file holding 32 bytes as 64 hex characters, readable by its owner "
            "only (chmod 600).  Empty: the key last set by SETUP_SIGNING (state_dir/signing.key), if any.",
            accepted="a file path or ''"),
    Setting("security.require_signing", False,
            "Refuse unsigned, wrongly signed and replayed frames for everything that changes the "
            "vehicle's state (commands, parameter sets, mission writes, manual control, payload "
            "commands); telemetry still flows to every link.  Needs a key.", kind=bool),
    Setting("security.trusted_links", ["serial"],
            "Links on which SETUP_SIGNING may set or change the key: a link kind ('serial', 'tcp', "
            "'udp') or one link ('serial:/dev/ttyACM0').  Name only the USB port on a boat whose "
            "serial ports are radios.", kind=list, accepted="a list of 'serial', 'tcp', 'udp' or 'KIND:NAME'",
            item_check=lambda v: None if v.partition(":")[0] in ("serial", "tcp", "udp") else
            "expected serial, tcp, udp or KIND:NAME"),
    Setting("security.gcs_sysids", [],
            "Ground-station system ids allowed to change the vehicle's state (empty: any); others get "
            "MAV_RESULT_DENIED / MAV_MISSION_DENIED and a STATUSTEXT.", kind=list, item_kind=int,
            accepted="a list of integers 1..255",
            item_check=lambda v: None if 1 <= v <= 255 else "system ids are 1..255"),
    Setting("mqtt.url", "",
            "MQTT broker for dashboards: 'mqtt://HOST[:PORT]' (1883) or 'mqtts://HOST[:PORT]' (TLS, 8883); "
            "empty: no MQTT (nothing needs a broker).",
            accepted="'mqtt://HOST[:PORT]', 'mqtts://HOST[:PORT]' or ''",
            item_check=lambda v: None if v == "" else check_mqtt_url(v)),
    Setting("mqtt.vehicle_id", "",
            "The <vehicle_id> of the topics usv/<vehicle_id>/...; empty: 'usv' and SYSID_THISMAV (usv1).",
            accepted="letters, digits, '-' and '_' (or '')",
            item_check=lambda v: None if v == "" or v.replace("-", "").replace("_", "").isalnum()
            else "only letters, digits, '-' and '_'"),
    Setting("mqtt.username", "", "MQTT user name (empty: connect without credentials)."),
    Setting("mqtt.password_file", "",
            "File holding the MQTT password (first line), readable by its owner only (chmod 600).",
            accepted="a file path or ''"),
    Setting("mqtt.tls_ca_file", "",
            "CA certificate(s) that sign the broker's certificate (mqtts://; empty: the system's CAs).",
            accepted="a file path or ''"),
    Setting("mqtt.tls_cert_file", "", "Client certificate for brokers that want one (mqtts://).",
            accepted="a file path or ''"),
    Setting("mqtt.tls_key_file", "", "Private key of tls_cert_file.", accepted="a file path or ''"),
    Setting("mqtt.tls_insecure", False,
            "Do not check the broker's host name against its certificate (test brokers only).", kind=bool),
    Setting("mqtt.reconnect_max_s", 30.0,
            "Longest wait between reconnection attempts (the wait doubles from 1 s up to this; wall clock).",
            kind=float, min=1.0, max=3600.0),
    Setting("mqtt.commands", False,
            "Accept commands on usv/<vehicle_id>/cmd (off by default).  Needs command_token_file and "
            "a broker user name; only the commands in command_allowlist run.", kind=bool),
    Setting("mqtt.command_token_file", "",
            "File holding the secret every MQTT command must carry as 'token' (first line, at least 16 "
            "characters, chmod 600).", accepted="a file path or ''"),
    Setting("mqtt.command_allowlist", ["RTL", "HOLD", "STOP_PUMP"],
            "Commands accepted over MQTT (a subset of RTL, HOLD, STOP_PUMP).", kind=list,
            accepted="a list of 'RTL', 'HOLD', 'STOP_PUMP'",
            item_check=lambda v: None if v in ("RTL", "HOLD", "STOP_PUMP") else "unknown command"),
    Setting("sensors.gnss_port", "",
            "Serial device of the GPS-INS (XW-GI5630); empty in SITL, where the simulator feeds "
            "the same parser.", accepted="a device path or ''"),
    Setting("sensors.gnss_baud", 115200, "Baud rate of the GPS-INS serial port.", kind=int,
            min=1200, max=4_000_000),
    Setting("servos.port", "", "Serial device of the servo controller; empty in SITL.",
            accepted="a device path or ''"),
    Setting("sim.lockstep", True,
            "SITL: advance physics only after the companion answered (deterministic, fast).",
            kind=bool),
    Setting("sim.speedup", 1.0, "SITL: speed cap relative to real time (0 = as fast as possible).",
            kind=float, min=0.0, max=10000.0),
    Setting("sim.seed", 1, "SITL: random seed of disturbances and sensor noise.", kind=int,
            min=0, max=2**31 - 1),
    Setting("sim.wind", "0,0", "SITL: wind 'SPEED_MPS,FROM_DEG' (meteorological convention).",
            accepted="'SPEED_MPS,FROM_DEG'"),
    Setting("sim.current", "0,0", "SITL: current 'SPEED_MPS,TOWARD_DEG[,VAR]' (oceanographic convention; "
            "VAR 0..1: slowly varying).", accepted="'SPEED_MPS,TOWARD_DEG[,VAR]'"),
    Setting("sim.waves", "0", "SITL: waves 'HS_M[,TP_S]' (significant height, peak period).",
            accepted="'HS_M[,TP_S]'"),
    Setting("sim.home", "41.7700,123.4300,0",
            "SITL: start position 'LAT_DEG,LON_DEG,HEADING_DEG' (default: Shenyang, as in the chapter).",
            accepted="'LAT_DEG,LON_DEG,HEADING_DEG'"),
    Setting("models.params_file", "",
            "Identified qLPV model (params.toml from 'usv identify'); empty: <state_dir>/model/params.toml "
            "if present, else the shipped default identified on the simulator."),
    Setting("models.ukf_noise", "chapter",
            "Noise covariances of the active-model UKF: 'chapter' (Eq. 13, the default) or 'identified' "
            "(the [ukf] table 'usv identify' writes into params.toml; falls back to Eq. 13 without it).",
            choices=("chapter", "identified")),
    Setting("models.ukf", "chapter",
            "Active-model UKF the controller flies on: 'chapter' (Eq. 5-11 on over-ground velocities, "
            "Eq. 13's noise, the default) or 'current' (the qLPV model on water-relative velocities with "
            "the current as two more states, R from the sensor, a fast surge model error; the active-model "
            "law then evaluates the model on water-relative velocities too; set USV_LOS_KI 0 with it).",
            choices=("chapter", "current")),
    Setting("models.current_estimator", "ukf",
            "Water-current estimate for guidance and the ground station (topic 'water_current'): 'ukf' "
            "(the default: the current-augmented filter with slow model-error states runs beside the "
            "controller's) or 'none' (no filter beside it: with models.ukf 'current' the controller "
            "filter's own estimate; with 'chapter' no estimate, and LOITER, GUIDED and RTL hold as before "
            "issue 14).", choices=("ukf", "none")),
    Setting("models.ukf_backend", "native",
            "Who computes the UKF: 'native' (compiled, a few microseconds per sample) or 'filterpy' "
            "(the same equations run by filterpy, about 100 times slower; a reference).",
            choices=("native", "filterpy")),
)

SETTINGS_BY_KEY: dict[str, Setting] = {s.key: s for s in SETTINGS}


@dataclass(frozen=True)
class Config:
    """Validated configuration: setting values by dotted key and initial parameter values."""

    values: Mapping[str, Any]
    params: Mapping[str, float]
    source: str = "<defaults>"

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def state_dir(self) -> Path:
        return Path(self.values["vehicle.state_dir"] or default_state_dir()).expanduser()

    def with_overrides(self, overrides: Mapping[str, Any]) -> Config:
        """A copy with some settings replaced (command-line flags), validated the same way."""
        merged = dict(self.values)
        for key, value in overrides.items():
            merged[key] = _setting(key).validate(value)
        return Config(merged, self.params, self.source)


def _setting(key: str) -> Setting:
    try:
        return SETTINGS_BY_KEY[key]
    except KeyError:
        section = key.partition(".")[0]
        known = sorted(k for k in SETTINGS_BY_KEY if k.startswith(section + "."))
        hint = f"; known keys in [{section}]: {', '.join(known)}" if known else (
            f"; known sections: {', '.join(sorted({k.partition('.')[0] for k in SETTINGS_BY_KEY}))}, params")
        raise ConfigError(f"unknown config key {key!r}{hint}") from None


def default_config() -> Config:
    return Config({s.key: s.default for s in SETTINGS}, {})


def parse_config(data: Mapping[str, Any], param_defs: Iterable[ParamDef], source: str = "<dict>") -> Config:
    """Validate a TOML document (already parsed) into a :class:`Config`."""
    values = {s.key: s.default for s in SETTINGS}
    params: dict[str, float] = {}
    defs = {d.name: d for d in param_defs}
    for section, table in data.items():
        if section == "params":
            if not isinstance(table, dict):
                raise ConfigError("params: expected a table of NAME = value")
            for name, value in table.items():
                if name not in defs:
                    raise ConfigError(f"unknown parameter params.{name} (see `usv params`)")
                try:
                    params[name] = defs[name].validate(value)
                except ParamError as exc:
                    raise ConfigError(f"params.{exc}") from None
            continue
        if not isinstance(table, dict):
            _setting(section)  # raises with the list of sections
            raise ConfigError(f"{section}: expected a table")
        for name, value in table.items():
            key = f"{section}.{name}"
            values[key] = _setting(key).validate(value)
    return Config(values, params, source)


def load_config(path: Path | None, param_defs: Iterable[ParamDef]) -> Config:
    """Read and validate a TOML configuration file (``None``: embedded SITL defaults)."""
    if path is None:
        return parse_config({}, param_defs)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read config file {path}: {exc.strerror or exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    return parse_config(data, param_defs, str(path))
