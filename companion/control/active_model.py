"""The chapter's active-model-based controller (Fig. 6): qLPV inversion plus model-error compensation.

Nominal law.  The surge and yaw rows of the qLPV model (Eq. 3-5) are

    u_dot = [A(nu) nu]_u + b_u * T cos(delta) + delta_nu_u
    r_dot = [A(nu) nu]_r + b_r * T sin(delta) + delta_nu_r

and B acts on the input only through ``w = T [sin delta, cos delta]``.  Feedback linearisation
(Fossen 2021, section 16.1) picks the desired accelerations from stable linear error dynamics

    r_dot_d = k_r (r_d - r),     r_d = sat(k_psi e_psi, r_max) + r_ff     (heading, critically
    u_dot_d = sat(k_u (u_d - u), -a_dec, a_acc)                            damped for k_r = 4 k_psi)

plus, in the yaw row, the feed-forward ``r_dot_ff`` = d/dt r_d obtained through a first-order
command filter (command-filtered backstepping: Farrell et al., IEEE TAC 2009; Fossen 2021 ch. 16):
without it the heading error decays with a lag of 1/k_r behind its design law and overshoots;
and solves the two rows for ``w``:  ``T sin delta = (r_dot_d - [A nu]_r - dnu_r) / b_r``,
``T cos delta = (u_dot_d - [A nu]_u - dnu_u) / b_u``.  Then ``delta = atan2(w_sin, w_cos)``, the
normalised thrust ``T~ = |w|`` and the throttle from the model's thrust map
``T~ = throttle^2 - c throttle u`` inverted.  Sway is the stable zero dynamics.

Compensation.  ``delta_nu`` is the UKF's online estimate of the model error (Eq. 5-11, published
on topic ``model_error`` by :mod:`companion.estimation`); subtracting it makes the closed loop
behave as designed despite mismatch, wind and waves: the UKF acts as a disturbance observer, so
no integrator is needed.  When the nozzle limit is reached the yaw row has priority: the thrust
is raised until full nozzle gives the requested yaw moment (a water jet has no steering without
thrust), so the boat does not lose its turn when it is also asked to slow down.

Near standstill (commanded speed below ``turn_boost_speed_mps``: station keeping, turning on the
spot, circling a point) the idle jet has almost no yaw authority (b_r T sin(delta_max) is small
at the thrust that holds the boat in a current), and two things change.  The extra thrust of the
yaw priority is scaled by how much of a turn guidance asks for (the larger of heading error /
``turn_boost_full_error_rad`` and r_d / r_max) and capped at ``turn_throttle_max`` unless guidance
plans the turn (its feed-forward rate ``course_rate_radps``, as when circling a point at the
turning radius), so a heading wobble does not rev the engine and push the boat off its station.
A hold orbit (``ControlTarget.circling``) is not capped: it is one continuous turn, and a boat the
wind had pushed off the orbit's circle, its heading 70-100 deg off the orbit's, came round at the
cap's 0.4 throttle with the nozzle at its stop in loops 6-8 m wide (``docs/tuning.md``).
And the nozzle angle is solved against at least the thrust of ``yaw_inversion_min_throttle``, so
a small yaw demand at idle does not throw the nozzle from stop to stop.

A boat carried by a current is slow through the water however fast it goes over ground: 2.2 m/s
over ground down a 0.8 m/s current is 1.4 m/s through the water, where the jet has as little yaw
authority as at 1.4 m/s in slack water.  There the full yaw priority of a boat making way turned
every heading wobble into thrust (nozzle from stop to stop, throttle 0.8-1.0) and the boat ran at
5-6 m/s on a 2.2 m/s leg.  So a commanded speed through the water (with the estimator's current,
``current``) below ``turn_boost_speed_mps`` gets the near-standstill nozzle floor and turn-scaled
thrust too, but not the throttle cap, which is for a boat that is slow over ground (a corner taken
down a current still gets the thrust that turns it).  So does a boat slowing down to stop at the
end of a leg with no next point (``ControlTarget.stopping``: GUIDED's and RTL's legs, AUTO's last
waypoint and its legs to items it circles) while
it is still more than the speed law's brake deadband faster than asked: with the surge demand near
zero every wave's yaw put the nozzle at its stop and the yaw priority held the throttle at 0.5-0.9,
so the boat reached its point at 2.5 m/s.  Slowing down for a corner keeps the full priority: the
turn that follows needs it.

A U-turn onto a leg (``ControlTarget.u_turn``) gets the full yaw priority at any speed, and the
heading loop asks for up to ``u_turn_rate_max_radps`` instead of ``turn_rate_max_radps``.  At full
nozzle the jet's turning circle hardly changes with thrust (about 1.2-1.5 m in the simulator from
idle to full throttle), but a turn at the capped thrust is slow: a boat that left station keeping
bow into a 1.2 m/s current at 1.2 m/s through the water kept that speed and turned at 20-35 deg/s,
on a circle 2.5-4.5 m wide, and swung 3.5 m past its leg.  More thrust turns it round before it
has gone far (``docs/tuning.md``).

Water-relative model (issue 14).  When the UKF estimates the current with the model error (the
current-augmented filter, ``models.ukf = "current"``), its delta_nu is the error of the model run
on the velocity through the water, and so is this law's model: Eq. 3-4 are evaluated on

    nu_r = nu - R(psi)^T [V_cN, V_cE, 0]^T      (the current delta_nu was estimated against,
                                                ``model_current``)

and the thrust map on the surge through the water (the jet's inflow).  On over-ground velocities
a cross-current reads as sway, whose coupling into yaw changes with every heading change: across
a 1.2 m/s current the heading, the crab and the course swung +-10-17 deg and the boat snaked
0.8-0.9 m off its leg; on water-relative velocities it holds the line (``docs/tuning.md``).  With
the chapter's filter (the default, delta_nu over the ground) the law stays on over-ground
velocities, the pair the chapter flies (on legs, with the fast coupling below taken out).  The
water-relative pair's filter has a fast surge model error (the identified surge row is far off at
the water speeds a boat makes into a flood current) and slow yaw and sway ones; it is not the
default because it settles onto a leg more slowly after a corner (the heading lags its command
by 2-3 deg for seconds; the test suite's cross-current square: 0.57 m off mid-leg, 0.5 allowed)
and measured no better on the arrivals and holds (``docs/tuning.md``).  Near standstill in a
current the law lets the boat wander, so station keeping runs the PID family unless
``USV_STN_CTRL`` is 1 (:mod:`companion.control.system`); this law is for making way.

On a leg with the chapter's filter (``ControlTarget.leg``, a course to make good, and the
estimator's current, ``current``), the yaw row is evaluated with the *fast* part of the
current-induced coupling taken out:

    f_r = [A(nu) nu]_r - HP( [A(nu) nu]_r - [A(nu_r) nu_r]_r ),   HP(x) = x - LowPass(x, tau)

(``coupling_tau_s``).  The chapter's delta_nu follows the slow part of the over-ground model's
error, but a heading wobble across a current changes the sway the over-ground model sees faster
than that; its fictitious yaw moment snaked the boat 0.7-0.85 m off a leg across 1.2 m/s.  The
slow part stays with delta_nu, so in steady running the law is the chapter's.  The measurements
behind these choices are in ``docs/tuning.md``; the current figures in ``usv bench`` (``control``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from companion.angles import current_along_mps, current_body_mps, wrap_pi
from companion.control.actuator import Saturation
from companion.control.am_speed import AmSpeedConfig, AmSpeedLaw
from companion.control.pid import LowPass
from companion.control.pid_family import HeadingLoopConfig, desired_turn_rate
from companion.control.target import ControlOutput, ControlTarget, CrabEstimator
from companion.messages import NavState
from companion.models.base import FloatArray
from companion.models.qlpv import QLPVModel

DeltaNuSource = Callable[[], tuple[float, float, float] | None]
"""Returns the latest model-error estimate delta_nu (m/s^2, m/s^2, rad/s^2), or None."""
CurrentSource = Callable[[], tuple[float, float] | None]
"""Returns the latest water-current estimate (north, east m/s), or None."""


@dataclass(frozen=True, slots=True)
class ActiveModelConfig:
    heading: HeadingLoopConfig = field(default_factory=HeadingLoopConfig)
    rate_k_per_s: float = 6.0
    """k_r: bandwidth of the turn-rate error dynamics (1/s)."""
    speed: AmSpeedConfig = field(default_factory=AmSpeedConfig)
    """The surge row's law (:mod:`companion.control.am_speed`)."""
    rate_ff_tau_s: float = 0.2
    """Command filter on the derivative of the desired turn rate, fed forward into the yaw
    acceleration demand (backstepping); 0 disables the feed-forward."""
    rate_ff_max_radps2: float = 1.0
    """Bound on that feed-forward (rad/s^2), so a jump of the desired course (a new leg) does
    not turn into a yaw-acceleration spike."""
    compensate_model_error: bool = True
    model_error_tau_s: float = 1.0
    """Low-pass time constant on delta_nu: compensate wind, drift and model mismatch, but do not
    chase first-order wave forces (wave filtering, Fossen 2021 ch. 13)."""
    nozzle_max_rad: float = math.radians(60.0)
    turn_throttle_max: float = 0.4
    """Largest throttle the yaw row may ask for when the commanded speed is below
    ``turn_boost_speed_mps`` (unless the speed law itself asks for more); it rises to full
    throttle with the turn rate guidance plans (``course_rate_radps``: circling a point); a hold
    orbit (``ControlTarget.circling``) is not capped."""
    turn_boost_speed_mps: float = 2.0
    yaw_inversion_min_throttle: float = 0.2
    """Below ``turn_boost_speed_mps`` the nozzle angle is solved as if the jet pushed at least
    this throttle's thrust; the surge row keeps what it asked for and the yaw row gets less than
    it asked.  At idle thrust the exact inversion turns the smallest yaw demand into full nozzle
    and the nozzle chatters from side to side."""
    coupling_tau_s: float = 0.5
    """On a leg with the chapter's filter: the low-pass time constant that splits the current-induced
    yaw coupling into the slow part left to delta_nu and the fast part taken out of the model
    (module docstring); 0 disables it."""
    turn_boost_full_error_rad: float = math.radians(90.0)
    """Below ``turn_boost_speed_mps`` the yaw row's extra thrust is scaled by the turn asked
    for: full at this heading error (or at the largest desired turn rate), in proportion below.
    Holding a heading at idle then does not rev the engine over every small yaw error (which
    pushed the boat off its station): a real turn still gets the thrust it needs, a wobble does
    not."""


def throttle_for_thrust(model: QLPVModel, thrust: float, u_mps: float) -> float:
    """Invert ``T~ = thr^2 - c thr u`` for thr >= 0 (the larger root)."""
    c_u = model.thrust_speed_coeff * max(u_mps, 0.0)
    return 0.5 * (c_u + math.sqrt(c_u * c_u + 4.0 * max(thrust, 0.0)))


class ActiveModelController:
    """Nominal qLPV inversion + UKF model-error compensation (chapter Fig. 6)."""

    name = "active_model"

    def __init__(self, model: QLPVModel, cfg: ActiveModelConfig | None = None,
                 delta_nu: DeltaNuSource | None = None, current: CurrentSource | None = None,
                 model_current: CurrentSource | None = None) -> None:
        """``model_current``: the current ``delta_nu`` was estimated against when it is the error of
        the model on the velocity through the water (the current-augmented filter; ``None`` from it
        when delta_nu is over the ground), so the model is evaluated there too (module docstring);
        ``current``: the vehicle's current estimate, for the commanded speed through the water."""
        self.model = model
        self.cfg = cfg or ActiveModelConfig()
        self.delta_nu_source = delta_nu
        self.current_source = current
        """The water current that gives the commanded speed through the water (module docstring)."""
        self.model_current_source = model_current
        """The current delta_nu was estimated against: nu_r of the water-relative model."""
        self.crab = CrabEstimator(self.cfg.heading.crab_tau_s)
        b = model.b_matrix()
        self._b_u = float(b[0, 1])
        self._b_r = float(b[2, 0])
        if self._b_u <= 0 or self._b_r == 0:
            raise ValueError(f"model {model.name!r} has no surge/yaw control authority (B = {b.tolist()})")
        self.dnu_u_raw = 0.0
        """Latest delta_nu_u (m/s^2); the speed law filters it itself."""
        self.dnu_r = 0.0
        """delta_nu_r low-passed with ``model_error_tau_s`` (rad/s^2)."""
        self.speed_law = AmSpeedLaw(model, self.cfg.speed)
        self._dnu_r_lp = LowPass(self.cfg.model_error_tau_s, 0.0)
        self._last_rd: float | None = None
        self._rd_dot_lp = LowPass(self.cfg.rate_ff_tau_s, 0.0)
        self._coupling_lp: LowPass | None = None
        """The slow part of the current-induced yaw coupling (rad/s^2) while on a leg, else ``None``."""

    def reset(self, nav: NavState) -> None:
        self.crab.reset()
        self.speed_law.reset()
        self._last_rd = None
        self._rd_dot_lp.value = 0.0
        self._coupling_lp = None

    def _model_current_ne(self) -> tuple[float, float] | None:
        """The current delta_nu was estimated against (north, east m/s): in the body frame,
        ``R(psi)^T V_c``, it is what is taken off the velocity over ground to get the one through
        the water; ``None`` unless the model error is the water-relative model's and fresh."""
        source = self.model_current_source
        return source() if source is not None else None

    def _update_model_error(self, dt_s: float) -> None:
        """Take the UKF's latest delta_nu (kept as it was when none or not finite; zero when
        compensation is off).  Sway is the zero dynamics: its row is not used."""
        if not self.cfg.compensate_model_error or self.delta_nu_source is None:
            return
        dn = self.delta_nu_source()
        if dn is not None and all(math.isfinite(x) for x in dn):
            self.dnu_u_raw = dn[0]
            self.dnu_r = self._dnu_r_lp.step(dn[2], dt_s)

    def _fast_coupling_radps2(self, nav: NavState, target: ControlTarget, nu: FloatArray, f_r: float,
                              water_relative: bool, current: tuple[float, float] | None,
                              dt_s: float) -> float:
        """The fast part of the current-induced yaw coupling, ``HP(f_r(nu) - f_r(nu_r))`` (module
        docstring), on a leg with the chapter's filter (``nu`` over the ground: not
        ``water_relative``) and the estimator's current; 0 otherwise (and the filter starts again
        from the coupling of the moment on the next leg)."""
        if (self.cfg.coupling_tau_s <= 0.0 or not target.leg or target.is_heading or current is None
                or water_relative):
            self._coupling_lp = None
            return 0.0
        u_c, v_c = current_body_mps(nav.heading_rad, current)
        nu_r = np.array([nu[0] - u_c, nu[1] - v_c, nu[2]])
        coupling = f_r - float((self.model.a_of_nu(nu_r) @ nu_r)[2])
        if self._coupling_lp is None:
            self._coupling_lp = LowPass(self.cfg.coupling_tau_s, coupling)
        return coupling - self._coupling_lp.step(coupling, dt_s)

    def _rd_dot(self, r_d: float, dt_s: float) -> float:
        """Derivative of the virtual control ``r_d`` through a first-order command filter
        (command-filtered backstepping), bounded; 0 when disabled or on the first step."""
        c = self.cfg
        if c.rate_ff_tau_s <= 0.0 or self._last_rd is None or dt_s <= 0.0:
            self._last_rd = r_d
            return 0.0
        raw = (r_d - self._last_rd) / dt_s
        self._last_rd = r_d
        rd_dot = self._rd_dot_lp.step(raw, dt_s)
        return max(-c.rate_ff_max_radps2, min(c.rate_ff_max_radps2, rd_dot))

    def _turn_intent(self, e_psi: float, r_d: float) -> float:
        """How much of a turn guidance asks for, 0-1: the larger of the heading error over
        ``turn_boost_full_error_rad`` and the desired turn rate over the largest turn rate."""
        c = self.cfg
        return min(1.0, max(abs(e_psi) / c.turn_boost_full_error_rad,
                            abs(r_d) / c.heading.turn_rate_max_radps))

    def _turn_throttle_cap(self, planned_rate_radps: float) -> float:
        """Throttle cap of the yaw-row boost: ``turn_throttle_max`` for turning toward a heading,
        rising to full throttle with the guidance's planned turn rate (circling a point)."""
        c = self.cfg
        planned = min(1.0, abs(planned_rate_radps) / c.heading.turn_rate_max_radps)
        return c.turn_throttle_max + (1.0 - c.turn_throttle_max) * planned

    def _allocate(self, w_sin: float, w_cos: float) -> tuple[float, float]:
        """Nozzle angle and normalised thrust for ``w = T [sin delta, cos delta]``.  At the nozzle
        limit the yaw row has priority: a water jet only turns while it pushes, so the thrust is
        the one that gives the requested yaw moment at full nozzle, and the surge row gets what
        that thrust leaves (never less than it asked for)."""
        c = self.cfg
        delta = math.atan2(w_sin, w_cos)
        if abs(delta) <= c.nozzle_max_rad:
            return delta, math.hypot(w_sin, w_cos)
        delta = math.copysign(c.nozzle_max_rad, delta)
        return delta, max(w_cos / math.cos(delta), abs(w_sin) / math.sin(c.nozzle_max_rad))

    @staticmethod
    def _commanded_water_speed_mps(nav: NavState, target: ControlTarget,
                                   current: tuple[float, float] | None) -> float:
        """The commanded speed through the water: over ground minus the estimator's ``current``
        along the bow (the commanded speed itself without an estimate)."""
        return target.speed_mps - current_along_mps(nav.heading_rad, current)

    def _allocate_near_standstill(self, w_sin: float, w_cos: float, nav: NavState, target: ControlTarget,
                                  e_psi: float, r_d: float, u_water_mps: float,
                                  capped: bool = True) -> tuple[float, float]:
        """:meth:`_allocate` below ``turn_boost_speed_mps``: the nozzle is solved against at least
        the thrust of ``yaw_inversion_min_throttle``, and the yaw row's extra thrust at the nozzle
        limit is scaled by the turn asked for and, when ``capped``, capped (module docstring)."""
        c = self.cfg
        floor = float(self.model.thrust(c.yaw_inversion_min_throttle, u_water_mps))
        delta = math.atan2(w_sin, max(w_cos, floor))
        surge_only = max(w_cos, 0.0)
        if abs(delta) <= c.nozzle_max_rad:
            return delta, surge_only / math.cos(delta)
        delta = math.copysign(c.nozzle_max_rad, delta)
        surge_only /= math.cos(delta)
        yaw_priority = max(surge_only, abs(w_sin) / math.sin(c.nozzle_max_rad))
        thrust = surge_only + self._turn_intent(e_psi, r_d) * (yaw_priority - surge_only)
        if not capped:
            return delta, thrust
        cap = float(self.model.thrust(self._turn_throttle_cap(target.course_rate_radps), u_water_mps))
        return delta, min(thrust, max(surge_only, cap))

    def update(self, nav: NavState, target: ControlTarget, dt_s: float, sat: Saturation) -> ControlOutput:
        c = self.cfg
        self.crab.update(nav, dt_s)
        psi_d = self.crab.heading_command(target)
        e_psi = wrap_pi(psi_d - nav.heading_rad)
        r_d = desired_turn_rate(c.heading, e_psi, target.course_rate_radps, nav.u_mps, target.u_turn)
        model_current = self._model_current_ne()
        u_c, v_c = current_body_mps(nav.heading_rad, model_current)
        u_water = nav.u_mps - u_c
        nu = np.array([u_water, nav.v_mps - v_c, nav.r_radps])  # nu_r (nu without a current)
        f = self.model.a_of_nu(nu) @ nu
        self._update_model_error(dt_s)
        r_dot_d = c.rate_k_per_s * (r_d - nav.r_radps) + self._rd_dot(r_d, dt_s)
        current = self.current_source() if self.current_source is not None else None
        water_relative = model_current is not None
        fast = self._fast_coupling_radps2(nav, target, nu, float(f[2]), water_relative, current, dt_s)
        f_r = float(f[2]) - fast
        w_sin = (r_dot_d - f_r - self.dnu_r) / self._b_r
        w_cos = self.speed_law.thrust_demand(nav, target.speed_mps, self.dnu_u_raw, dt_s, float(f[0]))
        slow_over_ground = target.speed_mps < c.turn_boost_speed_mps
        stopping = target.stopping and nav.u_mps > target.speed_mps + c.speed.brake_deadband_mps
        if target.u_turn:
            delta, thrust = self._allocate(w_sin, w_cos)
        elif (slow_over_ground or stopping
                or self._commanded_water_speed_mps(nav, target, current) < c.turn_boost_speed_mps):
            delta, thrust = self._allocate_near_standstill(w_sin, w_cos, nav, target, e_psi, r_d, u_water,
                                                           capped=slow_over_ground and not target.circling)
        else:
            delta, thrust = self._allocate(w_sin, w_cos)
        throttle = throttle_for_thrust(self.model, thrust, u_water)
        return ControlOutput(nozzle_rad=delta, throttle=min(1.0, throttle), heading_cmd_rad=psi_d)
