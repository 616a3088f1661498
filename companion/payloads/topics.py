"""Bus messages of the payloads: what the payload sensors report and what the payloads command.

``payload_sensors`` (:class:`PayloadSensors`) is published by the sensor driver that parses
the boat's payload sentence (cylinder pressure, bottle levels; in SITL the simulator sends
the same sentence).  ``payload_cmd`` (:class:`PayloadCommand`) is published by the
payloads; the actuator output stage merges it into the servo frame (see
:func:`merge_into_actuator_command` for the fields of :class:`~companion.messages.ActuatorCommand`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from companion.bus import Bus
from companion.clock import Clock
from companion.messages import ActuatorCommand

BOTTLE_COUNT = 4
"""Chapter section 4.2: four sampling bottles and one pump."""

PAYLOAD_SENSORS_TOPIC = "payload_sensors"
PAYLOAD_CMD_TOPIC = "payload_cmd"


@dataclass(frozen=True, slots=True)
class PayloadSensors:
    """Payload sensor readings: cylinder pressure and the water volume in each bottle."""

    t_s: float
    cylinder_pressure_mpa: float
    bottle_volume_ml: tuple[float, ...] = (0.0,) * BOTTLE_COUNT


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


def merge_into_actuator_command(cmd: ActuatorCommand, payload: PayloadCommand | None) -> ActuatorCommand:
    """The controller's command with the payload fields set from ``payload`` (None: both off)."""
    if payload is None:
        return replace(cmd, launcher_trigger=False, pump_on=False)
    return replace(cmd, launcher_trigger=payload.launcher_trigger, pump_on=payload.pump_on)


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
