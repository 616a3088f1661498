"""The command registry: COMMAND_LONG / COMMAND_INT id -> async handler.

Each vehicle has one :class:`CommandRegistry` (built by :mod:`companion.runtime`); the vehicle's
own commands (:mod:`companion.mavlink.vehicle_commands`) and every payload's
(:mod:`companion.payloads.registry`) are registered on it.  A handler is a coroutine function of
the request, bound to the objects it needs::

    async def fire(cmd: CommandRequest) -> CommandResult:
        if not launcher.vehicle_armed():
            return CommandResult.denied("launcher: vehicle not armed")
        cmd.progress(50)                         # sends COMMAND_ACK IN_PROGRESS, progress 50 %
        ...
        return CommandResult.accepted()

    registry.register(31011, fire, name="USV_LAUNCHER_FIRE")

The command service (:mod:`companion.mavlink.command_service`) answers every command with
exactly one final COMMAND_ACK: handlers returning after more than a moment are preceded by
IN_PROGRESS acks; an unknown id gets UNSUPPORTED; a NaN in a parameter the handler declared
required, or a handler's :meth:`CommandResult.denied`, gets DENIED plus a STATUSTEXT with
the reason; a handler that raises gets FAILED (the process never dies from a command).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

log = logging.getLogger(__name__)


class MAV_RESULT:
    """MAV_RESULT values (COMMAND_ACK.result)."""

    ACCEPTED = 0
    TEMPORARILY_REJECTED = 1
    DENIED = 2
    UNSUPPORTED = 3
    FAILED = 4
    IN_PROGRESS = 5
    CANCELLED = 6


@dataclass(slots=True)
class CommandRequest:
    """One received COMMAND_LONG or COMMAND_INT.

    ``params`` are param1..param7.  For COMMAND_INT, ``params[4]``/``params[5]`` hold the
    raw int32 x/y (degrees x 1e7 in global frames); use :attr:`lat_deg`/:attr:`lon_deg`,
    which decode both encodings.
    """

    command: int
    params: tuple[float, float, float, float, float, float, float]
    is_int: bool = False
    frame: int = 0
    source_system: int = 255
    source_component: int = 0
    confirmation: int = 0
    link: Any = field(default=None, repr=False)
    """The link the command arrived on (reply-to for REQUEST_MESSAGE and friends)."""
    progress_cb: Callable[[int], None] | None = field(default=None, repr=False)

    @property
    def param1(self) -> float:
        return self.params[0]

    @property
    def param2(self) -> float:
        return self.params[1]

    @property
    def param3(self) -> float:
        return self.params[2]

    @property
    def param4(self) -> float:
        return self.params[3]

    @property
    def param5(self) -> float:
        return self.params[4]

    @property
    def param6(self) -> float:
        return self.params[5]

    @property
    def param7(self) -> float:
        return self.params[6]

    @property
    def lat_deg(self) -> float:
        """Latitude in degrees from param5 (x) of either command encoding."""
        return self.params[4] / 1e7 if self.is_int else self.params[4]

    @property
    def lon_deg(self) -> float:
        """Longitude in degrees from param6 (y) of either command encoding."""
        return self.params[5] / 1e7 if self.is_int else self.params[5]

    def progress(self, percent: int) -> None:
        """Send COMMAND_ACK(IN_PROGRESS, progress=percent) to the sender now."""
        if self.progress_cb is not None:
            self.progress_cb(max(0, min(100, int(percent))))

    def nan_params(self, required: tuple[int, ...]) -> list[int]:
        """Which of the 1-based ``required`` params are NaN or infinite."""
        return [i for i in required if not math.isfinite(self.params[i - 1])]


@dataclass(frozen=True, slots=True)
class CommandResult:
    """A handler's answer: MAV_RESULT, a reason for the operator, optional result_param2."""

    result: int
    reason: str = ""
    result_param2: int = 0
    after_ack: Callable[[], None] | None = field(default=None, compare=False, repr=False)
    """Run right after the COMMAND_ACK is sent (REQUEST_MESSAGE: the message follows its ack)."""

    @classmethod
    def accepted(cls, reason: str = "") -> CommandResult:
        return cls(MAV_RESULT.ACCEPTED, reason)

    @classmethod
    def denied(cls, reason: str) -> CommandResult:
        return cls(MAV_RESULT.DENIED, reason)

    @classmethod
    def failed(cls, reason: str) -> CommandResult:
        return cls(MAV_RESULT.FAILED, reason)

    @classmethod
    def unsupported(cls, reason: str = "") -> CommandResult:
        return cls(MAV_RESULT.UNSUPPORTED, reason)

    @classmethod
    def temporarily_rejected(cls, reason: str) -> CommandResult:
        return cls(MAV_RESULT.TEMPORARILY_REJECTED, reason)


CommandHandler = Callable[[CommandRequest], Awaitable[CommandResult]]


@dataclass(frozen=True, slots=True)
class CommandSpec:
    """A registered command: its handler and the params that must be finite numbers."""

    command: int
    handler: CommandHandler
    required_params: tuple[int, ...] = ()
    name: str = ""


class CommandRegistry:
    """Command id -> :class:`CommandSpec`."""

    def __init__(self) -> None:
        self._specs: dict[int, CommandSpec] = {}

    def register(self, command: int, handler: CommandHandler, *, required_params: tuple[int, ...] = (),
                 name: str = "") -> None:
        """Register (or replace) the handler of ``command``.

        ``required_params``: 1-based params that must be finite; NaN there is DENIED before
        the handler runs.
        """
        if not 0 <= int(command) <= 65535:
            raise ValueError(f"command id {command} outside 0..65535")
        old = self._specs.get(int(command))
        if old is not None and old.handler is not handler:
            log.debug("command %d: handler %s replaced by %s", command, old.handler, handler)
        self._specs[int(command)] = CommandSpec(int(command), handler, tuple(required_params),
                                                name or getattr(handler, "__name__", str(command)))

    def get(self, command: int) -> CommandSpec | None:
        return self._specs.get(int(command))

    def __contains__(self, command: object) -> bool:
        return command in self._specs

    def commands(self) -> list[int]:
        return sorted(self._specs)
