"""The payload registry: what a payload declares and how the vehicle takes it in.

A payload is ONE module (or package) that defines ``PAYLOAD``, a :class:`PayloadDef`: its
parameters and a ``build(env)`` that creates its device objects and returns a :class:`Payload`
declaring everything the vehicle needs from it:

* ``commands`` -- MAVLink commands (COMMAND_LONG/INT id, handler, required params);
* ``mission_actions`` -- mission items AUTO runs through it, with their upload checks
  (:class:`~companion.modes.auto_items.MissionAction`);
* ``servo_channels`` -- the outputs it drives (the ``USV_CH_*`` parameter naming the output, its
  function for refusals, and the pulse it wants now); these outputs are autopilot-owned, so
  DO_SET_SERVO/DO_SET_RELAY cannot touch them;
* ``status`` -- telemetry messages it streams (id, builder, default rate, data-stream group);
* ``sentences`` -- sentences of the hardware seam it parses (the GPS-INS box relays them);
* ``dialect`` -- the dialect entries its commands and messages use, already in the shipped
  ``usv.xml`` or given as an XML fragment the registry merges in (:meth:`PayloadRegistry.dialect_xml`).

:func:`built_in_payloads` finds the payloads of this package (every module here defining
``PAYLOAD``: the rope launcher and the water sampler), so adding a payload edits nothing else;
:mod:`companion.runtime` can be given more (a test fixture).  :class:`PayloadRegistry` builds
them in order, checks that every declared command and message has its dialect entry, and stops
them (outputs safe) when the companion stops.
"""

from __future__ import annotations

import importlib
import logging
import pkgutil
import xml.etree.ElementTree as ET
from collections.abc import Awaitable, Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

from companion.actuators.servo import ServoChannel
from companion.app import BaseService, Context
from companion.mavlink.commands import CommandHandler, CommandRegistry
from companion.messages import STATUS_TEXT_TOPIC, Severity, StatusText
from companion.params import ParamDef
from companion.payloads.samplelog import SAMPLE_LOG_NAME, SampleLog
from companion.payloads.topics import PayloadOutputs

if TYPE_CHECKING:
    from companion.modes.auto_items import MissionAction

__all__ = ["DialectEntries", "Payload", "PayloadCommandDecl", "PayloadDef", "PayloadEnv",
           "PayloadError", "PayloadRegistry", "ServoChannel", "StatusMessage", "built_in_payloads"]

log = logging.getLogger(__name__)
T = TypeVar("T")

STATUSTEXT_CHARS = 50
"""Payload announcements are cut to one STATUSTEXT chunk."""
EXTRA3_STREAM = 12
"""MAV_DATA_STREAM_EXTRA3, the REQUEST_DATA_STREAM group of status messages (as ArduPilot)."""


class PayloadError(ValueError):
    """A payload declaration is inconsistent (e.g. a command without its dialect entry)."""


@dataclass(frozen=True)
class PayloadCommandDecl:
    """One MAVLink command of a payload."""

    command: int
    handler: CommandHandler
    name: str
    required_params: tuple[int, ...] = ()


@dataclass(frozen=True)
class StatusMessage:
    """One telemetry message of a payload, built from ``time_boot_ms``."""

    msg_id: int
    build: Callable[[int], Any]
    rate_hz: float = 1.0
    stream_group: int = EXTRA3_STREAM


SentenceHandler = Callable[[list[str]], None]
"""Handles the comma-separated fields of one checked sentence (``fields[0]`` is its name)."""


@dataclass(frozen=True)
class DialectEntries:
    """The dialect entries a payload uses: USV_CMD entry name by command id, message name by id,
    and ``xml``, a ``<mavlink>`` fragment with the ones the shipped ``usv.xml`` lacks."""

    commands: Mapping[int, str] = field(default_factory=dict)
    messages: Mapping[int, str] = field(default_factory=dict)
    xml: str = ""


@dataclass(frozen=True)
class Payload:
    """Everything one built payload contributes to the vehicle."""

    name: str
    device: Any = None
    """The payload's own object (for tests and tools)."""
    commands: tuple[PayloadCommandDecl, ...] = ()
    mission_actions: tuple[MissionAction, ...] = ()
    servo_channels: tuple[ServoChannel, ...] = ()
    status: tuple[StatusMessage, ...] = ()
    sentences: Mapping[str, SentenceHandler] = field(default_factory=dict)
    dialect: DialectEntries = field(default_factory=DialectEntries)
    stop: Callable[[], Awaitable[None]] | None = None
    """Make the payload safe when the companion stops."""


@dataclass(frozen=True)
class PayloadEnv:
    """What a payload is built with: the context, the durable sample log, the launcher/sampler
    outputs topic (``payload_cmd``), and a way to tell the operator."""

    ctx: Context
    samplelog: SampleLog
    outputs: PayloadOutputs

    def announce(self, text: str, severity: Severity = Severity.INFO) -> None:
        """A STATUSTEXT for the operator (one chunk)."""
        self.ctx.bus.topic(STATUS_TEXT_TOPIC).publish(
            StatusText(t_s=self.ctx.clock.now_s(), severity=severity, text=text[:STATUSTEXT_CHARS]))


@dataclass(frozen=True)
class PayloadDef:
    """A payload module's declaration: ``PAYLOAD = PayloadDef("name", PARAMS, build)``."""

    name: str
    params: tuple[ParamDef, ...]
    build: Callable[[PayloadEnv], Payload]


def built_in_payloads() -> tuple[PayloadDef, ...]:
    """Every module of :mod:`companion.payloads` that defines ``PAYLOAD``, by module name."""
    import companion.payloads as package

    found: list[PayloadDef] = []
    for info in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{package.__name__}.{info.name}")
        definition = getattr(module, "PAYLOAD", None)
        if isinstance(definition, PayloadDef):
            found.append(definition)
    return tuple(found)


def payload_params(payloads: Iterable[PayloadDef]) -> tuple[ParamDef, ...]:
    return tuple(p for payload in payloads for p in payload.params)


class PayloadRegistry(BaseService):
    """The payloads of one vehicle (service ``payloads``: makes them safe on shutdown)."""

    name = "payloads"

    def __init__(self, ctx: Context, definitions: Sequence[PayloadDef]) -> None:
        self.ctx = ctx
        self.samplelog = SampleLog(ctx.config.state_dir() / SAMPLE_LOG_NAME)
        self.outputs = PayloadOutputs(ctx.bus, ctx.clock)
        env = PayloadEnv(ctx, self.samplelog, self.outputs)
        self.payloads: tuple[Payload, ...] = tuple(d.build(env) for d in definitions)
        self._dialect = merged_dialect(p.dialect.xml for p in self.payloads)
        for payload in self.payloads:
            check_dialect(payload, self._dialect)

    def device(self, name: str) -> Any:
        """The device object of payload ``name`` (``LookupError`` if there is none)."""
        for payload in self.payloads:
            if payload.name == name:
                return payload.device
        raise LookupError(f"no payload {name!r} on this vehicle")

    def find(self, kind: type[T]) -> T | None:
        """The device of type ``kind`` (e.g. the sampler), or ``None`` if this vehicle has none."""
        return next((p.device for p in self.payloads if isinstance(p.device, kind)), None)

    def register_commands(self, registry: CommandRegistry) -> None:
        for payload in self.payloads:
            for c in payload.commands:
                registry.register(c.command, c.handler, required_params=c.required_params, name=c.name)

    @property
    def mission_actions(self) -> dict[int, MissionAction]:
        return {a.command: a for payload in self.payloads for a in payload.mission_actions}

    @property
    def servo_channels(self) -> tuple[ServoChannel, ...]:
        return tuple(ch for payload in self.payloads for ch in payload.servo_channels)

    @property
    def status_messages(self) -> tuple[StatusMessage, ...]:
        return tuple(s for payload in self.payloads for s in payload.status)

    @property
    def sentences(self) -> dict[str, SentenceHandler]:
        return {name: h for payload in self.payloads for name, h in payload.sentences.items()}

    def dialect_xml(self) -> str:
        """The shipped ``usv.xml`` with every payload's fragment merged in (for MAVSDK's
        ``mavlink_direct.load_custom_xml`` or mavgen)."""
        return ET.tostring(self._dialect, encoding="unicode")

    async def stop(self) -> None:
        for payload in reversed(self.payloads):
            if payload.stop is not None:
                try:
                    await payload.stop()
                except Exception:
                    log.exception("stopping payload %s failed", payload.name)
        self.samplelog.close()


def merged_dialect(fragments: Iterable[str]) -> ET.Element:
    """``usv.xml`` with the enum entries and messages of ``fragments`` added."""
    from mavlink_dialect import xml_text

    root = ET.fromstring(xml_text())
    for fragment in fragments:
        if not fragment.strip():
            continue
        extra = ET.fromstring(fragment)
        for enum in extra.iter("enum"):
            target = next((e for e in root.iter("enum") if e.get("name") == enum.get("name")), None)
            if target is None:
                enums = root.find("enums")
                assert enums is not None
                enums.append(enum)
            else:
                target.extend(list(enum.iter("entry")))
        messages = root.find("messages")
        assert messages is not None
        messages.extend(list(extra.iter("message")))
    return root


def check_dialect(payload: Payload, dialect: ET.Element) -> None:
    """Every command and message ``payload`` declares has a dialect entry of the same id and name."""
    entries = {int(e.get("value", "-1")): e.get("name") for enum in dialect.iter("enum")
               if enum.get("name") == "USV_CMD" for e in enum.iter("entry")}
    messages = {int(m.get("id", "-1")): m.get("name") for m in dialect.iter("message")}
    for command, name in payload.dialect.commands.items():
        if entries.get(command) != name:
            raise PayloadError(f"payload {payload.name}: command {command} {name} is not in USV_CMD")
    for msg_id, name in payload.dialect.messages.items():
        if messages.get(msg_id) != name:
            raise PayloadError(f"payload {payload.name}: message {msg_id} {name} is not in the dialect")
    for decl in payload.commands:
        if decl.command not in payload.dialect.commands:
            raise PayloadError(f"payload {payload.name}: command {decl.command} has no dialect entry")
    for action in payload.mission_actions:
        if action.command not in payload.dialect.commands:
            raise PayloadError(f"payload {payload.name}: mission item {action.command} has no dialect entry")
    for status in payload.status:
        if status.msg_id not in payload.dialect.messages:
            raise PayloadError(f"payload {payload.name}: message {status.msg_id} has no dialect entry")
