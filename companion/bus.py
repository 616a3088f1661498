"""A small typed publish/subscribe bus of latest values (the chapter's shared memory).

The chapter's onboard modules share memory guarded by read/write locks; in one asyncio
process the same idea is a set of named topics each holding the *latest* value of one
message type (PX4 calls this uORB).  Readers either poll :meth:`Topic.latest`, await
the next publication, or register a synchronous listener (used on the 100 Hz path so
that a lockstep simulation step runs the whole estimator-controller chain
deterministically before the servo outputs are answered).

A topic is named by a :class:`TopicKey`, its name paired with its message type; the product's
keys are constants next to the message types in :mod:`companion.messages` (``NAV_TOPIC``, ...).
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

T = TypeVar("T")


class TopicTypeError(TypeError):
    """A value of the wrong type was published, or a topic was requested with another type."""


@dataclass(frozen=True, slots=True)
class TopicKey(Generic[T]):
    """A topic's name and the one message type it carries."""

    name: str
    msg_type: type[T]


class Topic(Generic[T]):
    """One named latest-value slot of a fixed message type."""

    def __init__(self, name: str, msg_type: type[T]) -> None:
        self.name = name
        self.msg_type = msg_type
        self._value: T | None = None
        self._seq = 0
        self._waiters: list[asyncio.Future[None]] = []
        self._listeners: list[Callable[[T], None]] = []

    @property
    def seq(self) -> int:
        """Number of values published so far."""
        return self._seq

    def latest(self) -> T | None:
        """The most recent value, or ``None`` before the first publication."""
        return self._value

    def publish(self, value: T) -> None:
        """Store ``value`` as the latest, run listeners, and wake awaiting readers."""
        if not isinstance(value, self.msg_type):
            raise TopicTypeError(
                f"topic {self.name!r} carries {self.msg_type.__name__}, got {type(value).__name__}"
            )
        self._value = value
        self._seq += 1
        for listener in tuple(self._listeners):
            listener(value)
        if self._waiters:
            waiters, self._waiters = self._waiters, []
            for fut in waiters:
                if not fut.done():
                    fut.set_result(None)

    def add_listener(self, callback: Callable[[T], None]) -> Callable[[], None]:
        """Call ``callback(value)`` synchronously on every publication; returns a remover."""
        self._listeners.append(callback)

        def remove() -> None:
            if callback in self._listeners:
                self._listeners.remove(callback)

        return remove

    async def next(self, after_seq: int | None = None) -> T:
        """Wait for a value newer than ``after_seq`` (default: newer than now)."""
        target = self._seq if after_seq is None else after_seq
        while self._seq <= target:
            fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
            self._waiters.append(fut)
            await fut
        assert self._value is not None
        return self._value

    async def subscribe(self) -> AsyncIterator[T]:
        """Iterate over new values; a slow reader skips to the latest (no queue build-up)."""
        seen = self._seq
        while True:
            value = await self.next(seen)
            seen = self._seq
            yield value


class Bus:
    """Registry of topics by name; asking twice for a name returns the same topic."""

    def __init__(self) -> None:
        self._topics: dict[str, Topic[Any]] = {}

    def topic(self, key: TopicKey[T]) -> Topic[T]:
        """The topic named ``key.name`` (created on first use), which carries ``key.msg_type``."""
        existing = self._topics.get(key.name)
        if existing is None:
            created: Topic[T] = Topic(key.name, key.msg_type)
            self._topics[key.name] = created
            return created
        if existing.msg_type is not key.msg_type:
            raise TopicTypeError(f"topic {key.name!r} already carries {existing.msg_type.__name__}, "
                                 f"not {key.msg_type.__name__}")
        return existing

    def names(self) -> list[str]:
        return sorted(self._topics)
