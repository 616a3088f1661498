"""PID with conditional-integration anti-windup, derivative on measurement and a rate limiter.

Anti-windup follows the "conditional integration" (clamping) scheme of Astrom and Hagglund,
Advanced PID Control (2006), section 3.5: the integrator stops growing in the direction in which
either this controller's own output limit or the downstream actuator (reported as saturation
flags by :mod:`companion.control.actuator`) is saturated, and is also bounded by ``i_max``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class PidGains:
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    i_max: float = math.inf
    """Bound on the integral contribution (output units)."""
    out_min: float = -math.inf
    out_max: float = math.inf

    def __post_init__(self) -> None:
        vals = (self.kp, self.ki, self.kd)
        if not all(math.isfinite(v) and v >= 0.0 for v in vals):
            raise ValueError(f"PID gains must be finite and >= 0, got {vals}")
        if not (self.out_min < self.out_max and self.i_max >= 0.0):
            raise ValueError(f"invalid PID limits {self}")


class Pid:
    """``u = ff + kp*e + I + kd*de``; ``de`` is passed in (derivative on measurement, e.g. -r)."""

    def __init__(self, gains: PidGains) -> None:
        self.gains = gains
        self.integral = 0.0
        self.last_output = 0.0

    def reset(self, integral: float = 0.0) -> None:
        self.integral = integral
        self.last_output = 0.0

    def update(self, error: float, dt_s: float, *, error_rate: float = 0.0, feedforward: float = 0.0,
               saturated_high: bool = False, saturated_low: bool = False) -> float:
        """One step; ``saturated_high/low`` are the actuator's flags from the previous step."""
        g = self.gains
        if not (math.isfinite(error) and math.isfinite(error_rate) and math.isfinite(feedforward)):
            return self.last_output  # bad sample: hold, lose nothing
        unclamped = feedforward + g.kp * error + self.integral + g.kd * error_rate
        high = saturated_high or unclamped >= g.out_max
        low = saturated_low or unclamped <= g.out_min
        step = g.ki * error * dt_s
        if not ((step > 0 and high) or (step < 0 and low)):
            self.integral = min(g.i_max, max(-g.i_max, self.integral + step))
        out = feedforward + g.kp * error + self.integral + g.kd * error_rate
        self.last_output = min(g.out_max, max(g.out_min, out))
        return self.last_output


class RateLimiter:
    """Limits how fast a value may change (units per second)."""

    def __init__(self, rate_per_s: float, initial: float = 0.0) -> None:
        if not rate_per_s > 0:
            raise ValueError("rate limit must be positive")
        self.rate_per_s = rate_per_s
        self.value = initial

    def reset(self, value: float) -> None:
        self.value = value

    def step(self, target: float, dt_s: float) -> float:
        max_step = self.rate_per_s * dt_s
        self.value += min(max_step, max(-max_step, target - self.value))
        return self.value


class LowPass:
    """First-order low-pass filter with time constant ``tau_s`` (0 passes through)."""

    def __init__(self, tau_s: float, initial: float | None = None) -> None:
        self.tau_s = max(0.0, tau_s)
        self.value = initial

    def step(self, x: float, dt_s: float) -> float:
        if self.value is None or self.tau_s == 0.0:
            self.value = x
        else:
            self.value += (x - self.value) * min(1.0, dt_s / self.tau_s)
        return self.value
