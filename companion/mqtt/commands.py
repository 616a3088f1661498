"""Commands over MQTT: off by default; authenticated and allowlisted when on.

A dashboard sends ``{"id": "42", "command": "RTL", "token": "<secret>"}`` to
``usv/<vehicle_id>/cmd`` and gets ``{"id": "42", "command": "RTL", "result": "accepted",
"reason": "", ...}`` on ``usv/<vehicle_id>/cmd/reply``.  Three layers guard the boat:

1. commands are only subscribed to with ``mqtt.commands = true``, which needs an authenticated
   broker connection (user name and password) and a command token file (:mod:`.settings`);
2. every command carries the token, compared in constant time (``hmac.compare_digest``): a
   wrong or missing one is answered ``unauthorized`` and nothing happens;
3. only the commands in ``mqtt.command_allowlist`` run (default RTL, HOLD, STOP_PUMP); the
   others are answered ``denied``.

RTL and HOLD go through the same :meth:`~companion.vehicle.Vehicle.set_mode` as a MAVLink
SET_MODE (a refusal is answered ``failed`` with the vehicle's reason and announced as a
STATUSTEXT); STOP_PUMP stops the sampler's pump at once (a running sample ends ``aborted``).
Bad JSON or an unknown command is answered ``invalid``; nothing here raises.
"""

from __future__ import annotations

import enum
import hmac
import json
from collections.abc import Callable
from typing import Any

from companion.messages import ModeNumber, Severity
from companion.mqtt.settings import MqttCommand, MqttSettings

MAX_COMMAND_BYTES = 1024
MAX_ID_CHARS = 64


class CommandResult(enum.StrEnum):
    """The ``result`` of a reply."""

    ACCEPTED = "accepted"
    FAILED = "failed"
    DENIED = "denied"
    UNAUTHORIZED = "unauthorized"
    INVALID = "invalid"


class CommandTarget:
    """What the commands act on: the vehicle's mode switch, the pump, the operator's messages."""

    def __init__(self, set_mode: Callable[[int], str | None], stop_pump: Callable[[], bool] | None,
                 announce: Callable[[str, Severity], None]) -> None:
        self.set_mode = set_mode
        self.stop_pump = stop_pump
        self.announce = announce


class MqttCommands:
    """Checks and runs one command message; returns the reply document."""

    def __init__(self, settings: MqttSettings, target: CommandTarget) -> None:
        self.settings = settings
        self.target = target

    def handle(self, payload: bytes, now_unix_s: float) -> dict[str, Any]:
        reply: dict[str, Any] = {"id": None, "command": None, "result": CommandResult.INVALID.value,
                                 "reason": "", "t_unix_s": round(now_unix_s, 3)}
        if len(payload) > MAX_COMMAND_BYTES:
            reply["reason"] = f"command longer than {MAX_COMMAND_BYTES} bytes"
            return reply
        try:
            message = json.loads(payload)
        except (UnicodeDecodeError, ValueError):
            reply["reason"] = "not JSON"
            return reply
        if not isinstance(message, dict):
            reply["reason"] = "expected a JSON object"
            return reply
        ident, name, token = message.get("id"), message.get("command"), message.get("token")
        reply["id"] = ident[:MAX_ID_CHARS] if isinstance(ident, str) else None
        reply["command"] = name[:MAX_ID_CHARS] if isinstance(name, str) else None
        expected = self.settings.command_token
        if (not self.settings.commands_enabled or expected is None or not isinstance(token, str)
                or not hmac.compare_digest(token.encode(), expected.encode())):
            reply["result"], reply["reason"] = CommandResult.UNAUTHORIZED.value, "missing or wrong token"
            return reply
        try:
            command = MqttCommand(str(name))
        except ValueError:
            reply["reason"] = f"unknown command (known: {', '.join(c.value for c in MqttCommand)})"
            return reply
        if command not in self.settings.command_allowlist:
            reply["result"], reply["reason"] = CommandResult.DENIED.value, "not in mqtt.command_allowlist"
            return reply
        problem = self._run(command)
        reply["result"] = CommandResult.FAILED.value if problem else CommandResult.ACCEPTED.value
        reply["reason"] = problem or ""
        if problem:
            self.target.announce(f"MQTT {command.value} refused: {problem}"[:50], Severity.WARNING)
        else:
            self.target.announce(f"MQTT command {command.value}", Severity.INFO)
        return reply

    def _run(self, command: MqttCommand) -> str | None:
        if command is MqttCommand.RTL:
            return self.target.set_mode(ModeNumber.RTL)
        if command is MqttCommand.HOLD:
            return self.target.set_mode(ModeNumber.HOLD)
        if self.target.stop_pump is None:
            return "no sampler on this vehicle"
        self.target.stop_pump()
        return None
