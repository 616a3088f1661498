"""The baseline controller family: cascaded PID course keeping and PID speed control.

Structured like ArduPilot Rover's attitude controller (AR_AttitudeControl): the heading error
gives a desired turn rate (P, saturated at the maximum turn rate, plus the guidance feed-forward
rate); a rate PID with feed-forward gives the nozzle angle.  Speed is a PI loop on surge speed
over ground with a throttle feed-forward proportional to the desired speed (ArduPilot's
CRUISE_THROTTLE/CRUISE_SPEED scheme).  Both integrators stop on actuator saturation
(:mod:`companion.control.pid`).  Steering gains are scaled by ``sqrt(speed_ref / U)``: measured
steady turn rate per nozzle angle of the boat roughly doubles from 1.3 to 5 m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from companion.angles import wrap_pi
from companion.control.actuator import Saturation
from companion.control.pid import Pid, PidGains
from companion.control.target import ControlOutput, ControlTarget, CrabEstimator
from companion.messages import NavState


@dataclass(frozen=True, slots=True)
class HeadingLoopConfig:
    """Outer heading loop shared by both controller families."""

    heading_p_per_s: float = 2.0
    """Desired turn rate per radian of heading error (1/s) at ``speed_ref_mps``."""
    turn_rate_max_radps: float = math.radians(45.0)
    u_turn_rate_max_radps: float = math.radians(60.0)
    """Largest turn rate in a U-turn onto a leg (:attr:`ControlTarget.u_turn`)."""
    crab_tau_s: float = 0.3
    speed_ref_mps: float = 5.0
    """Below this speed the heading gain shrinks with sqrt(U / speed_ref) (less yaw authority)."""


def desired_turn_rate(cfg: HeadingLoopConfig, heading_err_rad: float, ff_radps: float,
                      u_mps: float, u_turn: bool = False) -> float:
    """``r_d = sat(k_psi(U) * e_psi, r_max) + r_ff`` (the guidance rate is added after saturation);
    ``r_max`` is ``u_turn_rate_max_radps`` in a ``u_turn``, else ``turn_rate_max_radps``."""
    k = cfg.heading_p_per_s * min(1.0, max(0.4, math.sqrt(max(u_mps, 0.0) / cfg.speed_ref_mps)))
    r_max = cfg.u_turn_rate_max_radps if u_turn else cfg.turn_rate_max_radps
    r = max(-r_max, min(r_max, k * heading_err_rad))
    return r + ff_radps


@dataclass(frozen=True, slots=True)
class PidConfig:
    heading: HeadingLoopConfig = field(default_factory=HeadingLoopConfig)
    rate_ff: float = 0.8
    """Nozzle angle per turn rate at the reference speed (rad per rad/s)."""
    rate_p: float = 1.0
    rate_i: float = 1.0
    rate_d: float = 0.0
    rate_imax_rad: float = math.radians(20.0)
    speed_ref_mps: float = 5.0
    """Reference speed of the steering gains; they scale with speed_ref / U."""
    speed_p: float = 0.15
    speed_i: float = 0.1
    speed_imax: float = 0.4
    cruise_throttle: float = 0.5
    """Throttle that holds ``cruise_speed_mps`` in calm water (feed-forward)."""
    cruise_speed_mps: float = 5.0
    nozzle_max_rad: float = math.radians(60.0)


class PidController:
    """Cascaded heading -> turn rate -> nozzle PID and speed PI with feed-forward."""

    name = "pid"

    def __init__(self, cfg: PidConfig | None = None) -> None:
        self.cfg = cfg or PidConfig()
        c = self.cfg
        self.crab = CrabEstimator(c.heading.crab_tau_s)
        self.rate_pid = Pid(PidGains(kp=c.rate_p, ki=c.rate_i, kd=c.rate_d, i_max=c.rate_imax_rad,
                                     out_min=-c.nozzle_max_rad, out_max=c.nozzle_max_rad))
        self.speed_pid = Pid(PidGains(kp=c.speed_p, ki=c.speed_i, i_max=c.speed_imax, out_min=0.0,
                                      out_max=1.0))
        self._last_r = 0.0

    def reset(self, nav: NavState) -> None:
        self.crab.reset()
        self.rate_pid.reset()
        self.speed_pid.reset()
        self._last_r = nav.r_radps

    def update(self, nav: NavState, target: ControlTarget, dt_s: float, sat: Saturation) -> ControlOutput:
        c = self.cfg
        self.crab.update(nav, dt_s)
        psi_d = self.crab.heading_command(target)
        e_psi = wrap_pi(psi_d - nav.heading_rad)
        r_d = desired_turn_rate(c.heading, e_psi, target.course_rate_radps, nav.u_mps, target.u_turn)
        u = max(nav.u_mps, 0.5)
        # the jet's yaw authority per nozzle angle grows about with the square root of speed
        scale = min(2.5, max(0.5, math.sqrt(c.speed_ref_mps / u)))
        r_rate = (nav.r_radps - self._last_r) / dt_s if dt_s > 0 else 0.0
        self._last_r = nav.r_radps
        nozzle = self.rate_pid.update(scale * (r_d - nav.r_radps), dt_s, error_rate=-scale * r_rate,
                                      feedforward=scale * c.rate_ff * r_d,
                                      saturated_high=sat.nozzle_high, saturated_low=sat.nozzle_low)
        ff = c.cruise_throttle * max(0.0, target.speed_mps - target.current_along_mps) / c.cruise_speed_mps
        throttle = self.speed_pid.update(target.speed_mps - nav.u_mps, dt_s, feedforward=ff,
                                         saturated_high=sat.throttle_high, saturated_low=sat.throttle_low)
        return ControlOutput(nozzle_rad=nozzle, throttle=throttle, heading_cmd_rad=psi_d)
