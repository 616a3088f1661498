"""Bus messages of the payloads: what the payload sensors report and what the payloads command.

``payload_sensors`` (:class:`PayloadSensors`) is published by the sensor driver that parses
the boat's payload sentence (cylinder pressure, bottle levels; in SITL the simulator sends
the same sentence).  ``payload_cmd`` (:class:`PayloadCommand`) holds what the launcher and the
sampler want from their outputs (:class:`PayloadOutputs`); their servo channels
(:mod:`companion.payloads.launcher`, :mod:`companion.payloads.sampler`) read it for every frame,
observers (logs, tests) see it on the bus.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from companion.bus import Bus
from companion.clock import Clock
from companion.messages import PayloadSensors

__all__ = ["BOTTLE_COUNT", "PAYLOAD_CMD_TOPIC", "PAYLOAD_SENSORS_TOPIC", "PayloadCommand", "PayloadOutputs",
           "PayloadSensors"]

BOTTLE_COUNT = 4
"""Chapter section 4.2: four sampling bottles and one pump."""

PAYLOAD_SENSORS_TOPIC = "payload_sensors"
PAYLOAD_CMD_TOPIC = "payload_cmd"



@dataclass(frozen=True, slots=True)
class PayloadCommand:
    """What the payloads want from their actuators right now.

    ``launcher_trigger``: trigger servo at its firing pulse (``trigger_pulse_us``) instead of
    its safe pulse; ``pump_on`` with ``valve_bottle`` (1-4, 0 = all valves closed).
    """

    t_s: float
    launcher_trigger: bool = False
    trigger_pulse_us: int = 1100
    pump_on: bool = False
    valve_bottle: int = 0


class PayloadOutputs:
    """Holds the payloads' actuator wishes and publishes them as one :class:`PayloadCommand`."""

    def __init__(self, bus: Bus, clock: Clock) -> None:
        self._topic = bus.topic(PAYLOAD_CMD_TOPIC, PayloadCommand)
        self._clock = clock
        self.current = PayloadCommand(t_s=clock.now_s())

    def set(self, **changes: object) -> PayloadCommand:
        """Change some fields (``launcher_trigger``, ``trigger_pulse_us``, ``pump_on``, ``valve_bottle``)."""
        self.current = replace(self.current, t_s=self._clock.now_s(), **changes)  # type: ignore[arg-type]
        self._topic.publish(self.current)
        return self.current
