"""How a boat keeping station in a current turns its bow onto the heading the station keeper
(:class:`~companion.guidance.holding.CurrentStationKeeper`) wants: :class:`KeeperTurn`, the rules
every task that holds a point bow into the current shares (LOITER, GUIDED and RTL on their point,
:class:`~companion.modes.holding.CurrentStationTask`; the hold on a sampling circle,
:class:`~companion.modes.stem_hold.StemHold`).

A water jet has no reverse and turns only while it pushes: at idle the bow comes round slowly and a
current sweeps the boat downstream while it turns, and a turn reversed at speed runs the boat on
straight.  So a large turn is made under power, the way the boat already turns, except upstream of
the point, where the current brings the boat back while it turns at idle.  The powered turn is
commanded through the water and steered by the controller of a boat making way, not by station
keeping's (``docs/tuning.md``): a boat running down a 1.2 m/s current at 3-4 m/s over ground, bow
downstream, was asked the corner speed over ground, so station keeping's PID speed loop idled the
jet, which then hardly turned, and the current swept the boat 40 m past its point in 15 s.
"""

from __future__ import annotations

import math

from companion.guidance.geo import along_across_m, wrap_pi
from companion.guidance.holding import KEEP_TURN_RADPS
from companion.guidance.waypoints import UTurnLatch

POWERED_TURN_RAD = math.radians(60.0)
"""The bow turns at the powered-turn speed (the corner speed, ``USV_WP_TURN_SPD``) while it is
farther than this off the keeper's heading and the boat is being carried downstream, unless it is
more than :data:`UPSTREAM_IDLE_M` upstream of its point (``docs/tuning.md``)."""
UPSTREAM_IDLE_M = 1.0


def downstream_speed_mps(vel_ne_mps: tuple[float, float], current_ne_mps: tuple[float, float]) -> float:
    """The component of a velocity over ground (north, east m/s) along the current."""
    return along_across_m(vel_ne_mps, (0.0, 0.0), current_ne_mps)[0]


class KeeperTurn:
    """The heading and surge a holding task commands for the station keeper's output.

    * Farther than :data:`POWERED_TURN_RAD` off the keeper's heading, while the boat moves
      downstream over ground, the turn is powered (:attr:`powered`): the surge is at least
      ``powered_turn_mps`` through the water, over ground that plus the current along the bow
      (``powered_turn_mps`` ``None``: never, below the idle creep, where the creep turns the
      boat), unless the boat is more than :data:`UPSTREAM_IDLE_M` upstream of its point.  A boat
      moving upstream (an arrival running on past its point) or well upstream of it turns at idle:
      the current brings it back, and a powered turn would drive it farther up.
    * A U-turn (:class:`~companion.guidance.waypoints.UTurnLatch`) starts the way the boat already
      turns when it turns faster than :data:`~companion.guidance.holding.KEEP_TURN_RADPS`, else the
      way of the heading error, and keeps that way."""

    def __init__(self, powered_turn_mps: float | None) -> None:
        self.powered_turn_mps = powered_turn_mps
        self.u_turn = UTurnLatch()
        self.powered = False
        """The last command was a powered turn: the holding task hands it to the controller of a
        boat making way (``ControlTarget.hold_station`` False)."""

    def command(self, keeper_heading_rad: float, surge_mps: float, heading_rad: float,
                yaw_rate_radps: float, downstream_m: float, downstream_mps: float,
                current_along_bow_mps: float = 0.0) -> tuple[float, float]:
        """Heading (rad) and surge over ground (m/s) to command, for the keeper's heading and surge,
        the boat's heading and yaw rate, how far it is downstream of its point
        (:func:`along_across_m`; negative: upstream), how fast it moves downstream over ground
        (negative: upstream) and the current's component along the bow (m/s, positive from astern;
        :func:`~companion.angles.current_along_mps`)."""
        err = wrap_pi(keeper_heading_rad - heading_rad)
        speed = surge_mps
        self.powered = (self.powered_turn_mps is not None and abs(err) > POWERED_TURN_RAD
                        and downstream_m > -UPSTREAM_IDLE_M and downstream_mps > 0.0)
        if self.powered and self.powered_turn_mps is not None:
            speed = max(speed, self.powered_turn_mps + current_along_bow_mps)
        turning = abs(yaw_rate_radps) > KEEP_TURN_RADPS
        latched = self.u_turn.heading(err, heading_rad,
                                      lambda: math.copysign(1.0, yaw_rate_radps if turning else err))
        return (keeper_heading_rad if latched is None else latched), speed
