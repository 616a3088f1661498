"""Ferry glide: keeping station bow into a current the idling jet outruns (issue 14).

A water jet idles with thrust, so the slowest the boat goes through the water is its idle creep,
and wind from astern adds to it (1.1-1.5 m/s with 6 m/s of wind against a 1.2 m/s current, in
the simulator).  Bow straight into a current weaker than that, the idling boat creeps up the
current past its point and nothing slows it: the station keeper asked for less speed than the jet
makes, the jet idled, and the boat crept 2 m upstream before the bow came off the line
(``docs/tuning.md``).

So while the jet idles and the desired water velocity ``w`` (the station keeper's, see
:class:`~companion.guidance.holding.CurrentStationKeeper`) is slower than the idling boat's speed
through the water ``U`` by more than :data:`FERRY_MARGIN_MPS`, the bow is set off upstream by::

    off = min(acos((w_up + margin) / U), FERRY_MAX_RAD)

so that the upstream component of the idling boat's water velocity, ``U cos(off)``, is about what
the keeper wants, as a ferry crossing a river sets its bow.  The boat then crosses the current at
``U sin(off)``; the side follows ``w``'s component across the current, led by the boat's ground
velocity over :data:`FERRY_LEAD_S` (at idle the bow needs 4-8 s to swing from one side to the
other: without the lead it weaved 2 m either side of its point), and stays the bow's side while
that is within :data:`FERRY_SIDE_MPS` of nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.guidance.current import water_speed_mps
from companion.guidance.geo import wrap_pi

FERRY_MAX_RAD = math.radians(20.0)
"""Largest ferry angle off upstream: the idle bow swings slowly, and the cross-current speed
``U sin(off)`` sets how far the boat weaves (in-process, 1.2 m/s against 6 m/s of wind: 30 deg
2.95 m off, 20 deg 0.97 m; ``docs/tuning.md``)."""
FERRY_MARGIN_MPS = 0.1
"""The ferry angle starts once the desired water speed is this far below the idle speed (a
margin for the idle speed's waves; without it and the idle gate the bow left the current in holds
the jet already held within 0.3-0.5 m)."""
FERRY_LEAD_S = 4.0
"""The side is chosen on where the boat will be this long ahead (s) at its present ground velocity
(in-process: 2 s held 1.28 m, 4 s 0.97 m; none 2.08 m)."""
FERRY_SIDE_MPS = 0.05
"""Dead band (m/s) of the desired water velocity across the current, within which the bow keeps
its side (0.2 m of position error at the keeper's 0.25 1/s)."""
IDLE_WATER_TAU_S = 2.0
"""Time constant (s) of :class:`IdleWater`."""


@dataclass(frozen=True, slots=True)
class IdleDrift:
    """How the boat moves while its jet idles: the input of the ferry glide."""

    idle_water_mps: float
    """The idling boat's speed through the water (m/s)."""
    vel_ne_mps: tuple[float, float]
    """Its velocity over ground (north, east m/s)."""


class IdleWater:
    """The idling boat's speed through the water, low-passed over ``tau_s`` while the jet idles
    (wind from astern adds to the creep).  The first idling sample sets it, never below
    ``creep_mps`` (``USV_HOLD_CREEP``): a keeper started under power then ferries at once, before
    :func:`~companion.modes.creep.creeping_up` gives it up (``docs/tuning.md``, "The ferry
    glide's idle speed starts from the first idling sample")."""

    def __init__(self, creep_mps: float, tau_s: float = IDLE_WATER_TAU_S) -> None:
        self.speed_mps = creep_mps
        self.tau_s = tau_s
        self.idled = False
        """Whether the jet has idled since the keeper started."""

    def update(self, idling: bool, vel_ne_mps: tuple[float, float], current_ne_mps: tuple[float, float],
               dt_s: float) -> IdleDrift | None:
        """The ferry glide's input while the jet idles (``None`` while it pushes)."""
        if not idling:
            return None
        water_mps = water_speed_mps(*vel_ne_mps, current_ne_mps)
        if self.idled:
            self.speed_mps += (water_mps - self.speed_mps) * min(1.0, dt_s / self.tau_s)
        else:
            self.idled = True
            self.speed_mps = max(self.speed_mps, water_mps)
        return IdleDrift(self.speed_mps, vel_ne_mps)


def holds_at_the_point(current_mps: float, drift: IdleDrift) -> bool:
    """Whether the ferry glide's largest angle can stand the idling boat on its point: bow
    :data:`FERRY_MAX_RAD` off upstream, the idling boat makes at most the current (plus the
    margin) up it, ``U cos(FERRY_MAX_RAD) <= |V_c| + margin``."""
    return drift.idle_water_mps * math.cos(FERRY_MAX_RAD) <= current_mps + FERRY_MARGIN_MPS


def ferry_heading(upstream_rad: float, w_ne_mps: tuple[float, float], bow_off_rad: float,
                  drift: IdleDrift, kp_per_s: float, current_mps: float | None = None) -> float | None:
    """The ferry-glide heading (rad) for the desired water velocity ``w`` (north, east m/s) of a
    keeper whose position gain is ``kp_per_s`` and whose bow is ``bow_off_rad`` off upstream, or
    ``None`` where the keeper's own heading serves (``w`` at least the idle speed less the margin,
    or pointing downstream of across); given the current's speed ``current_mps``, also ``None``
    where no ferry angle can stand the boat on its point (:func:`holds_at_the_point`)."""
    up_n, up_e = math.cos(upstream_rad), math.sin(upstream_rad)
    w_up = w_ne_mps[0] * up_n + w_ne_mps[1] * up_e
    if math.hypot(*w_ne_mps) + FERRY_MARGIN_MPS >= drift.idle_water_mps or w_up <= 0.0:
        return None
    if current_mps is not None and not holds_at_the_point(current_mps, drift):
        return None
    off = min(math.acos((w_up + FERRY_MARGIN_MPS) / drift.idle_water_mps), FERRY_MAX_RAD)
    lead_n = w_ne_mps[0] - kp_per_s * FERRY_LEAD_S * drift.vel_ne_mps[0]
    lead_e = w_ne_mps[1] - kp_per_s * FERRY_LEAD_S * drift.vel_ne_mps[1]
    across = up_n * lead_e - up_e * lead_n  # positive: clockwise of upstream
    side = math.copysign(1.0, across if abs(across) > FERRY_SIDE_MPS else wrap_pi(bow_off_rad))
    return upstream_rad + side * off
