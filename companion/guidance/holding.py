"""Holding a point in a known current (issue 14): bow into it, or a drift-compensated orbit.

A water jet idles with thrust (the simulated boat creeps at about 0.7 m/s through the water) and
has no reverse, so what holding a point means depends on the current ``V_c`` (earth frame,
north/east m/s, from the estimator):

* ``|V_c|`` above the idle creep: keep station bow into the current
  (:class:`CurrentStationKeeper`).  The station keeper's PI law of
  :mod:`companion.guidance.station` gets the current as a feed-forward instead of learning it
  through its integral (which took tens of seconds and let the boat wander meanwhile)::

      v_g = sat(-k_p e, v_max)                 desired velocity over ground
      r  += -k_i e dt  (|r| <= r_max)          residual the estimate misses (wind leeway)
      w   = v_g - V_c + r                      desired velocity through the water

  The heading is the direction of ``w``, kept within ``max_off_upstream_rad`` of upstream (a
  jet that turns broadside to a strong current is swept away: it backs down stern-first to the
  point, ferry-gliding sideways), and the surge over ground the projection of ``v_g`` on it.
  While the jet idles and ``w`` is slower than the idling boat, the bow is set off upstream
  instead (:mod:`companion.guidance.ferry`).

* weaker: the boat cannot stand still, so it circles the point (:class:`DriftOrbit`) at a
  constant speed through the water ``U_w`` on a ground circle of radius ``R``.  The desired
  course over ground is the orbit vector field of Beard and McLain (2012, Eq. 10.13; as
  :mod:`companion.guidance.circle`), ``chi = phi + lam (pi/2 + atan(k e_r / R))``, and the
  heading is the one that makes good ``chi`` through the current (crab feed-forward, wind
  triangle)::

      c_perp = V_c . h(chi),  h(chi) = (-sin chi, cos chi)
      psi    = chi - asin(c_perp / U_w)
      V_g    = U_w cos(psi - chi) + V_c . (cos chi, sin chi)         ground speed along chi

  with the feed-forward turn rate ``dpsi/dt = dchi/dt (1 + c_par / (U_w cos(psi - chi)))``,
  ``dchi/dt = lam V_g / R`` on the circle, and the surge over ground
  ``u = U_w + V_c . (cos psi, sin psi)`` (the speed the controllers track is over ground).

The strategy is picked from the estimate at once (no exploratory loops): :func:`pick_strategy`.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from companion.angles import upstream_rad
from companion.guidance.ferry import IdleDrift, ferry_heading
from companion.guidance.geo import along_across_m, distance_bearing, turn_to_go_rad, wrap_2pi, wrap_pi

MAX_CRAB_SIN = 0.8
"""Largest |sin| of the orbit's crab angle (53 deg)."""


class HoldStrategy(enum.IntEnum):
    """How a point is held."""

    LEGACY = 0
    """No current estimate: the station keeper learns the current itself (before issue 14)."""
    STATION = 1
    """Bow into the current."""
    ORBIT = 2
    """Drift-compensated orbit at the turning radius."""


def pick_strategy(current_ne_mps: tuple[float, float] | None, confidence: float, creep_mps: float,
                  min_confidence: float = 0.5) -> HoldStrategy:
    """STATION when the estimate stands out of its uncertainty (``confidence``) and is stronger
    than the jet's idle creep; ORBIT when it is weaker (a current that does not stand out is slack
    water); LEGACY without an estimate."""
    if current_ne_mps is None:
        return HoldStrategy.LEGACY
    if confidence >= min_confidence and math.hypot(*current_ne_mps) > creep_mps:
        return HoldStrategy.STATION
    return HoldStrategy.ORBIT


@dataclass(frozen=True, slots=True)
class HoldOutput:
    heading_rad: float
    surge_speed_mps: float
    """Desired surge speed over ground (negative: let the current set the boat back)."""
    turn_rate_radps: float
    distance_m: float
    radial_error_m: float = 0.0
    surge_cap_mps: float = math.inf
    """With the bow clamped off upstream (the station keeper: the desired water velocity points
    farther off than ``max_off_upstream_rad``), the largest surge at which the boat still makes
    good the desired velocity's component along the current (:func:`clamped_surge_cap_mps`); the
    caller decides whether to apply it."""


@dataclass(frozen=True, slots=True)
class CurrentStationGains:
    kp_per_s: float = 0.25
    ki_per_s2: float = 0.02
    v_max_mps: float = 2.0
    residual_max_mps: float = 0.5
    min_speed_mps: float = 0.15
    """Below this desired water speed the heading freezes (slack on station)."""
    max_off_upstream_rad: float = math.radians(70.0)
    ferry_only_to_hold: bool = False
    """Ferry-glide only where the ferry can stand the boat on its point
    (:func:`~companion.guidance.ferry.holds_at_the_point`; the hold on a sampling circle)."""


DOWNSTREAM_SIDE_RAD = math.radians(30.0)
"""A desired water velocity within this of straight downstream is clamped on the side of upstream
the bow is already on (:class:`CurrentStationKeeper`): either side serves, and one picked by the
sign of a near-180 deg angle flips with every wave, each flip a powered turn (``docs/tuning.md``)."""


class CurrentStationKeeper:
    """Station keeping bow into a known current (module docstring); positions north/east metres."""

    def __init__(self, target_ne: tuple[float, float], heading_rad: float,
                 gains: CurrentStationGains | None = None) -> None:
        self.target_ne = target_ne
        self.gains = gains or CurrentStationGains()
        self.residual_ne = [0.0, 0.0]
        self.heading_rad = wrap_2pi(heading_rad)

    def update(self, pos_ne: tuple[float, float], current_ne_mps: tuple[float, float],
               dt_s: float, idle: IdleDrift | None = None) -> HoldOutput:
        """One step: the heading and surge over ground for ``pos_ne``; ``idle`` (the jet idles):
        the ferry glide's heading when the keeper wants less speed than the idling boat makes
        (:func:`~companion.guidance.ferry.ferry_heading`)."""
        g = self.gains
        en, ee = pos_ne[0] - self.target_ne[0], pos_ne[1] - self.target_ne[1]
        vn, ve = -g.kp_per_s * en, -g.kp_per_s * ee
        vmag = math.hypot(vn, ve)
        if vmag > g.v_max_mps:
            vn, ve = vn * g.v_max_mps / vmag, ve * g.v_max_mps / vmag
        self.residual_ne[0] -= g.ki_per_s2 * en * dt_s
        self.residual_ne[1] -= g.ki_per_s2 * ee * dt_s
        rmag = math.hypot(*self.residual_ne)
        if rmag > g.residual_max_mps:
            self.residual_ne = [r * g.residual_max_mps / rmag for r in self.residual_ne]
        wn = vn - current_ne_mps[0] + self.residual_ne[0]
        we = ve - current_ne_mps[1] + self.residual_ne[1]
        clamped = False
        if math.hypot(wn, we) >= g.min_speed_mps:
            heading = math.atan2(we, wn)
            if math.hypot(*current_ne_mps) > 0.0:
                upstream = upstream_rad(current_ne_mps)
                off = wrap_pi(heading - upstream)
                clamped = abs(off) > g.max_off_upstream_rad
                if clamped and abs(off) > math.pi - DOWNSTREAM_SIDE_RAD:
                    # w points (nearly) downstream: either side of upstream serves, and which one
                    # the sign of a near-180 deg angle picks changes with every wave; keep the bow's
                    off = math.copysign(abs(off), wrap_pi(self.heading_rad - upstream))
                heading = upstream + max(-g.max_off_upstream_rad, min(g.max_off_upstream_rad, off))
                ferry = None if idle is None or clamped else ferry_heading(
                    upstream, (wn, we), self.heading_rad - upstream, idle, g.kp_per_s,
                    math.hypot(*current_ne_mps) if g.ferry_only_to_hold else None)
                heading = heading if ferry is None else ferry
            self.heading_rad = wrap_2pi(heading)
        surge = vn * math.cos(self.heading_rad) + ve * math.sin(self.heading_rad)
        cap = clamped_surge_cap_mps(self.heading_rad, (vn, ve), current_ne_mps) if clamped else math.inf
        return HoldOutput(self.heading_rad, surge, 0.0, math.hypot(en, ee), surge_cap_mps=cap)


def clamped_surge_cap_mps(heading_rad: float, v_g_ne: tuple[float, float],
                          current_ne_mps: tuple[float, float]) -> float:
    """Largest surge over ground on ``heading_rad`` (``off`` from upstream) at which the boat still
    makes good ``v_g``'s component ``a`` upstream (negative: downstream) through the current ``c``.
    Through the water at ``U_w`` the boat makes ``U_w cos(off) - |c|`` upstream, so
    ``U_w <= (|c| + a) / cos(off)``; the surge over ground is ``u = U_w - |c| cos(off)``::

        u_max = (|c| + a) / cos(off) - |c| cos(off)

    (negative: the surge controller idles)."""
    c = math.hypot(*current_ne_mps)
    if c <= 0.0:
        return math.inf
    up_n, up_e = -current_ne_mps[0] / c, -current_ne_mps[1] / c
    cos_off = up_n * math.cos(heading_rad) + up_e * math.sin(heading_rad)
    if cos_off <= 0.05:
        return math.inf
    a = v_g_ne[0] * up_n + v_g_ne[1] * up_e
    return (c + a) / cos_off - c * cos_off


@dataclass(frozen=True, slots=True)
class OrbitGains:
    k_orbit: float = 1.5
    """Convergence gain onto the circle (Beard and McLain's k)."""
    water_speed_mps: float = 1.0
    """Speed through the water on the orbit (at least the idle creep)."""
    water_speed_margin_mps: float = 0.2
    """The water speed is raised to |V_c| / MAX_CRAB_SIN + this when the current needs it."""
    ki_per_s: float = 0.1
    """Integral gain on the radial error (1/s): a turning hull slips outward through the water,
    which the crab feed-forward does not know; the integral moves the aim point inward."""
    integral_max_m: float = 1.5
    entry_lead_rad: float = math.radians(90.0)
    """Entered inside the circle: the heading command leads the bow by this, the orbit's way."""
    entry_turn_rad: float = math.radians(270.0)
    """The entry turn ends after the bow has turned this far at most (a turn that stays inside
    the circle would loop through the point and out the other side)."""
    entry_join_rad: float = math.radians(30.0)
    """... and as soon as the orbit's heading there is at most this far ahead of the bow, the
    orbit's way (the field takes over without a turn the other way: reversing the nozzle at speed
    ran the boat straight through the point at 2.9 m/s); not while the bow has turned past it,
    which would reverse the turn too; not within a quarter of the radius of the point, where the
    field's direction is GPS noise."""


REST_RUN_OUT_FRACTION = 0.25
"""An orbit entered at rest this close to its centre (a fraction of the radius) starts by running
out along the bow (:meth:`DriftOrbit.update`)."""
REST_MPS = 0.3
"""Below this speed through the water a boat entering an orbit is at rest."""


class DriftOrbit:
    """Circle ``centre_ne`` at ``radius_m`` through a known current (module docstring)."""

    def __init__(self, centre_ne: tuple[float, float], radius_m: float, clockwise: bool = True,
                 gains: OrbitGains | None = None) -> None:
        if not (radius_m > 0 and math.isfinite(radius_m)):
            raise ValueError(f"orbit radius must be positive, got {radius_m}")
        self.centre_ne = centre_ne
        self.radius_m = radius_m
        self.lam = 1.0 if clockwise else -1.0
        self.gains = gains or OrbitGains()
        self.integral_m = 0.0
        self._entering = True
        self._turned_rad = 0.0
        self._last_heading_rad: float | None = None
        self._run_out_rad: float | None = None
        """Entered at rest near the centre: the bow held on this heading until the field steers
        (:data:`REST_RUN_OUT_FRACTION`)."""

    def water_speed_mps(self, current_ne_mps: tuple[float, float]) -> float:
        g = self.gains
        return max(g.water_speed_mps, math.hypot(*current_ne_mps) / MAX_CRAB_SIN + g.water_speed_margin_mps)

    def update(self, pos_ne: tuple[float, float], current_ne_mps: tuple[float, float],
               dt_s: float, heading_rad: float, at_rest: bool = False) -> HoldOutput:
        """One step; ``heading_rad`` is the boat's.  Entered inside the circle (LOITER starts at
        its point, GUIDED hands over on it), the boat turns at once the orbit's way, at the
        orbit's water speed: the heading command leads the bow by ``entry_lead_rad`` until the
        orbit's heading is at most ``entry_join_rad`` ahead of the bow (the orbit's way; a bow
        turned past it keeps turning) or the bow has turned ``entry_turn_rad`` (a boat still fast
        when it crosses the circle keeps turning the orbit's way instead of being turned back by
        the field); entered from outside the circle, the field steers at once.  A boat that
        cannot stop, moving through its point with turning radius rho, stays within 2 rho of it
        only by turning at once (any straight stretch first takes it farther); holding the entry
        heading out to half the radius, as before, let it run out at speed and swing 7-9 m wide
        before it settled (usv bench nav, 0.5 m/s reporting cell; 3.5-4.6 m with the entry turn,
        docs/tuning.md).  Joining the field with the bow turned past its heading would reverse the
        turn, and the yaw row's thrust at the nozzle stop (``circling``) runs the boat out straight
        while the nozzle crosses (LOITER entered while GUIDED's orbit turns the boat;
        docs/tuning.md).  Entered ``at_rest`` (through the water) in slack water
        (:data:`ENTRY_CURRENT_MPS`) within :data:`REST_RUN_OUT_FRACTION` of the radius of the
        centre, the boat instead runs out along its bow at the orbit's water speed until it is
        that far out, and the field takes over there (it then asks a turn of about 40 deg the
        orbit's way): a turn from the centre the orbit's way meets the circle going round it the
        other way, so the entry turn spun the boat at full nozzle and throttle for 5 s and the join
        that followed ran it out 5.5-7.4 m (LOITER pressed at rest, calm or 0.1 m/s; 3.3-3.9 m
        now).  Not in a stronger current, where the entry turn toward upstream did better (0.2
        m/s: 3.2 m, run out 4.5 m; docs/tuning.md)."""
        g, lam, big_r = self.gains, self.lam, self.radius_m
        d, phi = distance_bearing(pos_ne[0] - self.centre_ne[0], pos_ne[1] - self.centre_ne[1])
        e_r = d - big_r
        if self._last_heading_rad is None and d >= big_r:
            self._entering = False  # entered from outside: the field brings the boat in
        near_centre = d < REST_RUN_OUT_FRACTION * big_r
        if self._last_heading_rad is None and at_rest and near_centre \
                and math.hypot(*current_ne_mps) < ENTRY_CURRENT_MPS:
            self._run_out_rad = heading_rad
        if self._run_out_rad is not None:
            if near_centre:
                self._last_heading_rad = heading_rad
                u_w = self.water_speed_mps(current_ne_mps)
                psi = self._run_out_rad
                surge = u_w + current_ne_mps[0] * math.cos(psi) + current_ne_mps[1] * math.sin(psi)
                return HoldOutput(psi, surge, 0.0, d, e_r)
            self._run_out_rad = None  # out far enough: the field steers from here
            self._entering = False
        if self._entering and self._last_heading_rad is not None:
            self._turned_rad += turn_to_go_rad(lam, self._last_heading_rad, heading_rad)
        self._last_heading_rad = heading_rad
        field = self._field(d, phi, e_r, current_ne_mps, dt_s if not self._entering else 0.0)
        ahead_rad = turn_to_go_rad(lam, heading_rad, field.heading_rad)  # the orbit's heading, from the bow
        if self._entering and self._turned_rad < g.entry_turn_rad \
                and (d < 0.25 * big_r or not 0.0 <= ahead_rad <= g.entry_join_rad):
            u_w = self.water_speed_mps(current_ne_mps)
            psi = wrap_2pi(heading_rad + lam * g.entry_lead_rad)
            surge = u_w + current_ne_mps[0] * math.cos(psi) + current_ne_mps[1] * math.sin(psi)
            return HoldOutput(psi, surge, lam * u_w / big_r, d, e_r)
        self._entering = False
        return field

    def _field(self, d: float, phi: float, e_r: float, current_ne_mps: tuple[float, float],
               dt_s: float) -> HoldOutput:
        """The orbit's vector field with the crab feed-forward (module docstring)."""
        g, lam, big_r = self.gains, self.lam, self.radius_m
        if abs(e_r) < big_r:  # on the circle: what remains is slip, not the approach
            self.integral_m += g.ki_per_s * e_r * dt_s
            self.integral_m = max(-g.integral_max_m, min(g.integral_max_m, self.integral_m))
        chi = phi + lam * (0.5 * math.pi + math.atan(g.k_orbit * (e_r + self.integral_m) / big_r))
        cn, ce = current_ne_mps
        u_w = self.water_speed_mps(current_ne_mps)
        c_perp = -cn * math.sin(chi) + ce * math.cos(chi)
        c_par = cn * math.cos(chi) + ce * math.sin(chi)
        s = max(-MAX_CRAB_SIN, min(MAX_CRAB_SIN, c_perp / u_w))
        cos_crab = math.sqrt(1.0 - s * s)
        psi = chi - math.asin(s)
        v_g = max(0.0, u_w * cos_crab + c_par)
        chi_rate = lam * v_g / max(d, 0.5 * big_r) if abs(e_r) < big_r else 0.0
        rate = chi_rate * (1.0 + c_par / (u_w * cos_crab))
        surge = u_w + cn * math.cos(psi) + ce * math.sin(psi)
        return HoldOutput(wrap_2pi(psi), surge, rate, d, e_r)


ENTRY_CURRENT_MPS = 0.15
"""Above this current the orbit turns toward upstream on entry, below it the way the boat turns."""
KEEP_TURN_RADPS = math.radians(10.0)
"""A boat turning faster than this keeps turning its way when a hold starts (the orbit's direction,
:func:`orbit_clockwise`; the direction of a U-turn onto the station keeper's heading,
:class:`~companion.guidance.bow_turn.KeeperTurn`): reversing a turn takes seconds in which the jet
pushes the boat on straight (``docs/tuning.md``)."""


def orbit_clockwise(heading_rad: float, yaw_rate_radps: float, current_ne_mps: tuple[float, float]) -> bool:
    """The orbit's direction for a boat entering it at its centre (``yaw_rate_radps`` > 0 is
    clockwise).  A boat turning faster than :data:`KEEP_TURN_RADPS` (LOITER entered from GUIDED's
    orbit) keeps turning its way.  Otherwise, in a current, the entry turn (radius rho through the
    water) is centred at bearing ``heading + lam pi/2``, and with that centre upstream the current
    sets the boat back toward the point while it turns (the opposite way it carries it ``|V_c| T``
    farther out, 2-3 m in 0.5 m/s); in slack water the boat turns the way it turns."""
    if abs(yaw_rate_radps) > KEEP_TURN_RADPS:
        return yaw_rate_radps > 0.0
    if math.hypot(*current_ne_mps) > ENTRY_CURRENT_MPS:
        right_n, right_e = math.cos(heading_rad + 0.5 * math.pi), math.sin(heading_rad + 0.5 * math.pi)
        return right_n * current_ne_mps[0] + right_e * current_ne_mps[1] < 0.0
    return yaw_rate_radps >= 0.0


JOIN_ROUND_MPS = 0.3
"""A boat outside an orbit's circle going round its centre at this speed or more (over ground)
keeps going round that way (:func:`going_round_clockwise`)."""


def going_round_clockwise(offset_ne_m: tuple[float, float], velocity_ne_mps: tuple[float, float],
                          radius_m: float) -> bool | None:
    """The way a boat outside an orbit's circle (``offset_ne_m`` from its centre, farther than
    ``radius_m``) already goes round the centre: True clockwise, False counter-clockwise; None
    inside the circle, or going round at under :data:`JOIN_ROUND_MPS` or slower than it heads for
    or away from the centre.  An orbit taken up off its point the other way round sends the boat
    through the centre at speed, and the entry turn there carries it out the far side."""
    d_m = math.hypot(*offset_ne_m)
    if d_m <= radius_m:
        return None
    out_mps, round_mps = along_across_m(velocity_ne_mps, (0.0, 0.0), offset_ne_m)  # round: clockwise
    if abs(round_mps) < max(JOIN_ROUND_MPS, abs(out_mps)):
        return None
    return round_mps > 0.0
