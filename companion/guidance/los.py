"""Line-of-sight path following of straight legs with integral (ILOS) or adaptive (ALOS) action.

Both laws follow Fossen, Handbook of Marine Craft Hydrodynamics and Motion Control, 2nd ed.
(2021), section 12.4, written in the local north-east frame of :mod:`companion.guidance.geo`:

- path-tangential angle ``pi_p = atan2(y2 - y1, x2 - x1)`` of the leg from P1 to P2;
- along-track and cross-track errors (Eq. 12.54)::

      x_e =  (x - x1) cos(pi_p) + (y - y1) sin(pi_p)
      y_e = -(x - x1) sin(pi_p) + (y - y1) cos(pi_p)      (positive: boat right of the path)

- ILOS (Boerhaug, Pavlov and Pettersen 2008; Fossen Eq. 12.108-12.110)::

      chi_d = pi_p - atan(Kp * y_e + Ki * y_int),  Kp = 1 / Delta
      d/dt y_int = Delta * y_e / (Delta^2 + (y_e + kappa * y_int)^2)

- ALOS (Fossen, Pettersen and Galeazzi 2015; Fossen Eq. 12.111-12.112)::

      chi_d = pi_p - beta_hat - atan(y_e / Delta)
      d/dt beta_hat = gamma * Delta / sqrt(Delta^2 + y_e^2) * y_e

Two additions make the laws hold up through corners on any day's waves, not only on the seeds
they were tuned on:

- time-varying look-ahead (Lekkas and Fossen 2012; Fossen 2021 section 12.4)::

      Delta(y_e) = Delta_min + (Delta_max - Delta_min) * exp(-gamma_D * y_e^2)

  on the line (small ``y_e``, wave-driven) the long ``Delta_max`` keeps the course calm; after a
  corner the boat is metres off the new leg and the short ``Delta_min`` brings it back in a few
  metres instead of a whole look-ahead length (the overshoot no longer reaches the middle of the
  leg);
- the integral (or adaptive) state is frozen while the boat is before the start of its leg
  (``x_e < 0``: the early switch of turn anticipation), and while its course over ground is more
  than ``course_gate_rad`` off the leg (:attr:`LosGains.course_gate_rad`: the turn onto the leg,
  and the way back from its overshoot).  There the cross-track error is the geometry of the turn,
  not a current, and integrating it winds up a bias that the boat then carries down the leg: the
  turn onto a leg across a 1.2 m/s current wound ``y_int`` up to 0.86 m, which held the boat 0.3-0.4
  m up the current of the line for 60 m (``docs/tuning.md``).  A steady offset, what the integral
  is for, is flown with the course along the leg.

The integral state ``y_int`` or the crab-angle estimate ``beta_hat`` is what makes the boat crab
into a cross-current instead of settling off the line (ArduPilot issue 19306).  The output is a
desired *course over ground* plus its feed-forward rate; the course controller turns it into a
heading by removing the measured crab angle, so both terms together cancel steady current.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from companion.guidance.geo import wrap_2pi, wrap_pi


class LosType(enum.IntEnum):
    ILOS = 0
    ALOS = 1


@dataclass(frozen=True, slots=True)
class LosGains:
    """Tuning of the LOS laws (names as in Fossen's handbook).  The defaults are a plain
    constant look-ahead for unit use; the vehicle's tuning is in the ``USV_LOS_*`` parameters
    (:func:`companion.guidance.params.los_gains`)."""

    lookahead_m: float = 8.0
    """Delta (Delta_max): look-ahead distance on the line; smaller converges faster but oscillates."""
    lookahead_min_m: float = 8.0
    """Delta_min: look-ahead far off the line (time-varying look-ahead); >= ``lookahead_m`` disables it."""
    lookahead_gamma_per_m2: float = 1.0
    """gamma_D: how fast the look-ahead shrinks from Delta_max to Delta_min with the cross-track error."""
    ki: float = 0.02
    """ILOS integral gain Ki (1/m)."""
    kappa: float = 2.0
    """ILOS anti-windup factor kappa (dimensionless, > 0)."""
    gamma: float = 0.002
    """ALOS adaptation gain gamma (rad/(m s))."""
    beta_max_rad: float = math.radians(30.0)
    """Bound on the integral/adaptive crab correction (projection)."""
    course_gate_rad: float = math.radians(10.0)
    """The integral/adaptive state is frozen while the course over ground is more than this off the
    leg (module docstring; only when :meth:`LosFollower.update` is given the course)."""

    def __post_init__(self) -> None:
        if not (self.lookahead_m > 0.0 and self.lookahead_min_m > 0.0 and self.lookahead_gamma_per_m2 >= 0.0
                and self.ki >= 0.0 and self.kappa > 0.0 and self.gamma >= 0.0 and self.course_gate_rad > 0.0):
            raise ValueError(f"invalid LOS gains {self}")


@dataclass(frozen=True, slots=True)
class LegErrors:
    """Errors of a position against a leg (metres, radians)."""

    along_m: float
    cross_m: float
    leg_length_m: float
    path_angle_rad: float

    @property
    def remaining_m(self) -> float:
        return self.leg_length_m - self.along_m


def leg_errors(p1_ne: tuple[float, float], p2_ne: tuple[float, float],
               pos_ne: tuple[float, float]) -> LegErrors:
    """Along- and cross-track errors (Fossen Eq. 12.54) of ``pos_ne`` on the leg P1 -> P2."""
    dx, dy = p2_ne[0] - p1_ne[0], p2_ne[1] - p1_ne[1]
    length = math.hypot(dx, dy)
    pi_p = math.atan2(dy, dx) if length > 1e-9 else 0.0
    ex, ey = pos_ne[0] - p1_ne[0], pos_ne[1] - p1_ne[1]
    c, s = math.cos(pi_p), math.sin(pi_p)
    return LegErrors(along_m=ex * c + ey * s, cross_m=-ex * s + ey * c, leg_length_m=length,
                     path_angle_rad=pi_p)


def lookahead(gains: LosGains, cross_m: float) -> float:
    """Time-varying look-ahead ``Delta(y_e)`` (m)."""
    d_max, d_min = gains.lookahead_m, min(gains.lookahead_min_m, gains.lookahead_m)
    return d_min + (d_max - d_min) * math.exp(-gains.lookahead_gamma_per_m2 * cross_m * cross_m)


@dataclass(frozen=True, slots=True)
class LosOutput:
    course_rad: float
    """Desired course over ground, clockwise from north, [0, 2*pi)."""
    course_rate_radps: float
    """Feed-forward rate of the desired course (from the LOS geometry and the integral state)."""
    errors: LegErrors


class LosFollower:
    """ILOS/ALOS follower for one leg at a time; :meth:`set_leg` keeps the integral state."""

    def __init__(self, gains: LosGains | None = None, los_type: LosType = LosType.ILOS) -> None:
        self.gains = gains or LosGains()
        self.los_type = LosType(los_type)
        self.y_int_m = 0.0
        self.beta_hat_rad = 0.0
        self._leg: tuple[tuple[float, float], tuple[float, float]] | None = None

    def reset(self) -> None:
        self.y_int_m = 0.0
        self.beta_hat_rad = 0.0

    def set_leg(self, p1_ne: tuple[float, float], p2_ne: tuple[float, float]) -> None:
        """Follow P1 -> P2 next.  The crab estimate carries over (current does not change with the
        leg); for ILOS it is re-expressed so that the correction angle keeps its world direction
        only approximately, so it is scaled by the cosine of the turn."""
        if self._leg is not None:
            old = leg_errors(*self._leg, p2_ne).path_angle_rad
            new = leg_errors(p1_ne, p2_ne, p2_ne).path_angle_rad
            turn = wrap_pi(new - old)
            # a cross-current on one leg is partly an along-current on the next one
            self.y_int_m *= max(0.0, math.cos(turn))
            self.beta_hat_rad *= max(0.0, math.cos(turn))
        self._leg = (p1_ne, p2_ne)

    @property
    def leg(self) -> tuple[tuple[float, float], tuple[float, float]] | None:
        return self._leg

    def update(self, pos_ne: tuple[float, float], speed_mps: float, dt_s: float,
               course_rad: float | None = None) -> LosOutput:
        """One guidance step; ``speed_mps`` is the speed over ground (for the course rate);
        ``course_rad``, the course over ground, freezes the integral while it is more than
        ``course_gate_rad`` off the leg (module docstring; ``None``: never)."""
        if self._leg is None:
            raise RuntimeError("LosFollower.update before set_leg")
        g = self.gains
        err = leg_errors(*self._leg, pos_ne)
        y_e = err.cross_m
        delta = lookahead(g, y_e)
        # The feed-forward rate uses the local gain 1/Delta, not the full slope d/dy_e (y_e/Delta(y_e)):
        # that slope peaks near |y_e| = 1 m, where it would turn wave-driven cross-track motion into
        # turn-rate demand (measured: corner overshoot grows on the square benchmark).
        slope = 1.0 / delta
        # before the leg starts (turn anticipation), and while the boat turns onto the leg or back
        # from overshooting it, the error is the turn, not a current
        adapt = err.along_m >= 0.0 and (
            course_rad is None or abs(wrap_pi(course_rad - err.path_angle_rad)) <= g.course_gate_rad)
        if self.los_type is LosType.ILOS:
            arg = y_e / delta + g.ki * self.y_int_m
            correction = math.atan(arg)
            y_int_dot = delta * y_e / (delta**2 + (y_e + g.kappa * self.y_int_m) ** 2) if adapt else 0.0
            self.y_int_m += y_int_dot * dt_s
            limit = math.tan(g.beta_max_rad) / g.ki if g.ki > 0 else 0.0
            self.y_int_m = min(limit, max(-limit, self.y_int_m))
            chi = err.path_angle_rad - correction
            # d/dt atan(y_e/Delta + Ki y_int) with d/dt y_e = U sin(chi - pi_p)
            y_e_dot = speed_mps * math.sin(chi - err.path_angle_rad)
            rate = -(slope * y_e_dot + g.ki * y_int_dot) / (1.0 + arg * arg)
        else:
            beta_dot = g.gamma * delta / math.hypot(delta, y_e) * y_e if adapt else 0.0
            self.beta_hat_rad = min(g.beta_max_rad, max(-g.beta_max_rad, self.beta_hat_rad + beta_dot * dt_s))
            chi = err.path_angle_rad - self.beta_hat_rad - math.atan(y_e / delta)
            y_e_dot = speed_mps * math.sin(chi - err.path_angle_rad)
            rate = -beta_dot - (slope * y_e_dot) / (1.0 + (y_e / delta) ** 2)
        return LosOutput(course_rad=wrap_2pi(chi), course_rate_radps=rate, errors=err)
