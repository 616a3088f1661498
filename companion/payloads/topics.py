"""The payloads' actuator wishes, published as one :class:`~companion.messages.PayloadCommand`.

``payload_cmd`` (:data:`~companion.messages.PAYLOAD_CMD_TOPIC`) holds what the launcher and the
sampler want from their outputs (:class:`PayloadOutputs`); their servo channels
(:mod:`companion.payloads.launcher`, :mod:`companion.payloads.sampler`) read it for every frame,
observers (logs, tests) see it on the bus.  What the payload sensors report (``$PUSVP``: cylinder
pressure, bottle levels; in SITL the simulator sends the same sentence) is
:data:`~companion.messages.PAYLOAD_SENSORS_TOPIC`.
"""

from __future__ import annotations

from dataclasses import replace

from companion.bus import Bus
from companion.clock import Clock
from companion.messages import PAYLOAD_CMD_TOPIC, PayloadCommand

__all__ = ["PayloadOutputs"]


class PayloadOutputs:
    """Holds the payloads' actuator wishes and publishes them as one :class:`PayloadCommand`."""

    def __init__(self, bus: Bus, clock: Clock) -> None:
        self._topic = bus.topic(PAYLOAD_CMD_TOPIC)
        self._clock = clock
        self.current = PayloadCommand(t_s=clock.now_s())

    def set(self, **changes: object) -> PayloadCommand:
        """Change some fields (``launcher_trigger``, ``trigger_pulse_us``, ``pump_on``, ``valve_bottle``)."""
        self.current = replace(self.current, t_s=self._clock.now_s(), **changes)  # type: ignore[arg-type]
        self._topic.publish(self.current)
        return self.current
