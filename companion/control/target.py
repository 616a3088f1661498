"""What guidance asks of the controllers, the crab-angle estimate, and the controller interface.

Guidance (:mod:`companion.guidance`) produces a desired course over ground ``chi_d`` (or, for
station keeping and course hold, a desired heading ``psi_d``) and a speed.  Controllers steer the
*heading*; the two differ by the crab angle ``beta = chi - psi`` (sideslip plus the current seen
over ground, Fossen 2021 Eq. 2.115), so ``psi_d = chi_d - beta_hat`` with ``beta_hat`` the measured
crab angle, low-pass filtered.  Every controller family implements :class:`CourseSpeedController`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from companion.angles import wrap_pi
from companion.control.actuator import Saturation
from companion.control.pid import LowPass
from companion.messages import NavState


@dataclass(frozen=True, slots=True)
class ControlTarget:
    """Desired motion for one control step."""

    course_rad: float
    """Desired course over ground (or heading when ``is_heading``), clockwise from north."""
    speed_mps: float
    """Desired surge speed over ground (may be negative only for station keeping)."""
    course_rate_radps: float = 0.0
    """Feed-forward turn rate (e.g. U/R when circling)."""
    is_heading: bool = False
    """``course_rad`` is a heading: do not remove the crab angle (station keeping, course hold)."""
    hold_station: bool = False
    """The target comes from station keeping (LOITER, GUIDED and RTL on their point), which the
    control system steers with the family ``USV_STN_CTRL`` names."""
    current_along_mps: float = 0.0
    """The estimated water current's component along the commanded heading (m/s, positive from
    astern), when guidance knows it: the speed through the water is ``speed_mps`` minus this, which
    the PID family's throttle feed-forward uses (bow into a 1.2 m/s current: 1.2 m/s through the
    water to stand still), so its integrator does not have to find the holding throttle again
    after every mode change (it is reset on entry).  A U-turn onto a leg gives the component along
    the bow as it turns (:func:`companion.guidance.waypoints.pivot_speed_mps`)."""
    circling: bool = False
    """The target comes from a hold orbit round a point (LOITER, GUIDED and RTL where the boat
    cannot stand on it, :class:`~companion.modes.holding.OrbitTask`): a continuous turn, which the
    active model gives the thrust its yaw row asks for at any commanded speed
    (``turn_throttle_max`` does not apply; :mod:`companion.control.active_model`)."""
    stopping: bool = False
    """The speed is slowing the boat down to stop at a point, not for a corner: set by the leg
    follower on a leg with no next point (GUIDED's and RTL's legs, AUTO's last waypoint and its legs
    to items it circles or holds, the legs of the hold on a circle).  While the boat is still faster
    than asked, the active model gives a heading wobble only the turn-scaled thrust of a slow boat
    (:mod:`companion.control.active_model`)."""
    leg: bool = False
    """The target follows a straight leg (line of sight, :mod:`companion.guidance.waypoints`): the
    active-model law takes the fast part of the current's yaw coupling out of its over-ground model
    there (``coupling_tau_s``, :mod:`companion.control.active_model`)."""
    u_turn: bool = False
    """The target turns the boat onto a leg it pointed more than 135 deg away from, at the U-turn's
    slow speed until the bow is within 45 deg of the leg
    (:meth:`companion.modes.navigation.GotoTask.step`): the heading loop may ask for
    ``USV_UTURN_RATE`` and the active model gives the turn all the thrust it asks for, so the jet
    turns on its smallest circle (:mod:`companion.control.active_model`)."""
    steady_crab_rad: float | None = None
    """The crab angle (course over ground less heading) that holds ``course_rad`` in steady running
    through the current guidance has observed (:func:`companion.guidance.current.steady_crab_rad`),
    when it knows one: the measured crab the controllers remove is kept within
    :data:`STEADY_CRAB_MARGIN_RAD` of it (:meth:`CrabEstimator.heading_command`)."""


@dataclass(frozen=True, slots=True)
class ControlRequest:
    """What the active mode asks of the control system for one sample: follow a ``target``
    (closed loop: controller family, then actuator mapping), or, without one, this nozzle angle
    and throttle through the actuator limits and slew rates (MANUAL; idle is both zero)."""

    ignition_on: bool
    target: ControlTarget | None = None
    nozzle_rad: float = 0.0
    throttle: float = 0.0

    @classmethod
    def follow(cls, target: ControlTarget, *, ignition_on: bool) -> ControlRequest:
        return cls(ignition_on, target)

    @classmethod
    def direct(cls, nozzle_rad: float, throttle: float, *, ignition_on: bool) -> ControlRequest:
        return cls(ignition_on, None, nozzle_rad, throttle)

    @classmethod
    def idle(cls, *, ignition_on: bool) -> ControlRequest:
        return cls(ignition_on)


@dataclass(frozen=True, slots=True)
class ControlOutput:
    nozzle_rad: float
    throttle: float
    heading_cmd_rad: float
    """The heading the controller steered for (after crab compensation), for telemetry."""


class CourseSpeedController(Protocol):
    """A controller family: (nav, target, dt, actuator saturation) -> nozzle angle and throttle."""

    name: str

    def reset(self, nav: NavState) -> None: ...

    def update(self, nav: NavState, target: ControlTarget, dt_s: float, sat: Saturation) -> ControlOutput: ...


STEADY_CRAB_MARGIN_RAD = math.radians(5.0)
"""How far the removed crab may stray from a target's ``steady_crab_rad``.  In a turn the course over
ground lags the heading by 20-30 deg (the hull slips sideways through the water); removed in full,
that slip leads the heading command past the new leg, and the lead outlasts the turn: the bow
swung 10-15 deg past the leg's crab heading at every corner and the boat landed 0.4-0.6 m inside
the leg 10 m after it.  Within the margin the bow still swings past the leg: 8 deg measured best
before the ILOS integral's course gate, 5 deg after it (``docs/tuning.md``)."""


class CrabEstimator:
    """Low-pass filtered crab angle ``beta = course over ground - heading`` (rad).

    Below ``min_speed_mps`` the course over ground is noise, so the estimate holds its value.
    """

    def __init__(self, tau_s: float = 0.5, min_speed_mps: float = 0.8,
                 beta_max_rad: float = math.radians(35.0)) -> None:
        self._lp_sin = LowPass(tau_s, 0.0)
        self._lp_cos = LowPass(tau_s, 1.0)
        self.min_speed_mps = min_speed_mps
        self.beta_max_rad = beta_max_rad
        self.beta_rad = 0.0

    def reset(self) -> None:
        self._lp_sin.value, self._lp_cos.value, self.beta_rad = 0.0, 1.0, 0.0

    def update(self, nav: NavState, dt_s: float) -> float:
        if nav.speed_over_ground_mps >= self.min_speed_mps:
            chi = nav.course_over_ground_rad
            beta = wrap_pi(chi - nav.heading_rad)
            # filter on the unit circle so that +-pi wrap does not upset it
            s = self._lp_sin.step(math.sin(beta), dt_s)
            c = self._lp_cos.step(math.cos(beta), dt_s)
            self.beta_rad = max(-self.beta_max_rad, min(self.beta_max_rad, math.atan2(s, c)))
        return self.beta_rad

    def heading_command(self, target: ControlTarget) -> float:
        """Heading to steer for ``target``: the crab removed unless the target is a heading, kept
        within :data:`STEADY_CRAB_MARGIN_RAD` of the target's ``steady_crab_rad`` when it has one."""
        if target.is_heading:
            return target.course_rad
        beta_rad = self.beta_rad
        if target.steady_crab_rad is not None:
            beta_rad = min(max(beta_rad, target.steady_crab_rad - STEADY_CRAB_MARGIN_RAD),
                           target.steady_crab_rad + STEADY_CRAB_MARGIN_RAD)
        return target.course_rad - beta_rad
