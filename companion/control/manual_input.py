"""Pilot input for MANUAL and CRUISE: MAVLink MANUAL_CONTROL from a ground station, else the RC receiver.

Two sources, one normalised :class:`PilotInput` (steering -1..1, positive = nozzle to starboard;
throttle 0..1):

- MAVLink ``MANUAL_CONTROL`` (msg 69) as ArduPilot Rover reads it (``GCS_MAVLINK_Rover::
  handle_manual_control_axes``): ``y`` is steering and ``z`` is throttle, both -1000..1000
  (INT16_MAX = axis not used).  Rover maps ``z`` onto a centred throttle channel (0 = stop,
  negative = reverse); a water jet has no reverse, so ``z <= 0`` is idle and ``z = 1000`` full
  throttle.  :mod:`companion.mavlink.manual_control` publishes :class:`ManualControlInput` on
  the bus topic :data:`~companion.messages.MANUAL_CONTROL_TOPIC`.
- The RC receiver on ``rc_in`` (``$PUSVRC`` from the GPS-INS box): channel 1 steering
  (1500 +- 400 us), channel 3 throttle (1100 us idle .. 1900 us full), as the boat's
  transmitter is set up (:class:`sim_bridge.payload.RcTransmitter`).

A fresh ground-station input wins over the receiver (like ArduPilot's RC overrides); an input is
fresh for ``timeout_s`` (``USV_MAN_TIMEOUT``).  With neither fresh, :func:`pilot_input` returns
None and MANUAL puts the outputs in their safe state (throttle idle, nozzle centred).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.bus import Bus
from companion.messages import MANUAL_CONTROL_TOPIC, RC_IN_TOPIC, ManualControlInput

AXIS_UNUSED = 32767
"""INT16_MAX: MANUAL_CONTROL's marker for an axis the ground station does not send."""
STICK_DEADBAND = 0.05
RC_STEER_CHANNEL = 1
RC_THROTTLE_CHANNEL = 3


@dataclass(frozen=True, slots=True)
class PilotInput:
    steering: float
    throttle: float
    source: str
    """``"gcs"`` (MANUAL_CONTROL) or ``"rc"`` (the receiver)."""


def _axis(value: float) -> float | None:
    if int(value) == AXIS_UNUSED or not math.isfinite(value):
        return None
    return max(-1.0, min(1.0, value / 1000.0))


def from_manual_control(t_s: float, y: float, z: float) -> ManualControlInput:
    """Normalise the steering (y) and throttle (z) axes of a MANUAL_CONTROL; out of range is clipped."""
    steering = _axis(y)
    throttle = _axis(z)
    return ManualControlInput(t_s, _deadband(steering) if steering is not None else None,
                              max(0.0, throttle) if throttle is not None else None)


def _deadband(value: float) -> float:
    return 0.0 if abs(value) < STICK_DEADBAND else value


def rc_steering(channels_us: tuple[int, ...]) -> float | None:
    """Steering stick -1..1 (1500 us centre, +-400 us), None if the channel is absent or invalid."""
    us = _channel(channels_us, RC_STEER_CHANNEL)
    return None if us is None else _deadband(max(-1.0, min(1.0, (us - 1500) / 400.0)))


def rc_throttle(channels_us: tuple[int, ...]) -> float | None:
    """Throttle stick 0..1 (1100 us idle, 1900 us full), None if absent or invalid."""
    us = _channel(channels_us, RC_THROTTLE_CHANNEL)
    return None if us is None else max(0.0, min(1.0, (us - 1100) / 800.0))


def _channel(channels_us: tuple[int, ...], channel: int) -> int | None:
    if len(channels_us) < channel or not 800 <= channels_us[channel - 1] <= 2200:
        return None
    return channels_us[channel - 1]


def pilot_input(bus: Bus, now_s: float, timeout_s: float) -> PilotInput | None:
    """The pilot's steering and throttle: fresh MANUAL_CONTROL first, else a fresh RC receiver."""
    gcs = bus.topic(MANUAL_CONTROL_TOPIC).latest()
    if gcs is not None and now_s - gcs.t_s <= timeout_s:
        return PilotInput(gcs.steering or 0.0, gcs.throttle or 0.0, "gcs")
    rc = bus.topic(RC_IN_TOPIC).latest()
    if rc is not None and now_s - rc.t_s <= timeout_s:
        steering, throttle = rc_steering(rc.channels_us), rc_throttle(rc.channels_us)
        if steering is not None and throttle is not None:
            return PilotInput(steering, throttle, "rc")
    return None
