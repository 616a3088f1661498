"""Actuator command (SI units) -> servo pulse widths -> the servo controller's frame.

Servo frame (companion -> servo controller, ASCII, NMEA checksum):
``$PUSVS,ACK,P1,P2,P3,P4,P5,P6,P7,P8*HH`` with P1..P8 the pulse widths in microseconds of
output channels 1-8 and ACK the GPS time field of the ``$GPFPD`` sample this frame
answers (empty for frames not answering a sample).  The simulator's lockstep waits for
the frame whose ACK matches the sample it sent.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

from companion.actuators.overrides import owned_channels
from companion.messages import ActuatorCommand, ControlSource
from companion.params import ParamStore
from companion.sensors.nmea import build, frame

N_CHANNELS = 8


_FRAME_FORMAT = b"PUSVS,%s" + b",%d" * N_CHANNELS


class ServoFrame(NamedTuple):
    ack: str
    pulse_us: tuple[int, ...]


def encode_frame(ack: str, pulse_us: tuple[int, ...]) -> bytes:
    """``$PUSVS,ACK,P1..P8*HH`` (one 100 Hz frame: formatted as bytes in one step)."""
    if len(pulse_us) == N_CHANNELS:
        return frame(_FRAME_FORMAT % (ack.encode("ascii"), *pulse_us))
    return build("PUSVS," + ack + "," + ",".join(map(str, pulse_us)))


def decode_frame(body: str) -> ServoFrame | None:
    """Parse the body (``PUSVS,...``) of a checked sentence; ``None`` if malformed."""
    parts = body.split(",")
    if parts[0] != "PUSVS" or len(parts) != 2 + N_CHANNELS:
        return None
    try:
        pulses = tuple(map(int, parts[2:]))
    except ValueError:
        return None
    if min(pulses) < 500 or max(pulses) > 2500:
        return None
    return ServoFrame(parts[1], pulses)


@dataclass(frozen=True)
class ServoChannel:
    """An output a payload drives: ``param`` names its channel (1-based, default ``default``)."""

    param: str
    default: int
    function: str
    """What the output does, for the operator ("launcher trigger")."""
    pulse_us: Callable[[], int]
    """The pulse the payload wants on it now (called for every servo frame)."""


class _Resolved(NamedTuple):
    """The parameter values the mapping needs, read once per parameter change (speed)."""

    noz_max_rad: float
    noz_rev: bool
    noz_trim: float
    noz_span_stbd: float
    noz_span_port: float
    ch_nozzle: int
    thr_lo: float
    thr_span: float
    ch_throttle: int
    sw_off: int
    sw_on: int
    ch_ignition: int
    ch_selector: int
    payload: tuple[tuple[int, Callable[[], int]], ...]
    """0-based index and pulse source of every payload output."""
    owned: frozenset[int]
    """0-based indices of the autopilot-owned outputs (never overridden)."""


class ServoMap:
    """Maps an :class:`ActuatorCommand` and the payloads' outputs to pulses (USV_CH_*/USV_*_PWM_*).

    Parameter values are cached and re-read after any parameter change (store listener).
    :attr:`overrides_us` (1-based channel -> pulse; DO_SET_SERVO / DO_SET_RELAY, see
    :mod:`companion.actuators.overrides`) drives free outputs only: an entry for an
    autopilot-owned channel (the boat's and the payloads') is ignored.
    """

    def __init__(self, params: ParamStore, payload_channels: Sequence[ServoChannel] = (),
                 overrides_us: dict[int, int] | None = None) -> None:
        self.params = params
        self.payload_channels = tuple(payload_channels)
        self._cache: _Resolved | None = None
        self.overrides_us: dict[int, int] = {} if overrides_us is None else overrides_us
        """The operator's overrides (the vehicle's table, shared, not copied)."""
        params.add_listener(lambda _n, _v: self._invalidate())

    def _invalidate(self) -> None:
        self._cache = None

    def _p(self, name: str, default: float) -> float:
        return self.params.get(name) if name in self.params else default

    def _resolve(self) -> _Resolved:
        p = self._p
        trim = p("USV_NOZ_PWM_TRIM", 1500)
        lo, hi = p("USV_THR_PWM_MIN", 1100), p("USV_THR_PWM_MAX", 1900)
        self._cache = _Resolved(
            noz_max_rad=math.radians(p("USV_NOZ_MAX_DEG", 60.0)), noz_rev=p("USV_NOZ_REV", 0) >= 1,
            noz_trim=trim, noz_span_stbd=p("USV_NOZ_PWM_MAX", 1900) - trim,
            noz_span_port=trim - p("USV_NOZ_PWM_MIN", 1100), ch_nozzle=int(p("USV_CH_NOZZLE", 1)) - 1,
            thr_lo=lo, thr_span=hi - lo, ch_throttle=int(p("USV_CH_THROTTLE", 3)) - 1,
            sw_off=round(p("USV_SW_PWM_OFF", 1100)), sw_on=round(p("USV_SW_PWM_ON", 1900)),
            ch_ignition=int(p("USV_CH_IGNITION", 5)) - 1, ch_selector=int(p("USV_CH_SELECTOR", 6)) - 1,
            payload=tuple((int(p(ch.param, ch.default)) - 1, ch.pulse_us) for ch in self.payload_channels),
            owned=frozenset(ch - 1 for ch in self.owned_channels()))
        return self._cache

    def owned_channels(self) -> dict[int, str]:
        """1-based channel -> function of every autopilot-owned output (never overridable)."""
        payload = ((ch.param, ch.default, ch.function) for ch in self.payload_channels)
        return owned_channels(self.params, payload)

    def pulses(self, cmd: ActuatorCommand) -> tuple[int, ...]:
        """Pulse widths of channels 1-8: the command's, the payloads' outputs, the overrides."""
        c = self._cache or self._resolve()
        out = [1500] * N_CHANNELS
        frac = max(-1.0, min(1.0, cmd.nozzle_rad / c.noz_max_rad))
        if c.noz_rev:
            frac = -frac
        span = c.noz_span_stbd if frac >= 0 else c.noz_span_port
        out[c.ch_nozzle] = round(c.noz_trim + frac * span)
        thr = max(0.0, min(1.0, cmd.throttle))
        out[c.ch_throttle] = round(c.thr_lo + thr * c.thr_span)
        off, on = c.sw_off, c.sw_on
        out[c.ch_ignition] = on if cmd.ignition_on else off
        out[c.ch_selector] = on if cmd.source == ControlSource.COMPANION else off
        for index, payload_pulse_us in c.payload:
            out[index] = payload_pulse_us()
        if self.overrides_us:
            for channel, pulse_us in self.overrides_us.items():
                index = channel - 1
                if 0 <= index < N_CHANNELS and index not in c.owned:
                    out[index] = pulse_us
        return tuple(out)
