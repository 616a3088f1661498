"""Leaving a hold orbit onto AUTO's first leg, as an aircraft leaves a holding pattern (issue 14).

In a current weaker than the jet's idle creep, RTL, LOITER and GUIDED hold their point on a
drift-compensated orbit (:class:`~companion.modes.holding.OrbitTask`).  AUTO entered there used
to start the first leg at once from wherever the orbit had the boat: with the course 90 degrees
off the leg, or pointing the other way, the turn onto it ran at ``USV_WP_TURN_SPD`` and swung the
boat 5-10 m off the line (``docs/tuning.md``).  Instead, AUTO keeps flying the very orbit the hold
was flying (same centre, radius, direction and current feed-forward) until the course points
along the leg, over the ground and through the water alike, then starts the leg from where the
boat is::

    to_go = lam * wrap(beta - chi)          beta: bearing from the boat to the leg's end
                                            chi:  course over ground, lam: +1 clockwise orbit
    to_go_w = lam * wrap(beta - chi_w)      chi_w: course through the water (the velocity over
                                                   ground less the estimated current)
    to_go_b = lam * wrap(beta - psi)        psi: heading
    join when  to_go, to_go_w and to_go_b all lie in [0, USV_WP_JOIN]
                                            or the bow has turned a full orbit
                                            or MAX_WAIT_S have passed

``to_go`` is the turn still to come the orbit's way.  In a current the course over ground and the
course through the water (where the boat turns) differ by up to 30-40 deg on the orbit, and each
alone joined early on one side: over the ground with the current down the leg (the course points
along it while the bow is still across: the leg then finished the turn at speed, 2.0-2.7 m off its
line), through the water with the current against it (2.3 m); both must agree.  And only while the
boat still turns toward the leg: joined just past it (up to 20 deg, as before) the leg had to
reverse the orbit's turn and swung 4.5-7.9 m off; it now keeps the orbit round once more
(``docs/tuning.md``, "Leaving the hold orbit: course over ground and through the water").  Nor
may the bow be past the leg: on the orbit it leads the course by the hull's slip (25 deg at 1.8 m/s
through the water), so a course still short of the leg came with the bow past it; the leg then
reversed a 50 deg/s turn, and in 0.3 m/s with 6 m/s of wind the boat swung 4.4 m off its first leg
(2.2 m waiting for the bow; ``docs/tuning.md``).  The
leg's LOS finishes the turn the same way; with the default 70 deg the boat leaves before the
orbit's far side, 1.9-2.3 m from the point in a 0.5 m/s current, and
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
from companion.guidance.geo import distance_bearing, turn_to_go_rad
from companion.messages import NavState
from companion.modes.holding import OrbitTask

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


def course_rad(nav: NavState, current_ne_mps: tuple[float, float] = (0.0, 0.0)) -> float:
    """Course relative to the water moving at ``current_ne_mps`` (the default: over ground), or the
    heading when the boat barely moves relative to it."""
    north_mps, east_mps = nav.vel_north_mps - current_ne_mps[0], nav.vel_east_mps - current_ne_mps[1]
    if math.hypot(north_mps, east_mps) < COURSE_MIN_SPEED_MPS:
        return nav.heading_rad
    return math.atan2(east_mps, north_mps)


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

    def to_go_rad(self, nav: NavState, current_ne_mps: tuple[float, float] = (0.0, 0.0)) -> float:
        """The turn (rad, the orbit's way) from the course (over ground; through the water with
        the current ``current_ne_mps``) to the bearing of the leg's end."""
        return turn_to_go_rad(self.lam, course_rad(nav, current_ne_mps), self._bearing_rad(nav))

    def _bearing_rad(self, nav: NavState) -> float:
        here = self.frame.to_ne(nav.lat_deg, nav.lon_deg)
        return distance_bearing(self.end_ne[0] - here[0], self.end_ne[1] - here[1])[1]

    def aligned(self, nav: NavState) -> bool:
        """Whether to leave the orbit now (module docstring)."""
        if self._start_s is None:
            self._start_s = nav.t_s
        if nav.t_s - self._start_s >= MAX_WAIT_S:
            return True
        if self._last_heading_rad is not None:
            self.turned_rad += turn_to_go_rad(self.lam, self._last_heading_rad, nav.heading_rad)
        self._last_heading_rad = nav.heading_rad
        bearing_rad = self._bearing_rad(nav)
        directions_rad = (course_rad(nav), course_rad(nav, self.orbit.current()), nav.heading_rad)
        turning_toward = all(0.0 <= turn_to_go_rad(self.lam, d, bearing_rad) <= self.tolerance_rad
                             for d in directions_rad)
        return turning_toward or abs(self.turned_rad) >= FULL_ORBIT_RAD

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        target = self.orbit.step(nav, dt_s)
        self.distance_m = math.dist(self.end_ne, self.frame.to_ne(nav.lat_deg, nav.lon_deg))
        return target
