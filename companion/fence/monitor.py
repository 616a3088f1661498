"""Breach logic: where the boat would stop, and breach episodes (count, time) as FENCE_STATUS reports them.

The boat is stopped *before* it leaves an inclusion zone or enters an exclusion zone: the check
looks at the point the boat reaches before a fence action can take effect,

    L = V * t_react + V / r_max        (lookahead, m)

with V the speed over ground (the current's drift included), ``t_react`` = USV_FENCE_REACT
(detection to action) and ``V / r_max`` the turning radius at the turn rate USV_FENCE_YAWR: the
way a water-jet boat stops short of a line is to turn away (RTL), which carries it about one
turning radius further (coasting straight is far longer: 49 m from 2.7 m/s in SITL, see the README).
The predicted point is ``p + L * v / V`` along the course over ground.  A breach is the predicted
point or the boat itself closer than FENCE_MARGIN to a boundary (clearance, :mod:`.zones`); it
clears when both are FENCE_MARGIN + :data:`CLEAR_HYSTERESIS_M` away again, so a boat sitting at
the margin does not flicker between breach and clear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.fence.zones import NO_FENCE, Fence, Zone

CLEAR_HYSTERESIS_M = 1.0
"""A breach clears only this far beyond FENCE_MARGIN."""
MIN_SPEED_MPS = 0.05
"""Below this the course over ground is noise: only the boat's own position is checked."""


def lookahead_m(speed_mps: float, react_s: float, yaw_rate_radps: float) -> float:
    """L = V t_react + V / r_max (module doc)."""
    if not math.isfinite(speed_mps) or speed_mps <= 0.0:
        return 0.0
    return speed_mps * react_s + speed_mps / max(1e-3, yaw_rate_radps)


@dataclass(frozen=True, slots=True)
class FenceCheck:
    """One look at the fence: clearances (m, negative outside) now and at the predicted stop point."""

    clearance_m: float
    predicted_clearance_m: float
    lookahead_m: float
    zone: Zone | None
    """The zone that limits the smaller of the two clearances."""

    @property
    def outside(self) -> bool:
        """The boat itself is beyond a boundary."""
        return self.clearance_m < 0.0

    @property
    def worst_m(self) -> float:
        return min(self.clearance_m, self.predicted_clearance_m)


def check_fence(fence: Fence, lat_deg: float, lon_deg: float, vel_north_mps: float, vel_east_mps: float,
                react_s: float, yaw_rate_radps: float) -> FenceCheck:
    """Clearances of the boat and of its predicted stop point (module doc)."""
    p = fence.to_ne(lat_deg, lon_deg)
    now_m, now_zone = fence.clearance_m(p)
    speed = math.hypot(vel_north_mps, vel_east_mps)
    if not math.isfinite(speed) or speed < MIN_SPEED_MPS:
        return FenceCheck(now_m, now_m, 0.0, now_zone)
    ahead_m = lookahead_m(speed, react_s, yaw_rate_radps)
    q = (p[0] + ahead_m * vel_north_mps / speed, p[1] + ahead_m * vel_east_mps / speed)
    pred_m, pred_zone = fence.clearance_m(q)
    return FenceCheck(now_m, pred_m, ahead_m, now_zone if now_m <= pred_m else pred_zone)


class FenceMonitor:
    """Breach episodes of one fence: :meth:`update` says when a new one starts."""

    def __init__(self) -> None:
        self.fence: Fence = NO_FENCE
        self.breached = False
        self.breach_count = 0
        self.breach_time_s: float | None = None
        self.last: FenceCheck | None = None

    def set_fence(self, fence: Fence) -> None:
        """A new FENCE plan: the episode in progress ends (the count is kept)."""
        self.fence = fence
        self.breached = False
        self.last = None

    def update(self, check: FenceCheck, margin_m: float, now_s: float) -> bool:
        """Record ``check``; ``True`` when it starts a new breach episode."""
        self.last = check
        if not self.breached and check.worst_m < margin_m:
            self.breached = True
            self.breach_count += 1
            self.breach_time_s = now_s
            return True
        if self.breached and check.worst_m >= margin_m + CLEAR_HYSTERESIS_M:
            self.breached = False
        return False
