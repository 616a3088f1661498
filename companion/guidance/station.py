"""Station keeping: hold a point against current, bow into the current (active, not drifting).

A water-jet boat cannot go astern or sideways, so station keeping is done the way a coxswain
does it: point the bow into the current and run the jet just enough to cancel it.  A PI law on
the north-east position error gives a desired velocity over ground; its integral is an estimate
of the current (the water velocity to be cancelled)::

    v_g  = sat(-kp * p_err, v_max)              desired velocity over ground
    c^   += -ki * p_err * dt                    (bounded) estimate of minus the current
    w    = v_g + c^                             desired velocity through the water

The desired heading is the direction of ``w`` (into the current once the estimate has
converged) and the desired *surge speed over ground* is the projection of ``v_g`` on that heading;
it may be negative (let the current set the boat back), and the speed controller's integral or
model-error compensation finds the throttle that holds it against the current.  When ``|w|`` is
below ``min_speed_mps`` (slack water, on station) the heading freezes at its last value.
Contrast: ArduPilot Rover's LOITER drifts to the edge of LOIT_RADIUS before driving back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.guidance.geo import wrap_2pi


@dataclass(frozen=True, slots=True)
class StationGains:
    kp_per_s: float = 0.25
    """Position gain: desired ground speed per metre of error (1/s)."""
    ki_per_s2: float = 0.01
    """Integral gain of the current estimate (1/s^2)."""
    v_max_mps: float = 2.0
    """Largest approach speed over ground."""
    current_max_mps: float = 2.0
    """Bound on the current estimate."""
    min_speed_mps: float = 0.15
    """Below this desired water speed the boat idles with its heading frozen."""


@dataclass(frozen=True, slots=True)
class StationOutput:
    heading_rad: float
    surge_speed_mps: float
    """Desired speed over ground along the heading; negative means fall back with the current."""
    distance_m: float
    current_est_ne_mps: tuple[float, float]


class StationKeeper:
    """Keep the boat on ``target_ne`` (north-east metres)."""

    def __init__(self, target_ne: tuple[float, float], gains: StationGains | None = None,
                 initial_heading_rad: float = 0.0) -> None:
        self.target_ne = target_ne
        self.gains = gains or StationGains()
        self.water_ne = [0.0, 0.0]  # -current estimate (what the boat must do through the water)
        self.heading_rad = wrap_2pi(initial_heading_rad)

    @property
    def current_est_ne_mps(self) -> tuple[float, float]:
        return (-self.water_ne[0], -self.water_ne[1])

    def update(self, pos_ne: tuple[float, float], dt_s: float) -> StationOutput:
        g = self.gains
        en, ee = pos_ne[0] - self.target_ne[0], pos_ne[1] - self.target_ne[1]
        dist = math.hypot(en, ee)
        vn, ve = -g.kp_per_s * en, -g.kp_per_s * ee
        vmag = math.hypot(vn, ve)
        if vmag > g.v_max_mps:
            vn, ve = vn * g.v_max_mps / vmag, ve * g.v_max_mps / vmag
        self.water_ne[0] += -g.ki_per_s2 * en * dt_s
        self.water_ne[1] += -g.ki_per_s2 * ee * dt_s
        cmag = math.hypot(*self.water_ne)
        if cmag > g.current_max_mps:
            self.water_ne = [c * g.current_max_mps / cmag for c in self.water_ne]
        wn, we = vn + self.water_ne[0], ve + self.water_ne[1]
        if math.hypot(wn, we) >= g.min_speed_mps:
            self.heading_rad = wrap_2pi(math.atan2(we, wn))
        surge = vn * math.cos(self.heading_rad) + ve * math.sin(self.heading_rad)
        return StationOutput(heading_rad=self.heading_rad, surge_speed_mps=surge, distance_m=dist,
                             current_est_ne_mps=self.current_est_ne_mps)
