"""Waypoint path following: legs between consecutive points, switching, and corner slow-down.

A :class:`LegNavigator` follows the straight leg from the previous waypoint to the current one
with :class:`~companion.guidance.los.LosFollower` (ILOS/ALOS) and reports when the waypoint is
reached.  Reaching uses the acceptance radius (ArduPilot WP_RADIUS) *or* passing the end of the
leg (along-track beyond its length), so a boat pushed wide by current never circles back for a
waypoint.  Before a corner it slows to ``turn_speed_mps`` so that the turn radius (U / r_max)
keeps the corner cut small, and it switches to the next leg one turn radius early (turn
anticipation) so that the turn is an arc tangent to both legs.  The radius of that arc is the one
the boat will actually turn on: ``U / r_max`` at the larger of the planned corner speed and the
measured speed over ground (waves, a following current or a lagging speed loop can bring the boat
to the corner faster than planned; an anticipation sized for the planned speed then swings it
metres wide of the next leg).  A mission item's own acceptance radius caps the anticipation so
that the corner is passed within it (:func:`lead_for_cut_m`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from companion.angles import current_along_mps
from companion.control.target import ControlTarget
from companion.guidance.geo import wrap_2pi, wrap_pi
from companion.guidance.los import LegErrors, LosFollower

Point = tuple[float, float]


@dataclass(frozen=True, slots=True)
class LegConfig:
    speed_mps: float = 5.0
    accept_radius_m: float = 2.0
    turn_speed_mps: float = 2.5
    """Speed through corners of more than ``sharp_turn_rad``."""
    sharp_turn_rad: float = math.radians(30.0)
    turn_rate_max_radps: float = math.radians(45.0)
    decel_mps2: float = 0.25
    """Planned deceleration before a corner (sets where slowing starts).  0.4 m/s^2 was more than the
    jet (no reverse: drag only) makes at 4-5 m/s: in 1.2 m/s of cross current the boat came into the
    first corner at 4.6 m/s instead of 2 and overshot it by 3.3 m (0.25: 2.0 m, usv bench nav)."""
    yaw_lag_s: float = 2.5
    """Time the boat needs to build up its turn rate; the turn starts this much earlier."""
    corner_cut_max_m: float | None = None
    """A mission item's own acceptance radius (m): the corner's anticipation is capped so the boat
    passes the waypoint within it (:func:`lead_for_cut_m`); ``None`` (WP_RADIUS): no cap."""
    arrive_short_m: float = 0.0
    """Before the last point (no next one) the boat is down to ``turn_speed_mps`` this far short of
    it, where the caller hands over to what comes next (a circle item's circle law or hold)."""


@dataclass(frozen=True, slots=True)
class LegStep:
    target: ControlTarget
    errors: LegErrors
    reached: bool


def turn_angle_rad(p0: Point, p1: Point, p2: Point) -> float:
    """Absolute change of path angle at ``p1`` when going p0 -> p1 -> p2."""
    a = math.atan2(p1[1] - p0[1], p1[0] - p0[0])
    b = math.atan2(p2[1] - p1[1], p2[0] - p1[0])
    return abs(wrap_pi(b - a))


def drift_lead_m(p0: Point, p1: Point, p2: Point, current_ne_mps: tuple[float, float],
                 turn_s: float) -> float:
    """Extra turn anticipation (m) at ``p1`` for the drift of a turn lasting ``turn_s`` in a current.

    The water-relative turn ends on the new leg when the start of the turn is moved back along the
    old leg (unit ``a``) by the drift across the new leg (normal ``m`` with ``a . m > 0``)::

        dL = (c . m) T / (a . m)

    positive (turn earlier) when the current sets the boat past the new leg, negative when it sets
    it back; the sum with the calm-water lead is kept >= 0 by the caller.
    """
    an, ae = p1[0] - p0[0], p1[1] - p0[1]
    bn, be = p2[0] - p1[0], p2[1] - p1[1]
    la, lb = math.hypot(an, ae), math.hypot(bn, be)
    if la < 1e-9 or lb < 1e-9:
        return 0.0
    an, ae, bn, be = an / la, ae / la, bn / lb, be / lb
    mn, me = -be, bn  # normal of the new leg
    a_m = an * mn + ae * me
    if abs(a_m) < 0.2:  # (nearly) straight on: no corner to plan
        return 0.0
    return (current_ne_mps[0] * mn + current_ne_mps[1] * me) * turn_s / a_m


MIN_WATER_SPEED_MPS = 0.3
"""Below this speed through the water on either leg the crab heading is not defined."""


def water_corner_lead_m(p0: Point, p1: Point, p2: Point, current_ne_mps: tuple[float, float],
                        entry_speed_mps: float, corner_speed_mps: float, turn_rate_radps: float,
                        yaw_lag_s: float) -> float | None:
    """Turn anticipation (m before ``p1``) for the corner p0 -> p1 -> p2 planned on the water-relative
    path; ``None`` where that path is not defined (then :func:`drift_lead_m` on the calm-water lead).

    In a current the bow does not turn through the corner's angle: it turns from the old leg's crab
    heading ``th0`` (water velocity ``w0 = U_in a - c`` at the entry speed over ground ``U_in``) to
    the new leg's ``th1`` (``w1 = v b - c`` at the corner speed ``v``), on an arc drawn in the water
    over ``turn_rate_radps``, while the current carries the boat ``c T`` over the arc's ``T =
    |th1 - th0| / r``.  The arc's water speed is the calm-water one changed by the mean of what the
    current does to it at the turn's start and end, ``U = U_in + ((|w0| - U_in) + (|w1| - v)) / 2``
    (down a new leg the boat turns slower through the water, and tighter).  Before the arc the yaw
    lag ``t_l = yaw_lag_s turn / pi`` (the path's turn, as in calm water) runs on along the old leg
    at ``v`` over ground (that speed already has the current in it).  The sum, ``s`` the turn's
    sign::

        dp = (U / (r s)) (sin th1 - sin th0, cos th0 - cos th1) + c T + v t_l a

    ends on the new leg's line when the turn starts ``L = (m . dp) / (m . a)`` before the corner
    (``m`` the new leg's normal).  In calm water that is ``R tan(turn / 2) + v t_l``, the calm-water
    anticipation of :class:`LegNavigator`."""
    an, ae = p1[0] - p0[0], p1[1] - p0[1]
    bn, be = p2[0] - p1[0], p2[1] - p1[1]
    la, lb = math.hypot(an, ae), math.hypot(bn, be)
    if la < 1e-9 or lb < 1e-9:
        return None
    an, ae, bn, be = an / la, ae / la, bn / lb, be / lb
    mn, me = -be, bn
    a_m = an * mn + ae * me
    if abs(a_m) < 0.2:  # (nearly) straight on or back: no corner arc to plan
        return None
    sign = math.copysign(1.0, an * be - ae * bn)  # +1: the path turns right (clockwise)
    cn, ce = current_ne_mps
    w0 = (entry_speed_mps * an - cn, entry_speed_mps * ae - ce)
    w1 = (corner_speed_mps * bn - cn, corner_speed_mps * be - ce)
    u0, u1 = math.hypot(*w0), math.hypot(*w1)
    if min(u0, u1) < MIN_WATER_SPEED_MPS:
        return None
    th0, th1 = math.atan2(w0[1], w0[0]), math.atan2(w1[1], w1[0])
    turn_rad = wrap_pi(th1 - th0)
    if turn_rad * sign <= 0.0:  # the bow would turn against the path: the current dominates
        return None
    arc_speed_mps = max(MIN_WATER_SPEED_MPS,
                        entry_speed_mps + 0.5 * ((u0 - entry_speed_mps) + (u1 - corner_speed_mps)))
    arc_m = arc_speed_mps / turn_rate_radps * sign
    turn_s = abs(turn_rad) / turn_rate_radps
    lag_m = corner_speed_mps * yaw_lag_s * turn_angle_rad(p0, p1, p2) / math.pi
    dn = arc_m * (math.sin(th1) - math.sin(th0)) + cn * turn_s + lag_m * an
    de = arc_m * (math.cos(th0) - math.cos(th1)) + ce * turn_s + lag_m * ae
    return (mn * dn + me * de) / a_m


def lead_for_cut_m(cut_m: float, radius_m: float) -> float:
    """The longest turn anticipation (m) before a corner that passes it within ``cut_m``.

    The tightest path from the switch is a turn at once on ``radius_m`` from the old leg: its
    circle's centre is ``sqrt(L^2 + R^2)`` from the corner, so it passes the corner at
    ``sqrt(L^2 + R^2) - R``; that is ``cut_m`` for ``L = sqrt(cut_m^2 + 2 cut_m R)``.  A boat that
    builds up its turn rate later turns after the switch and passes closer.
    """
    return math.sqrt(cut_m * cut_m + 2.0 * cut_m * radius_m)


U_TURN_RAD = math.radians(135.0)
"""A heading error beyond this is a U-turn: its direction is chosen, not left to the sign of noise."""
U_TURN_DONE_RAD = math.radians(90.0)
"""The chosen direction is kept until the heading error is below this."""


U_TURN_PROGRESS_RAD = math.radians(20.0)
U_TURN_STALL_S = 10.0
"""A latched U-turn that has not closed the heading error by U_TURN_PROGRESS_RAD for U_TURN_STALL_S
turns the other way: the slow pivot (:func:`pivot_speed_mps`) can lack the thrust to turn against
6 m/s of wind from astern, which turned the boat the other way while the latch held, and the leg
ran off 90 m up the wind (in-process, 1.2 m/s with the wind against the current)."""

PIVOT_DONE_RAD = math.radians(45.0)
"""A U-turn onto a leg runs slowly (:func:`pivot_speed_mps`) until the heading error is below this."""


def pivot_speed_mps(water_speed_mps: float, heading_rad: float,
                    current_ne_mps: tuple[float, float] | None) -> float:
    """Speed over ground (>= 0) that is ``water_speed_mps`` through the water on ``heading_rad``:
    the water speed plus the current along the bow (the water speed itself without an estimate).

    A jet turns on the smallest circle slowly (radius U_w / r_max: about 1.3 m at 1 m/s), and the
    circle is drawn in the water, so a U-turn with the bow into a 1.2 m/s current is commanded at
    0 over ground (the current carries the boat down the leg), and at 2.2 m/s once it points down
    the current.  Commanding the corner speed over ground instead asks 3.2 m/s through the water
    with the bow upstream: the turn then spans a 5-7 m circle (``docs/tuning.md``)."""
    return max(0.0, water_speed_mps + current_along_mps(heading_rad, current_ne_mps))


class UTurnLatch:
    """Keeps a U-turn going the way it started: a heading error beyond :data:`U_TURN_RAD` latches a
    direction, which holds until the error is below :data:`U_TURN_DONE_RAD` (near 180 deg the
    error's sign flips with every wave, and the boat ran on straight).  The caller picks the
    direction (:func:`u_turn_sign` for a leg; the way the boat turns for a hold)."""

    def __init__(self) -> None:
        self.sign = 0.0
        """+1 (clockwise) / -1 while a U-turn is latched, 0 otherwise."""
        self._closest_rad = math.inf
        self._closest_t_s = 0.0

    def heading(self, err_rad: float, heading_rad: float, pick_sign: Callable[[], float],
                t_s: float | None = None) -> float | None:
        """For the heading error ``err_rad`` of a boat on ``heading_rad``: the heading to command
        instead of the target's (the latched way round), or ``None`` to follow the target.
        ``pick_sign`` is called when a U-turn starts (0: none is latched).  With the time ``t_s``,
        a latched turn that has not brought the error :data:`U_TURN_PROGRESS_RAD` lower for
        :data:`U_TURN_STALL_S` goes the other way (:meth:`_stalled`)."""
        if self.sign == 0.0 and abs(err_rad) > U_TURN_RAD:
            self.sign = pick_sign()
            self._closest_rad, self._closest_t_s = abs(err_rad), (t_s or 0.0)
        elif abs(err_rad) < U_TURN_DONE_RAD:
            self.sign = 0.0
        if self.sign != 0.0 and t_s is not None and self._stalled(abs(err_rad), t_s):
            self.sign = -self.sign
        if self.sign == 0.0 or math.copysign(1.0, err_rad) == self.sign:
            return None
        return wrap_2pi(heading_rad + self.sign * U_TURN_RAD)

    def latch(self, sign: float) -> None:
        """Latch a U-turn the way ``sign`` says (+1 starboard) before it starts (the side step,
        :mod:`companion.guidance.sidestep`, prepares the turn for one way)."""
        self.sign = sign
        self._closest_rad, self._closest_t_s = math.inf, 0.0

    def _stalled(self, abs_err_rad: float, t_s: float) -> bool:
        """The latched turn has not closed the heading error by :data:`U_TURN_PROGRESS_RAD` for
        :data:`U_TURN_STALL_S` (restarts the count when it returns True)."""
        if abs_err_rad < self._closest_rad - U_TURN_PROGRESS_RAD or t_s < self._closest_t_s:
            self._closest_rad, self._closest_t_s = abs_err_rad, t_s
            return False
        if t_s - self._closest_t_s > U_TURN_STALL_S:
            self._closest_rad, self._closest_t_s = abs_err_rad, t_s
            return True
        return False


def u_turn_sign(heading_rad: float, leg_rad: float, inside_sign: float) -> float:
    """Direction of a U-turn onto a leg (+1 starboard, -1 port): the one whose turning circle lies
    on the ``inside_sign`` side of the leg (+1 right of it, where the next corner turns right).

    A U-turn sets the boat one turning diameter beside the line (a jet cannot turn on the spot); on
    the inside of the route that offset lies toward the legs to come, not out into open water.  The
    centre of the turning circle is at bearing ``psi + s pi/2``; the inside at ``leg + inside pi/2``.
    """
    right = math.cos(heading_rad + 0.5 * math.pi - leg_rad - inside_sign * 0.5 * math.pi)
    return 1.0 if right >= 0.0 else -1.0


class LegNavigator:
    """Follow ``start -> end``; ``next_point`` (if any) is used for corner slow-down/anticipation."""

    def __init__(self, los: LosFollower, cfg: LegConfig) -> None:
        self.los = los
        self.cfg = cfg
        self.start: Point = (0.0, 0.0)
        self.end: Point = (0.0, 0.0)
        self.next_point: Point | None = None

    def set_leg(self, start: Point, end: Point, next_point: Point | None = None,
                speed_mps: float | None = None) -> None:
        self.start, self.end, self.next_point = start, end, next_point
        if speed_mps is not None:
            self.cfg = replace(self.cfg, speed_mps=speed_mps)
        self.los.set_leg(start, end)

    @property
    def inside_sign(self) -> float:
        """+1 when the corner at the end of this leg turns right (starboard), -1 left, 0 none."""
        if self.next_point is None:
            return 0.0
        a = math.atan2(self.end[1] - self.start[1], self.end[0] - self.start[0])
        b = math.atan2(self.next_point[1] - self.end[1], self.next_point[0] - self.end[0])
        turn = wrap_pi(b - a)
        return 0.0 if abs(turn) < 1e-6 else math.copysign(1.0, turn)

    def _corner(self, speed_mps: float | None = None,
                current_ne_mps: tuple[float, float] | None = None) -> tuple[float, float]:
        """(speed through the coming corner, anticipation distance before it); the turn radius is
        sized for ``speed_mps`` (the measured speed over ground) when that is above the corner speed.
        With ``current_ne_mps`` the turn is planned on the water-relative path
        (:func:`water_corner_lead_m`; :func:`drift_lead_m` where that is not defined); a waypoint's
        own radius caps the calm-water part only."""
        c = self.cfg
        if self.next_point is None:
            return c.speed_mps, 0.0
        turn = turn_angle_rad(self.start, self.end, self.next_point)
        if turn < c.sharp_turn_rad:
            return c.speed_mps, 0.0
        v = min(c.speed_mps, c.turn_speed_mps)
        entry_mps = max(v, speed_mps or 0.0)
        radius = entry_mps / c.turn_rate_max_radps
        calm = radius * math.tan(0.5 * min(turn, math.radians(150.0))) + v * c.yaw_lag_s * turn / math.pi
        lead = calm
        if c.corner_cut_max_m is not None:
            lead = min(lead, lead_for_cut_m(c.corner_cut_max_m, radius))
        if current_ne_mps is not None:
            water = water_corner_lead_m(self.start, self.end, self.next_point, current_ne_mps, entry_mps, v,
                                        c.turn_rate_max_radps, c.yaw_lag_s)
            if water is None:
                turn_s = turn / c.turn_rate_max_radps + c.yaw_lag_s * turn / math.pi
                water = calm + drift_lead_m(self.start, self.end, self.next_point, current_ne_mps, turn_s)
            lead = max(0.0, lead + water - calm)
        return v, lead

    def update(self, pos_ne: Point, speed_mps: float, dt_s: float,
               course_rad: float | None = None, current_ne_mps: tuple[float, float] | None = None) -> LegStep:
        """One step; ``course_rad`` (course over ground) keeps the corner speed until the boat
        points along the new leg, so it does not accelerate out of the turn; ``current_ne_mps``
        (estimated current) plans the corner on the water-relative path."""
        c = self.cfg
        out = self.los.update(pos_ne, speed_mps, dt_s, course_rad)
        err = out.errors
        remaining = err.remaining_m
        v_corner, lead = self._corner()
        brake_lead = lead
        if self.next_point is None:
            # last point: slow to arrive (the caller decides what happens there)
            v_corner, lead, brake_lead = min(c.speed_mps, c.turn_speed_mps), 0.0, c.arrive_short_m
        # v^2 = v_corner^2 + 2 a d  (constant-deceleration profile up to the corner)
        v_brake = math.sqrt(v_corner**2 + 2.0 * c.decel_mps2 * max(0.0, remaining - brake_lead))
        speed = min(c.speed_mps, v_brake)
        if course_rad is not None and abs(wrap_pi(out.course_rad - course_rad)) > c.sharp_turn_rad:
            speed = min(speed, c.turn_speed_mps)
        dist_end = math.hypot(pos_ne[0] - self.end[0], pos_ne[1] - self.end[1])
        if self.next_point is not None:
            lead = self._corner(speed_mps, current_ne_mps)[1]  # switch for the speed the boat has
        reached = remaining <= lead or dist_end <= c.accept_radius_m
        return LegStep(ControlTarget(out.course_rad, speed, out.course_rate_radps,
                                     stopping=self.next_point is None, leg=True), err, reached)
