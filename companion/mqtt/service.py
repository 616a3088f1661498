"""The MQTT service: an aiomqtt client beside the MAVLink service, observing the vehicle.

Life cycle (``run``), in aiomqtt's documented reconnection style: connect inside ``async with
client``; on :class:`aiomqtt.MqttError` (broker away, connection lost) wait and connect again,
the wait doubling from 1 s up to ``mqtt.reconnect_max_s`` (wall clock: the broker lives in wall
time) and back to 1 s after a successful connection.  While connected, three tasks run:

* **state** -- every state topic at its rate (:mod:`.params`, vehicle clock, so rates hold in
  simulated time at any ``--speedup``), QoS 0, retained; ``status`` also at once on a change of
  mode or arming.  The document is built when it is due (:class:`~.snapshot.StateSnapshot`),
  so nothing piles up while the broker is away: the latest state wins.
* **records** -- the outbox (:mod:`.outbox`), fed by :class:`~.records.RecordFeed` (sample log
  polled every :data:`RECORD_POLL_S`; failsafe events at once), published with QoS 1 one at a
  time, each marked delivered after its PUBACK.
* **commands** -- only with ``mqtt.commands``: ``usv/<id>/cmd`` answered on ``usv/<id>/cmd/reply``.

``online`` is retained ``{"online": true}`` after each connection; the broker publishes the
last will ``{"online": false}`` when the companion vanishes.  :attr:`MqttService.stats` counts
publications, their cost (wall microseconds spent building, encoding and handing over state
documents) and reconnections, for ``usv bench --only mqtt``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Protocol

import aiomqtt

from companion.app import BaseService, Context
from companion.messages import VEHICLE_STATUS_TOPIC, VehicleStatus
from companion.mqtt.commands import MqttCommands
from companion.mqtt.outbox import Outbox, OutboxEntry
from companion.mqtt.records import RecordFeed
from companion.mqtt.settings import MqttSettings
from companion.mqtt.snapshot import StateSnapshot
from companion.mqtt.topics import (
    COMMAND_TOPIC,
    ONLINE_TOPIC,
    RATE_PARAM,
    RECORD_QOS,
    REPLY_TOPIC,
    STATE_QOS,
    RecordTopic,
    StateTopic,
    encode,
    record_topic,
    topic,
)

log = logging.getLogger(__name__)

IDLE_S = 0.1
"""Longest the state loop sleeps (vehicle clock): a change of mode is published within this."""
MIN_SLEEP_S = 0.01
RECORD_POLL_S = 1.0
"""How often the sample log is read for new records (vehicle clock)."""
PUBACK_TIMEOUT_S = 10.0
"""Wall seconds to wait for the broker's PUBACK before the connection is given up."""
MAX_QUEUED_OUTGOING = 64
"""Bound on the client library's own queue of unsent messages."""
FIRST_RETRY_S = 1.0


def _raise_if_cancelled() -> None:
    """Raise CancelledError if this task is being cancelled.

    Python 3.11's ``asyncio.wait_for`` (which aiomqtt uses to wait for a publication) can swallow
    a cancellation that arrives as the awaited operation completes; every loop here checks, so
    stopping the companion never hangs on the MQTT service."""
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError


class MqttClient(Protocol):
    """What the service uses of :class:`aiomqtt.Client` (a fake in unit tests)."""

    async def __aenter__(self) -> Any: ...

    async def __aexit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                        tb: TracebackType | None) -> Any: ...

    async def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False, *,
                      timeout: float | None = None) -> None: ...

    async def subscribe(self, topic: str, qos: int = 0) -> Any: ...

    @property
    def messages(self) -> Any: ...


@dataclass
class MqttStats:
    """What the service did (for the bench, the tests and the log)."""

    connects: int = 0
    connect_failures: int = 0
    state_published: int = 0
    state_cost_us: float = 0.0
    """Wall microseconds spent building, encoding and handing over state documents."""
    records_published: int = 0
    commands: int = 0
    by_topic: dict[str, int] = field(default_factory=dict)


def aiomqtt_client(settings: MqttSettings) -> MqttClient:
    """The real client for ``settings`` (credentials, TLS, last will, bounded queue)."""
    will = aiomqtt.Will(topic(settings.vehicle_id, ONLINE_TOPIC), encode({"online": False, "t_unix_s": None}),
                        qos=1, retain=True)
    client: MqttClient = aiomqtt.Client(
        settings.host, settings.port, username=settings.username, password=settings.password,
        identifier=f"usv-companion-{settings.vehicle_id}", will=will, tls_context=settings.tls_context(),
        tls_insecure=settings.tls_insecure if settings.tls else None, timeout=PUBACK_TIMEOUT_S, keepalive=10,
        max_queued_outgoing_messages=MAX_QUEUED_OUTGOING)
    return client


class MqttService(BaseService):
    """Publishes the vehicle's state, records and events to an MQTT broker; optional commands."""

    name = "mqtt"

    def __init__(self, ctx: Context, settings: MqttSettings, snapshot: StateSnapshot, outbox: Outbox,
                 feed: RecordFeed, commands: MqttCommands | None = None,
                 client_factory: Callable[[MqttSettings], MqttClient] = aiomqtt_client) -> None:
        self.ctx = ctx
        self.settings = settings
        self.snapshot = snapshot
        self.outbox = outbox
        self.feed = feed
        self.commands = commands
        self.client_factory = client_factory
        self.stats = MqttStats()
        self.connected = False
        self._next_due_s: dict[StateTopic, float] = {}
        self._status_changed = False
        self._records_waiting = asyncio.Event()
        feed.on_added = self._records_waiting.set
        self._remove_listener = ctx.bus.topic(VEHICLE_STATUS_TOPIC).add_listener(self._on_vehicle_status)

    def _on_vehicle_status(self, _status: VehicleStatus) -> None:
        self._status_changed = True

    async def stop(self) -> None:
        self._remove_listener()
        self.feed.close()
        self.outbox.close()

    # -- connection ------------------------------------------------------------------------
    async def run(self) -> None:
        wait_s = FIRST_RETRY_S
        while True:
            # one connection in a task of its own: this task then hosts no TaskGroup, so its
            # cancelling() count is exact (Python 3.11's TaskGroup can leave its parent's count
            # raised after a child failed) and tells a stop from a lost connection
            session = asyncio.create_task(self._session(), name="mqtt-session")
            try:
                connected = await session
            finally:
                if not session.done():
                    session.cancel()
                    await asyncio.gather(session, return_exceptions=True)
            _raise_if_cancelled()  # a stop that the closing client turned into an MqttError
            if connected:
                wait_s = FIRST_RETRY_S
            await asyncio.sleep(wait_s)
            wait_s = min(2.0 * wait_s, self.settings.reconnect_max_s)

    async def _session(self) -> bool:
        """Connect, publish until the connection ends; whether it connected at all."""
        connected = False
        try:
            async with self.client_factory(self.settings) as client:
                self.connected = connected = True
                self.stats.connects += 1
                log.info("MQTT connected to %s as usv/%s", self.settings.url, self.settings.vehicle_id)
                await self._connected(client)
        except* aiomqtt.MqttError as group:
            self._lost(group.exceptions[0], connected)
        except* Exception:  # MQTT must never take the boat down: log, and connect again
            log.exception("MQTT service error; reconnecting")
        finally:
            self.connected = False
        return connected

    def _lost(self, exc: BaseException, was_connected: bool) -> None:
        if was_connected:
            log.warning("MQTT connection to %s lost (%s); reconnecting", self.settings.url, exc)
        else:
            self.stats.connect_failures += 1
            log.info("MQTT broker %s not reachable (%s); trying again", self.settings.url, exc)

    async def _connected(self, client: MqttClient) -> None:
        vid = self.settings.vehicle_id
        await client.publish(topic(vid, ONLINE_TOPIC), encode(
            {"online": True, "t_unix_s": round(self.ctx.clock.unix_time_s(), 3)}), qos=1, retain=True)
        _raise_if_cancelled()
        self._next_due_s.clear()
        self._status_changed = True
        async with asyncio.TaskGroup() as tg:
            tg.create_task(self._state_loop(client), name="mqtt-state")
            tg.create_task(self._record_loop(client), name="mqtt-records")
            if self.commands is not None:
                await client.subscribe(topic(vid, COMMAND_TOPIC), qos=1)
                tg.create_task(self._command_loop(client), name="mqtt-commands")

    # -- state topics ----------------------------------------------------------------------
    async def _state_loop(self, client: MqttClient) -> None:
        clock = self.ctx.clock
        while True:
            now_s = clock.now_s()
            for which in self.due(now_s):
                await self._publish_state(client, which)
                _raise_if_cancelled()
            await clock.sleep(self._sleep_s(clock.now_s()))

    def due(self, now_s: float) -> list[StateTopic]:
        """The state topics to publish now (each rescheduled one period later; ``status`` also
        when the mode or arming changed)."""
        due: list[StateTopic] = []
        for which, param in RATE_PARAM.items():
            rate_hz = self.ctx.params.get(param)
            if rate_hz <= 0.0:
                self._next_due_s.pop(which, None)
                continue
            next_s = self._next_due_s.get(which)
            changed = which is StateTopic.STATUS and self._status_changed
            if next_s is None or now_s >= next_s - 1e-9 or changed:
                due.append(which)
                period_s = 1.0 / rate_hz
                # no drift, but no burst after a stall: the next slot after now
                base_s = now_s if next_s is None or changed or now_s - next_s > period_s else next_s
                self._next_due_s[which] = base_s + period_s
        if StateTopic.STATUS in due:
            self._status_changed = False
        return due

    def _sleep_s(self, now_s: float) -> float:
        wake_s = min(self._next_due_s.values(), default=now_s + IDLE_S)
        return min(IDLE_S, max(MIN_SLEEP_S, wake_s - now_s))

    async def _publish_state(self, client: MqttClient, which: StateTopic) -> None:
        t0 = time.perf_counter()
        document = self.snapshot.document(which)
        if document is None:
            return
        payload = encode(document)
        publish = client.publish(topic(self.settings.vehicle_id, which.value), payload, qos=STATE_QOS,
                                 retain=True)
        self.stats.state_cost_us += 1e6 * (time.perf_counter() - t0)
        await publish
        self.stats.state_published += 1
        self.stats.by_topic[which.value] = self.stats.by_topic.get(which.value, 0) + 1

    # -- records ---------------------------------------------------------------------------
    async def _record_loop(self, client: MqttClient) -> None:
        clock = self.ctx.clock
        while True:
            self.feed.poll()
            while batch := self.outbox.pending():
                for entry in batch:
                    await self._publish_record(client, entry)
                    _raise_if_cancelled()
            self._records_waiting.clear()
            sleeper = asyncio.ensure_future(clock.sleep(RECORD_POLL_S))
            waiter = asyncio.ensure_future(self._records_waiting.wait())
            try:
                await asyncio.wait({sleeper, waiter}, return_when=asyncio.FIRST_COMPLETED)
            finally:
                sleeper.cancel()
                waiter.cancel()

    async def _publish_record(self, client: MqttClient, entry: OutboxEntry) -> None:
        kind = RecordTopic(entry.kind)
        name = record_topic(self.settings.vehicle_id, kind, str(entry.source_id))
        await client.publish(name, entry.payload, qos=RECORD_QOS, retain=True, timeout=PUBACK_TIMEOUT_S)
        self.outbox.mark_delivered(entry.record_id, self.ctx.clock.unix_time_s())
        self.stats.records_published += 1
        self.stats.by_topic[kind.value] = self.stats.by_topic.get(kind.value, 0) + 1

    # -- commands --------------------------------------------------------------------------
    async def _command_loop(self, client: MqttClient) -> None:
        assert self.commands is not None
        reply_topic = topic(self.settings.vehicle_id, REPLY_TOPIC)
        async for message in client.messages:
            payload = message.payload if isinstance(message.payload, bytes) else str(message.payload).encode()
            self.stats.commands += 1
            reply = self.commands.handle(payload, self.ctx.clock.unix_time_s())
            log.info("MQTT command %s: %s %s", reply["command"], reply["result"], reply["reason"])
            with contextlib.suppress(TimeoutError):
                await client.publish(reply_topic, encode(reply), qos=RECORD_QOS, timeout=PUBACK_TIMEOUT_S)
            _raise_if_cancelled()
