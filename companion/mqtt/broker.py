"""The embedded MQTT broker of ``usv sitl --mqtt-embedded``: amqtt on loopback, in-process.

For a newcomer who wants to watch the boat with any MQTT client (``mosquitto_sub -h 127.0.0.1
-t 'usv/#' -v``, MQTT Explorer, Node-RED) without installing a broker.  It listens on
127.0.0.1 only and lets anyone on this machine connect (anonymous), so it is for SITL, not
for a boat.  amqtt is the optional extra ``broker`` (``pip install 'usv-companion[broker]'``);
without it the flag is a one-line error.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from typing import Any

from companion.config import ConfigError

log = logging.getLogger(__name__)

EMBEDDED_HOST = "127.0.0.1"
DEFAULT_EMBEDDED_PORT = 1883
SHUTDOWN_S = 3.0
"""Longest wait (wall seconds) for the broker to shut down."""


def broker_config(port: int, host: str = EMBEDDED_HOST) -> dict[str, Any]:
    """amqtt's configuration: one TCP listener on ``host:port``, anonymous clients allowed."""
    return {
        "listeners": {"default": {"type": "tcp", "bind": f"{host}:{port}"}},
        "plugins": {"amqtt.plugins.authentication.AnonymousAuthPlugin": {"allow_anonymous": True}},
    }


class EmbeddedBroker:
    """An amqtt broker in a thread of its own (its own event loop), started before the companion
    and stopped after it.

    Its own loop keeps the broker's work off the companion's 100 Hz loop, and a broker that does
    not shut down in time (amqtt on Python 3.11 can wait for a connected client's reader that
    swallowed its cancellation) cannot keep ``usv sitl`` from exiting: the thread is a daemon and
    its loop is stopped after :data:`SHUTDOWN_S`.  ``usv sitl`` calls :meth:`start` before the
    companion's services, so a port in use is a one-line error.
    """

    def __init__(self, port: int = DEFAULT_EMBEDDED_PORT) -> None:
        self.port = port
        self._broker: Any = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        return f"mqtt://{EMBEDDED_HOST}:{self.port}"

    async def start(self) -> None:
        try:
            from amqtt.broker import Broker
        except ImportError:
            raise ConfigError("--mqtt-embedded needs the amqtt broker: pip install 'usv-companion[broker]'") \
                from None
        for noisy in ("amqtt", "transitions"):
            logging.getLogger(noisy).setLevel(logging.WARNING)
        amqtt_log = logging.getLogger("amqtt.broker")
        amqtt_log.setLevel(logging.CRITICAL)  # a failed start is our one-line error, not its traceback
        loop = asyncio.new_event_loop()
        thread = threading.Thread(target=loop.run_forever, name="mqtt-broker", daemon=True)
        thread.start()
        self._loop, self._thread = loop, thread

        async def start_broker() -> Any:
            broker = Broker(broker_config(self.port))
            await broker.start()
            return broker

        try:
            self._broker = await asyncio.wrap_future(asyncio.run_coroutine_threadsafe(start_broker(), loop))
        except Exception as exc:  # amqtt wraps the bind error in its own exception types
            self._stop_loop()
            raise ConfigError(f"--mqtt-embedded: cannot start the broker on {EMBEDDED_HOST}:{self.port} "
                              f"({exc})") from None
        finally:
            amqtt_log.setLevel(logging.WARNING)
        log.info("embedded MQTT broker on %s", self.url)

    async def stop(self) -> None:
        if self._broker is not None and self._loop is not None:
            done = asyncio.run_coroutine_threadsafe(self._broker.shutdown(), self._loop)
            try:
                await asyncio.wait_for(asyncio.wrap_future(done), SHUTDOWN_S)
            except Exception as exc:  # a broker that cannot stop must not keep the companion alive
                log.warning("embedded MQTT broker did not shut down cleanly (%s)", exc or "timeout")
            self._broker = None
        self._stop_loop()

    def _stop_loop(self) -> None:
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._loop.stop)
            if self._thread is not None:
                self._thread.join(SHUTDOWN_S)
            self._loop = self._thread = None
