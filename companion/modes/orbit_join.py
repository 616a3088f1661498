"""Leaving a hold orbit onto AUTO's first leg, as an aircraft leaves a holding pattern (issue 14).

In a current weaker than the jet's idle creep, RTL, LOITER and GUIDED hold their point on a
drift-compensated orbit (:class:`~companion.modes.holding.OrbitTask`).  AUTO entered there used
to start the first leg at once from wherever the orbit had the boat: with the course 90 degrees
off the leg, or pointing the other way, the turn onto it ran at ``USV_WP_TURN_SPD`` and swung the
boat 5-10 m off the line (``docs/tuning.md``).  Instead, AUTO keeps flying the very orbit the hold
was flying (same centre, radius, direction and current feed-forward) until the course over ground
points along the leg, then starts the leg from where the boat is::

    to_go = lam * wrap(beta - chi)          beta: bearing from the boat to the leg's end
                                            chi:  course over ground, lam: +1 clockwise orbit
    join when  -PAST_RAD <= to_go <= USV_WP_JOIN     or the bow has turned a full orbit
                                                     or MAX_WAIT_S have passed

``to_go`` is the turn still to come the orbit's way; the join happens while the boat is still
turning toward the leg (the leg's LOS finishes the turn the same way: with the default 70 deg the
boat leaves before the orbit's far side, 1.9-2.3 m from the point in a 0.5 m/s current), and
after at most one orbit (about 12 s at ``USV_HOLD_ORB_SPD`` 1 m/s on ``USV_TURN_RAD`` 2 m) it
joins wherever it is.  AUTO entered from rest or from a straight run starts at once, as
ArduRover's does: only a hold orbit handed over by the previous mode is continued, and only while
the boat is on it (within :data:`ON_ORBIT_M` of its circle).  A boat that drifted off the orbit
(disarmed in RTL, then armed again: in a 0.5 m/s current it drifts 50 m in 100 s) would otherwise
have to run back to the orbit before it could line up, and AUTO would wait on that return.
"""

from __future__ import annotations

import math

from companion.control.target import ControlTarget
from companion.guidance.geo import distance_bearing, wrap_pi
from companion.messages import NavState
from companion.modes.holding import OrbitTask

PAST_RAD = math.radians(20.0)
"""A course this far past the leg's bearing (the orbit's way) still joins at once."""
FULL_ORBIT_RAD = 2.0 * math.pi
"""The join gives up waiting after the bow has turned this far."""
COURSE_MIN_SPEED_MPS = 0.3
"""Below this speed over ground the heading stands in for the (noisy) course."""
LEAVING_ORBIT_TEXT = "AUTO: leaving the orbit onto the first leg"
"""Start of the STATUSTEXT that ends the wait (``usv bench nav`` starts the first leg there)."""
ON_ORBIT_M = 2.0
"""AUTO waits on the orbit only if the boat is this close to the orbit's circle."""
MAX_WAIT_S = 20.0
"""Never longer than this (vehicle time; one orbit is about 12 s at ``USV_HOLD_ORB_SPD`` 1 m/s on
``USV_TURN_RAD`` 2 m): a boat swept off the orbit while waiting still starts its mission."""
MIN_LEG_RADII = 5.0
"""A first waypoint closer than this many orbit radii is gone to at once (from inside or near the
orbit the bearing to it swings round with the boat and may never line up with the course)."""


def course_rad(nav: NavState) -> float:
    """Course over ground, or the heading when the boat barely moves."""
    moving = nav.speed_over_ground_mps >= COURSE_MIN_SPEED_MPS
    return nav.course_over_ground_rad if moving else nav.heading_rad


class OrbitJoin:
    """Keep flying ``orbit`` until the course points along the leg to ``target`` (lat, lon)."""

    def __init__(self, orbit: OrbitTask, target: tuple[float, float], tolerance_rad: float) -> None:
        self.orbit = orbit
        self.frame = orbit.frame
        self.point = target
        self.end_ne = self.frame.to_ne(*target)
        """The leg's end in the orbit's frame (north, east m from the orbit's centre)."""
        self.tolerance_rad = tolerance_rad
        self.lam = orbit.orbit.lam
        self.turned_rad = 0.0
        self.distance_m = math.inf
        self.cross_track_m = 0.0
        self._last_heading_rad: float | None = None
        self._start_s: float | None = None

    def worth_waiting(self, nav: NavState) -> bool:
        """Whether the boat is on the orbit (:data:`ON_ORBIT_M`) and the leg's end far enough for a
        wait there (:data:`MIN_LEG_RADII`)."""
        here = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        on_orbit = abs(math.hypot(*here) - self.orbit.radius_m) <= ON_ORBIT_M
        far = math.dist(self.end_ne, here) > MIN_LEG_RADII * self.orbit.radius_m
        return on_orbit and far

    def to_go_rad(self, nav: NavState) -> float:
        """The turn (rad, the orbit's way) from the course to the bearing of the leg's end."""
        here = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        bearing = distance_bearing(self.end_ne[0] - here[0], self.end_ne[1] - here[1])[1]
        return self.lam * wrap_pi(bearing - course_rad(nav))

    def aligned(self, nav: NavState) -> bool:
        """Whether to leave the orbit now (module docstring)."""
        if self._start_s is None:
            self._start_s = nav.t_s
        if nav.t_s - self._start_s >= MAX_WAIT_S:
            return True
        if self._last_heading_rad is not None:
            self.turned_rad += self.lam * wrap_pi(nav.heading_rad - self._last_heading_rad)
        self._last_heading_rad = nav.heading_rad
        to_go = self.to_go_rad(nav)
        return -PAST_RAD <= to_go <= self.tolerance_rad or abs(self.turned_rad) >= FULL_ORBIT_RAD

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        target = self.orbit.step(nav, dt_s)
        self.distance_m = math.dist(self.end_ne, self.frame.to_ne(nav.lat_deg, nav.lon_deg))
        return target
