"""The embedded MQTT broker of ``usv sitl --mqtt-embedded``: amqtt on loopback, in-process.

For a newcomer who wants to watch the boat with any MQTT client (``mosquitto_sub -h 127.0.0.1
-t 'usv/#' -v``, MQTT Explorer, Node-RED) without installing a broker.  It listens on
127.0.0.1 only and lets anyone on this machine connect (anonymous), so it is for SITL, not
for a boat.  amqtt is the optional extra ``broker`` (``pip install 'usv-companion[broker]'``);
without it the flag is a one-line error.
"""

from __future__ import annotations

import logging
from typing import Any

from companion.app import BaseService
from companion.config import ConfigError

log = logging.getLogger(__name__)

EMBEDDED_HOST = "127.0.0.1"
DEFAULT_EMBEDDED_PORT = 1883


def broker_config(port: int, host: str = EMBEDDED_HOST) -> dict[str, Any]:
    """amqtt's configuration: one TCP listener on ``host:port``, anonymous clients allowed."""
    return {
        "listeners": {"default": {"type": "tcp", "bind": f"{host}:{port}"}},
        "plugins": {"amqtt.plugins.authentication.AnonymousAuthPlugin": {"allow_anonymous": True}},
    }


class EmbeddedBroker(BaseService):
    """An amqtt broker started before the companion and stopped after it."""

    name = "mqtt-broker"

    def __init__(self, port: int = DEFAULT_EMBEDDED_PORT) -> None:
        self.port = port
        self._broker: Any = None

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
        broker = Broker(broker_config(self.port))
        try:
            await broker.start()
        except Exception as exc:  # amqtt wraps the bind error in its own exception types
            raise ConfigError(f"--mqtt-embedded: cannot start the broker on {EMBEDDED_HOST}:{self.port} "
                              f"({exc})") from None
        self._broker = broker
        log.info("embedded MQTT broker on %s", self.url)

    async def stop(self) -> None:
        if self._broker is not None:
            await self._broker.shutdown()
            self._broker = None
