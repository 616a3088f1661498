import asyncio
from dataclasses import FrozenInstanceError

import pytest

from companion.bus import Bus, TopicKey, TopicTypeError
from companion.messages import (
    ENGINE_TOPIC,
    NAV_TOPIC,
    SETPOINT_TOPIC,
    TOPICS,
    EngineState,
    NavState,
    Setpoint,
)


def test_topic_keeps_only_the_latest_value_and_counts_publications() -> None:
    bus = Bus()
    topic = bus.topic(SETPOINT_TOPIC)
    assert topic.latest() is None
    topic.publish(Setpoint(0.0, 1.0, 2.0))
    topic.publish(Setpoint(0.1, 1.5, 3.0))
    assert topic.latest() == Setpoint(0.1, 1.5, 3.0)
    assert topic.seq == 2
    assert bus.topic(SETPOINT_TOPIC) is topic


def test_wrong_types_are_refused() -> None:
    bus = Bus()
    topic = bus.topic(ENGINE_TOPIC)
    with pytest.raises(TopicTypeError, match="carries EngineState"):
        topic.publish(Setpoint(0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(TopicTypeError, match="already carries"):
        bus.topic(TopicKey("engine", Setpoint))


def test_messages_are_frozen() -> None:
    sp = Setpoint(0.0, 1.0, 2.0)
    with pytest.raises(FrozenInstanceError):
        sp.speed_mps = 3.0  # type: ignore[misc]


def test_every_canonical_topic_type_is_a_frozen_dataclass_with_a_timestamp() -> None:
    assert len({key.name for key in TOPICS}) == len(TOPICS)  # one key per name
    for key in TOPICS:
        fields = key.msg_type.__dataclass_fields__
        assert "t_s" in fields, key.name
        assert key.msg_type.__dataclass_params__.frozen, key.name


async def test_listeners_run_synchronously_and_readers_wake() -> None:
    bus = Bus()
    topic = bus.topic(ENGINE_TOPIC)
    heard: list[float] = []
    remove = topic.add_listener(lambda m: heard.append(m.rpm))
    reader = asyncio.create_task(topic.next())
    await asyncio.sleep(0)
    topic.publish(EngineState(0.0, 3000.0, True))
    assert heard == [3000.0]
    assert (await reader).rpm == 3000.0
    remove()
    topic.publish(EngineState(0.1, 0.0, False))
    assert heard == [3000.0]


async def test_slow_subscriber_skips_to_latest() -> None:
    bus = Bus()
    topic = bus.topic(NAV_TOPIC)
    seen: list[float] = []

    async def reader() -> None:
        async for msg in topic.subscribe():
            seen.append(msg.t_s)
            if msg.t_s >= 2.0:
                return

    task = asyncio.create_task(reader())
    await asyncio.sleep(0)
    for t in (0.0, 1.0, 2.0):  # published back-to-back: the reader only sees the latest
        topic.publish(NavState(t, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0))
    await task
    assert seen == [2.0]
