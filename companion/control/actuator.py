"""Actuator mapping: limits, slew rates, saturation flags and servo pulse widths.

The last stage of the stack.  Controllers ask for a nozzle angle (rad, positive turns the boat
to starboard) and a throttle (0..1); :class:`ActuatorMapper` clips them to the physical range,
applies the servo slew rates, and reports which limits were hit so that the controllers stop
integrating into a wall (anti-windup, :mod:`companion.control.pid`).  :func:`nozzle_to_pulse_us`
and :func:`throttle_to_pulse_us` are the chapter's execute module (PWM to the rudder and
throttle servos, section 2.1.6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.control.pid import RateLimiter


@dataclass(frozen=True, slots=True)
class ActuatorLimits:
    nozzle_max_rad: float = math.radians(60.0)
    nozzle_rate_radps: float = math.radians(120.0)
    throttle_min: float = 0.0
    throttle_max: float = 1.0
    throttle_rate_per_s: float = 1.0

    def __post_init__(self) -> None:
        if not (0 < self.nozzle_max_rad <= math.pi / 2 and self.nozzle_rate_radps > 0):
            raise ValueError(f"invalid nozzle limits {self}")
        if not (0 <= self.throttle_min < self.throttle_max <= 1 and self.throttle_rate_per_s > 0):
            raise ValueError(f"invalid throttle limits {self}")


@dataclass(frozen=True, slots=True)
class Saturation:
    """Which limit (range or slew rate) held back the last command."""

    nozzle_high: bool = False
    nozzle_low: bool = False
    throttle_high: bool = False
    throttle_low: bool = False


NO_SATURATION = Saturation()


IDLE_THROTTLE = 0.02
"""At this throttle or less the jet idles (it still pushes the boat at its idle creep)."""


class ActuatorMapper:
    """Clip and slew-limit (nozzle_rad, throttle); remembers the last saturation flags."""

    def __init__(self, limits: ActuatorLimits | None = None) -> None:
        self.limits = limits or ActuatorLimits()
        self._nozzle = RateLimiter(self.limits.nozzle_rate_radps)
        self._throttle = RateLimiter(self.limits.throttle_rate_per_s, self.limits.throttle_min)
        self.saturation = NO_SATURATION

    @property
    def nozzle_rad(self) -> float:
        """The last nozzle angle sent."""
        return self._nozzle.value

    @property
    def throttle(self) -> float:
        """The last throttle sent."""
        return self._throttle.value

    def idling(self) -> bool:
        """The jet idles: the last throttle sent is at most :data:`IDLE_THROTTLE`."""
        return self._throttle.value <= IDLE_THROTTLE

    def reset(self, nozzle_rad: float = 0.0, throttle: float = 0.0) -> None:
        lim = self.limits
        self._nozzle.reset(min(lim.nozzle_max_rad, max(-lim.nozzle_max_rad, nozzle_rad)))
        self._throttle.reset(min(lim.throttle_max, max(lim.throttle_min, throttle)))
        self.saturation = NO_SATURATION

    def apply(self, nozzle_rad: float, throttle: float, dt_s: float) -> tuple[float, float, Saturation]:
        lim = self.limits
        if not math.isfinite(nozzle_rad):
            nozzle_rad = self._nozzle.value
        if not math.isfinite(throttle):
            throttle = self._throttle.value
        noz_c = min(lim.nozzle_max_rad, max(-lim.nozzle_max_rad, nozzle_rad))
        thr_c = min(lim.throttle_max, max(lim.throttle_min, throttle))
        noz = self._nozzle.step(noz_c, dt_s)
        thr = self._throttle.step(thr_c, dt_s)
        eps = 1e-9
        self.saturation = Saturation(
            nozzle_high=nozzle_rad > noz + eps, nozzle_low=nozzle_rad < noz - eps,
            throttle_high=throttle > thr + eps, throttle_low=throttle < thr - eps)
        return noz, thr, self.saturation


def nozzle_to_pulse_us(nozzle_rad: float, nozzle_max_rad: float, *, centre_us: int = 1500,
                       half_span_us: int = 400, reversed_: bool = False) -> int:
    """Nozzle angle -> steering servo pulse (full deflection = centre +/- half_span)."""
    frac = min(1.0, max(-1.0, nozzle_rad / nozzle_max_rad))
    if reversed_:
        frac = -frac
    return round(centre_us + frac * half_span_us)


def throttle_to_pulse_us(throttle: float, *, min_us: int = 1100, max_us: int = 1900) -> int:
    """Throttle 0..1 -> throttle servo pulse."""
    frac = min(1.0, max(0.0, throttle))
    return round(min_us + frac * (max_us - min_us))
