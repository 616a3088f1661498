"""Actuator command (SI units) -> servo pulse widths -> the servo controller's frame.

Servo frame (companion -> servo controller, ASCII, NMEA checksum):
``$PUSVS,ACK,P1,P2,P3,P4,P5,P6,P7,P8*HH`` with P1..P8 the pulse widths in microseconds of
output channels 1-8 and ACK the GPS time field of the ``$GPFPD`` sample this frame
answers (empty for frames not answering a sample).  The simulator's lockstep waits for
the frame whose ACK matches the sample it sent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.messages import ActuatorCommand, ControlSource
from companion.params import ParamStore
from companion.sensors.nmea import build

N_CHANNELS = 8


@dataclass(frozen=True, slots=True)
class ServoFrame:
    ack: str
    pulse_us: tuple[int, ...]


def encode_frame(ack: str, pulse_us: tuple[int, ...]) -> bytes:
    return build("PUSVS," + ack + "," + ",".join(str(p) for p in pulse_us))


def decode_frame(body: str) -> ServoFrame | None:
    """Parse the body (``PUSVS,...``) of a checked sentence; ``None`` if malformed."""
    parts = body.split(",")
    if parts[0] != "PUSVS" or len(parts) != 2 + N_CHANNELS:
        return None
    try:
        pulses = tuple(int(p) for p in parts[2:])
    except ValueError:
        return None
    if not all(500 <= p <= 2500 for p in pulses):
        return None
    return ServoFrame(parts[1], pulses)


class ServoMap:
    """Maps an :class:`ActuatorCommand` to pulses using the USV_CH_*/USV_*_PWM_* parameters."""

    def __init__(self, params: ParamStore) -> None:
        self.params = params
        self._cache: tuple[float, ...] | None = None
        params.add_listener(lambda _n, _v: self._invalidate())

    def _invalidate(self) -> None:
        self._cache = None

    def _p(self, name: str, default: float) -> float:
        return self.params.get(name) if name in self.params else default

    def pulses(self, cmd: ActuatorCommand, launcher_pulse_us: int = 1900, launcher_safe_us: int = 1100,
               valve_bottle: int = 0) -> tuple[int, ...]:
        p = self._p
        out = [1500] * N_CHANNELS
        noz_max = math.radians(p("USV_NOZ_MAX_DEG", 60.0))
        frac = max(-1.0, min(1.0, cmd.nozzle_rad / noz_max))
        if p("USV_NOZ_REV", 0) >= 1:
            frac = -frac
        trim = p("USV_NOZ_PWM_TRIM", 1500)
        span = (p("USV_NOZ_PWM_MAX", 1900) - trim) if frac >= 0 else (trim - p("USV_NOZ_PWM_MIN", 1100))
        out[int(p("USV_CH_NOZZLE", 1)) - 1] = round(trim + frac * span)
        thr = max(0.0, min(1.0, cmd.throttle))
        lo, hi = p("USV_THR_PWM_MIN", 1100), p("USV_THR_PWM_MAX", 1900)
        out[int(p("USV_CH_THROTTLE", 3)) - 1] = round(lo + thr * (hi - lo))
        off, on = round(p("USV_SW_PWM_OFF", 1100)), round(p("USV_SW_PWM_ON", 1900))
        out[int(p("USV_CH_IGNITION", 5)) - 1] = on if cmd.ignition_on else off
        out[int(p("USV_CH_SELECTOR", 6)) - 1] = on if cmd.source == ControlSource.COMPANION else off
        launcher_us = launcher_pulse_us if cmd.launcher_trigger else launcher_safe_us
        out[int(p("USV_CH_LAUNCHER", 7)) - 1] = launcher_us
        out[int(p("USV_CH_PUMP", 8)) - 1] = on if cmd.pump_on else off
        bottle = max(0, min(4, valve_bottle)) if cmd.pump_on else 0
        out[int(p("USV_CH_VALVE", 4)) - 1] = 1000 + 200 * bottle
        return tuple(out)
