"""A U-turn onto a leg from station keeping in a strong current, centred on the leg's line.

A jet cannot turn on the spot: a U-turn runs round a circle of about one turning radius ``R`` in
the water, so it sets the boat one turning diameter beside where it started (from a hold in
1.2 m/s, 3.2 m on the lockstep SITL; in the grid's flights 4-6 m with the swing back across the
line after it).  With the bow held into a current stronger than the idle creep the boat can move
sideways first: the station keeper ferries it ``offset`` to the side away from the turn, so the
turn runs from ``offset`` on one side of the line to about ``2 R - offset`` on the other::

    n      = (cos(psi + s pi/2), sin(psi + s pi/2))     toward the turning circle's centre
    side   = start - offset * n                          where the turn starts

with ``psi`` the heading and ``s`` the turn's direction (+1 starboard), as
:func:`companion.guidance.waypoints.u_turn_sign` picks it.  In a weaker current the boat cannot
stand still to do this (it orbits instead, and AUTO joins the first leg from the orbit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.angles import upstream_rad
from companion.control.target import ControlTarget
from companion.guidance.geo import wrap_pi
from companion.guidance.holding import CurrentStationGains, CurrentStationKeeper

Point = tuple[float, float]

SIDESTEP_DONE_M = 0.8
"""The side step is done when the boat has moved to within this of the offset sideways (how far
the current carries it along the leg meanwhile does not matter: the leg runs down the current) ...
The boat goes on moving sideways while its bow straightens up the current: with 0.3 m it ended up
to 1.1 m past the offset, and the turn ran from 3.2 m beside the line (``docs/tuning.md``)."""
SIDESTEP_BOW_RAD = math.radians(15.0)
"""... and, there, the bow is back within this of upstream (the keeper angles it to ferry the boat
aside, away from the turn: a turn started from there is that much longer, and in 1.2 m/s with
6 m/s of wind from astern the slow pivot never got round: the wind turned the boat the other way
and the leg ran off 90 m up the wind) ..."""
SIDESTEP_MAX_S = 15.0
"""... or after this long (a keeper that cannot reach it: the turn starts from where it is)."""
SIDESTEP_MAX_SOG_MPS = 1.0
"""Only a boat this slow over ground is keeping station: one under way turns as it is.  In waves
of Hs 0.3 m a boat holding station bow into 1.2 m/s reads 0.5-0.8 m/s over ground (0.5 m/s let
a hold in the grid's flood start its U-turn where it was, and the boat went 3.9-4.0 m off the
square)."""


def away_from_turn(heading_rad: float, turn_sign: float) -> tuple[float, float]:
    """Unit vector (north, east) from the turning circle's centre side of a boat on ``heading_rad``
    turning ``turn_sign`` (+1 starboard): the way the side step goes."""
    toward_centre = heading_rad + turn_sign * 0.5 * math.pi
    return (-math.cos(toward_centre), -math.sin(toward_centre))


def sidestep_point(pos_ne: Point, heading_rad: float, turn_sign: float, offset_m: float) -> Point:
    """Where a U-turn in direction ``turn_sign`` (+1 starboard) starts so that it spans the line
    through ``pos_ne`` along the bow: ``offset_m`` away from the turning circle's side."""
    away = away_from_turn(heading_rad, turn_sign)
    return (pos_ne[0] + offset_m * away[0], pos_ne[1] + offset_m * away[1])


@dataclass
class SideStep:
    """Keep station on ``point_ne`` (bow into the current) until the boat has moved ``offset_m``
    sideways from ``start_ne`` (along ``away``)."""

    start_ne: Point
    away: tuple[float, float]
    offset_m: float
    keeper: CurrentStationKeeper
    elapsed_s: float = 0.0
    done: bool = False

    @classmethod
    def start(cls, pos_ne: Point, heading_rad: float, turn_sign: float, offset_m: float,
              gains: CurrentStationGains) -> SideStep:
        away = away_from_turn(heading_rad, turn_sign)
        point = sidestep_point(pos_ne, heading_rad, turn_sign, offset_m)
        return cls(pos_ne, away, offset_m, CurrentStationKeeper(point, heading_rad, gains))

    @property
    def point_ne(self) -> Point:
        return self.keeper.target_ne

    def moved_m(self, pos_ne: Point) -> float:
        """How far the boat has moved sideways, the way the side step goes."""
        return (pos_ne[0] - self.start_ne[0]) * self.away[0] + (pos_ne[1] - self.start_ne[1]) * self.away[1]

    def step(self, pos_ne: Point, heading_rad: float, current_ne_mps: tuple[float, float],
             dt_s: float) -> ControlTarget:
        """The station keeper's target; once the boat is within :data:`SIDESTEP_DONE_M` of the
        offset sideways, the bow straightened up the current.  Sets :attr:`done` when the boat is
        aside with its bow within :data:`SIDESTEP_BOW_RAD` of upstream, or after
        :data:`SIDESTEP_MAX_S`."""
        self.elapsed_s += dt_s
        out = self.keeper.update(pos_ne, current_ne_mps, dt_s)
        heading = out.heading_rad
        if self.moved_m(pos_ne) > self.offset_m - SIDESTEP_DONE_M:
            heading = upstream_rad(current_ne_mps)
            self.done = abs(wrap_pi(heading_rad - heading)) < SIDESTEP_BOW_RAD
        self.done = self.done or self.elapsed_s > SIDESTEP_MAX_S
        return ControlTarget(heading, out.surge_speed_mps, is_heading=True, hold_station=True)
