"""Unit tests of the MQTT service against a fake client (one part alone, simulated clock).

The real broker, the real ``usv sitl`` process and a real subscriber are in
``test_mqtt_sitl.py``."""

from __future__ import annotations

import asyncio
import itertools
import json
from pathlib import Path
from typing import Any

import aiomqtt
import pytest

import companion.mqtt.service as service_module
from companion.clock import SimClock
from companion.config import default_config
from companion.messages import STATUS_TEXT_TOPIC, ModeNumber, Severity, StatusText
from companion.mqtt.commands import CommandTarget, MqttCommands
from companion.mqtt.outbox import Outbox
from companion.mqtt.records import RecordFeed
from companion.mqtt.service import MqttService
from companion.mqtt.settings import MqttCommand, MqttSettings
from companion.mqtt.topics import StateTopic
from companion.payloads.samplelog import SampleLog
from companion.runtime import build_context

TOKEN = "0123456789abcdef-token"


class FakeClient:
    """Records publications; ``fail_connects`` connection attempts fail first; ``fail_publish``
    makes QoS 1 publications fail (a broker that vanished mid-flight)."""

    def __init__(self, world: dict[str, Any]) -> None:
        self.world = world
        self.inbox: asyncio.Queue[Any] = asyncio.Queue()
        world["clients"].append(self)

    async def __aenter__(self) -> FakeClient:
        if self.world["fail_connects"] > 0:
            self.world["fail_connects"] -= 1
            raise aiomqtt.MqttError("connection refused")
        return self

    async def __aexit__(self, *exc: object) -> None:
        return None

    async def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False, *,
                      timeout: float | None = None) -> None:
        if qos == 1 and self.world["fail_publish"]:
            raise aiomqtt.MqttError("connection lost")
        self.world["published"].append((topic, json.loads(payload), qos, retain))

    async def subscribe(self, topic: str, qos: int = 0) -> None:
        self.world["subscribed"].append(topic)

    @property
    def messages(self) -> Any:
        async def iterate() -> Any:
            while True:
                yield await self.inbox.get()
        return iterate()


class FakeSnapshot:
    def __init__(self, clock: SimClock) -> None:
        self.clock = clock

    def document(self, which: StateTopic) -> dict[str, Any] | None:
        return {"t_s": self.clock.now_s(), "topic": which.value}


async def _advance(clock: SimClock, seconds: float, step_s: float = 0.01) -> None:
    for _ in range(round(seconds / step_s)):
        clock.advance_to(clock.now_s() + step_s)
        for _ in range(3):
            await asyncio.sleep(0)


def _world() -> dict[str, Any]:
    return {"clients": [], "published": [], "subscribed": [], "fail_connects": 0, "fail_publish": False}


def _service(tmp_path: Path, world: dict[str, Any], commands: MqttCommands | None = None
             ) -> tuple[MqttService, SimClock, SampleLog]:
    clock = SimClock(start_unix_time_s=1.7e9)
    ctx = build_context(default_config().with_overrides({"vehicle.state_dir": str(tmp_path)}), clock)
    settings = MqttSettings(host="h", port=1883, tls=False, vehicle_id="usv1")
    samplelog = SampleLog(tmp_path / "samples.sqlite")
    outbox = Outbox(tmp_path / "outbox.sqlite")
    feed = RecordFeed(ctx, outbox, samplelog.path)
    svc = MqttService(ctx, settings, FakeSnapshot(clock), outbox, feed, commands,  # type: ignore[arg-type]
                      client_factory=lambda _s: FakeClient(world))
    return svc, clock, samplelog


def _topics(world: dict[str, Any], name: str) -> list[Any]:
    return [p for p in world["published"] if p[0] == name]


def _sample(log: SampleLog, bottle: int) -> int:
    sid = log.begin_sample(t_unix_s=1.7e9, bottle=bottle, lat_deg=41.77, lon_deg=123.43, mission_seq=None,
                           target_lat_deg=None, target_lon_deg=None, distance_m=None, bottle_state=1)
    log.finish_sample(sid, status="complete", volume_ml=250.0, duration_s=10.0, distance_m=1.0, bottle=bottle,
                      bottle_state=2)
    return sid


async def test_state_topics_follow_their_rate_parameters_on_the_simulated_clock(tmp_path: Path) -> None:
    world = _world()
    svc, clock, _log = _service(tmp_path, world)
    svc.ctx.params.set("USV_MQTT_ENG_HZ", 0.0, persist=False)  # 0 turns a topic off
    task = asyncio.create_task(svc.run())
    await _advance(clock, 10.0)
    positions = _topics(world, "usv/usv1/position")
    times = [p[1]["t_s"] for p in positions]
    assert len(positions) == 20 or len(positions) == 21  # 2 Hz for 10 simulated seconds
    assert all(abs((b - a) - 0.5) < 0.02 for a, b in itertools.pairwise(times))
    assert 5 <= len(_topics(world, "usv/usv1/sampler")) <= 6  # 0.5 Hz
    assert not _topics(world, "usv/usv1/engine")
    assert all(p[2] == 0 and p[3] for p in positions)  # QoS 0, retained
    assert _topics(world, "usv/usv1/online")[0][1]["online"] is True
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    await svc.stop()


async def test_status_is_published_at_once_on_a_change(tmp_path: Path) -> None:
    world = _world()
    svc, clock, _log = _service(tmp_path, world)
    task = asyncio.create_task(svc.run())
    await _advance(clock, 0.55)
    before = len(_topics(world, "usv/usv1/status"))
    svc._on_vehicle_status(None)  # type: ignore[arg-type]  # what a vehicle_status publication does
    await _advance(clock, 0.12)
    assert len(_topics(world, "usv/usv1/status")) == before + 1  # not 1 s later
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    await svc.stop()


async def test_records_wait_in_the_outbox_while_the_broker_is_away_then_go_once(tmp_path: Path,
                                                                                 monkeypatch: Any) -> None:
    monkeypatch.setattr(service_module, "FIRST_RETRY_S", 0.01)
    world = _world()
    svc, clock, log = _service(tmp_path, world)
    world["fail_connects"] = 3
    _sample(log, 1)
    texts = svc.ctx.bus.topic(STATUS_TEXT_TOPIC)
    texts.publish(StatusText(0.0, Severity.CRITICAL, "GCS failsafe: no heartbeat"))
    texts.publish(StatusText(0.0, Severity.INFO, "Armed"))  # not an event
    task = asyncio.create_task(svc.run())
    for _ in range(300):
        await _advance(clock, 0.2)
        await asyncio.sleep(0.01)
        if svc.outbox.delivered("sample-1") and svc.outbox.delivered("failsafe-1"):
            break
    assert svc.stats.connect_failures == 3 and svc.stats.connects == 1
    sample = _topics(world, "usv/usv1/sample/1")
    failsafe = _topics(world, "usv/usv1/failsafe/1")
    assert len(sample) == 1 and sample[0][1]["record_id"] == "sample-1" and sample[0][2] == 1
    assert len(failsafe) == 1 and failsafe[0][1]["kind"] == "gcs"
    assert not _topics(world, "usv/usv1/failsafe/2")
    _sample(log, 2)  # a second one while connected: published within the poll period
    await _advance(clock, 1.2)
    assert len(_topics(world, "usv/usv1/sample/2")) == 1 and len(_topics(world, "usv/usv1/sample/1")) == 1
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    await svc.stop()


async def test_a_record_whose_publication_failed_stays_pending(tmp_path: Path, monkeypatch: Any) -> None:
    monkeypatch.setattr(service_module, "FIRST_RETRY_S", 0.01)
    world = _world()
    svc, clock, log = _service(tmp_path, world)
    world["fail_publish"] = True  # the online message and every record fail: connection lost
    _sample(log, 1)
    task = asyncio.create_task(svc.run())
    await _advance(clock, 0.5)
    await asyncio.sleep(0.05)
    assert not svc.outbox.delivered("sample-1") and not _topics(world, "usv/usv1/sample/1")
    world["fail_publish"] = False
    for _ in range(300):
        await _advance(clock, 0.1)
        await asyncio.sleep(0.01)
        if svc.outbox.delivered("sample-1"):
            break
    assert svc.outbox.delivered("sample-1")
    assert len(_topics(world, "usv/usv1/sample/1")) == 1
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    await svc.stop()


def _commands(allow: frozenset[MqttCommand], modes: list[int], refusal: str | None = None
              ) -> tuple[MqttCommands, list[str]]:
    settings = MqttSettings(host="h", port=1883, tls=False, vehicle_id="usv1", username="boat", password="pw",
                            commands_enabled=True, command_token=TOKEN, command_allowlist=allow)
    said: list[str] = []

    def set_mode(number: int) -> str | None:
        modes.append(number)
        return refusal

    target = CommandTarget(set_mode, lambda: True, lambda text, _sev: said.append(text))
    return MqttCommands(settings, target), said


@pytest.mark.parametrize(("payload", "result"), [
    (b"not json", "invalid"),
    (b"[1]", "invalid"),
    (json.dumps({"id": "1", "command": "RTL"}).encode(), "unauthorized"),
    (json.dumps({"id": "1", "command": "RTL", "token": "wrong"}).encode(), "unauthorized"),
    (json.dumps({"id": "1", "command": "DISARM", "token": TOKEN}).encode(), "invalid"),
    (json.dumps({"id": "1", "command": "STOP_PUMP", "token": TOKEN}).encode(), "denied"),
    (b"x" * 5000, "invalid"),
])
def test_bad_or_unauthorised_commands_do_nothing(payload: bytes, result: str) -> None:
    modes: list[int] = []
    commands, said = _commands(frozenset({MqttCommand.RTL, MqttCommand.HOLD}), modes)
    reply = commands.handle(payload, 1.0)
    assert reply["result"] == result and reply["reason"]
    assert modes == [] and said == []


def test_an_allowlisted_command_with_the_token_runs_and_a_refusal_is_reported() -> None:
    modes: list[int] = []
    commands, said = _commands(frozenset({MqttCommand.RTL}), modes)
    reply = commands.handle(json.dumps({"id": "7", "command": "RTL", "token": TOKEN}).encode(), 1.0)
    assert (reply["id"], reply["result"], modes) == ("7", "accepted", [ModeNumber.RTL])
    modes.clear()
    commands, said = _commands(frozenset({MqttCommand.HOLD}), modes, refusal="HOLD: no position")
    reply = commands.handle(json.dumps({"id": "8", "command": "HOLD", "token": TOKEN}).encode(), 1.0)
    assert (reply["result"], reply["reason"]) == ("failed", "HOLD: no position")
    assert said and "refused" in said[0]
