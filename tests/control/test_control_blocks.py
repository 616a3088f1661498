"""Control building blocks: PID anti-windup, actuator limits/flags, qLPV inversion, families."""

from __future__ import annotations

import math

import numpy as np
import pytest

from companion.control.active_model import ActiveModelConfig, ActiveModelController, throttle_for_thrust
from companion.control.actuator import (
    NO_SATURATION,
    ActuatorLimits,
    ActuatorMapper,
    nozzle_to_pulse_us,
    throttle_to_pulse_us,
)
from companion.control.pid import Pid, PidGains, RateLimiter
from companion.control.pid_family import PidConfig, PidController, desired_turn_rate
from companion.control.target import STEADY_CRAB_MARGIN_RAD, ControlTarget, CrabEstimator
from companion.guidance.geo import wrap_pi
from companion.messages import NavState
from companion.models.qlpv import QLPV_FEATURES, QLPVModel


def toy_model(yaw_gain: float = 3.0) -> QLPVModel:
    """A hand-made qLPV model with plausible signs (not identified; for unit tests only)."""
    theta = np.zeros((3, len(QLPV_FEATURES)))
    i = QLPV_FEATURES.index
    theta[0, i("u")], theta[0, i("|u|u")], theta[0, i("Tcos")] = -0.1, -0.06, 2.0
    theta[1, i("v")], theta[1, i("r")], theta[1, i("ur")], theta[1, i("Tsin")] = -1.2, -0.1, -0.3, -0.5
    theta[2, i("v")], theta[2, i("r")], theta[2, i("|r|r")], theta[2, i("Tsin")] = 0.2, -1.5, -0.5, yaw_gain
    return QLPVModel(theta=theta, name="toy", thrust_speed_coeff=0.05)


def nav_from(t: float, x: float, y: float, psi: float, nu: np.ndarray) -> NavState:
    u, v, r = (float(a) for a in nu)
    vn = u * math.cos(psi) - v * math.sin(psi)
    ve = u * math.sin(psi) + v * math.cos(psi)
    return NavState(t_s=t, lat_deg=0.0, lon_deg=0.0, alt_m=0.0, heading_rad=psi % (2 * math.pi), roll_rad=0.0,
                    pitch_rad=0.0, vel_north_mps=vn, vel_east_mps=ve, u_mps=u, v_mps=v, r_radps=r)


def test_pid_integrator_stops_growing_into_a_saturated_actuator() -> None:
    pid = Pid(PidGains(kp=1.0, ki=1.0, out_min=-1.0, out_max=1.0))
    for _ in range(100):
        pid.update(0.5, 0.1, saturated_high=True)
    assert pid.integral == 0.0
    for _ in range(10):
        pid.update(0.5, 0.1)
    assert pid.integral == pytest.approx(0.5)  # integrates while the output stays below its limit
    assert pid.update(-0.5, 0.1, saturated_high=True) < 1.0  # may still unwind


def test_pid_holds_its_output_on_nan_input() -> None:
    pid = Pid(PidGains(kp=2.0))
    assert pid.update(0.25, 0.01) == 0.5
    assert pid.update(float("nan"), 0.01) == 0.5


def test_rate_limiter() -> None:
    lim = RateLimiter(2.0)
    assert lim.step(10.0, 0.5) == 1.0
    assert lim.step(-10.0, 0.25) == 0.5


def test_actuator_mapper_limits_slews_and_flags() -> None:
    m = ActuatorMapper(ActuatorLimits(nozzle_max_rad=0.5, nozzle_rate_radps=1.0, throttle_rate_per_s=1.0))
    noz, thr, sat = m.apply(1.0, 0.2, 0.1)
    assert noz == pytest.approx(0.1) and thr == pytest.approx(0.1)
    assert sat.nozzle_high and sat.throttle_high and not sat.nozzle_low
    for _ in range(20):
        noz, thr, sat = m.apply(1.0, 0.2, 0.1)
    assert noz == pytest.approx(0.5) and thr == pytest.approx(0.2)
    assert sat.nozzle_high and not sat.throttle_high  # range limit still reported
    noz, thr, sat = m.apply(float("nan"), float("inf"), 0.1)
    assert math.isfinite(noz) and math.isfinite(thr)


def test_servo_pulses() -> None:
    assert nozzle_to_pulse_us(0.0, 0.5) == 1500
    assert nozzle_to_pulse_us(0.5, 0.5) == 1900 and nozzle_to_pulse_us(-9.0, 0.5) == 1100
    assert throttle_to_pulse_us(0.0) == 1100 and throttle_to_pulse_us(1.0) == 1900


def test_thrust_map_inversion() -> None:
    model = toy_model()
    for thr in (0.0, 0.3, 0.9):
        for u in (0.0, 3.0, 6.0):
            t = float(model.thrust(thr, u))
            if t > 0:
                assert throttle_for_thrust(model, t, u) == pytest.approx(thr)


def test_active_model_inversion_achieves_the_designed_accelerations() -> None:
    """Plant == model: the law's input makes the model produce exactly the desired r_dot and u_dot."""
    model = toy_model()
    cfg = ActiveModelConfig(compensate_model_error=False, nozzle_max_rad=math.radians(40))
    ctl = ActiveModelController(model, cfg)
    nu = np.array([2.0, 0.1, 0.05])
    nav = nav_from(0.0, 0, 0, 0.0, nu)
    target = ControlTarget(course_rad=math.radians(4.0), speed_mps=2.5, is_heading=True)
    out = ctl.update(nav, target, 0.01, NO_SATURATION)
    nu_dot = model.derivative(nu, out.throttle, out.nozzle_rad)
    assert abs(out.nozzle_rad) < cfg.nozzle_max_rad  # not saturated: the law is exact
    r_d = desired_turn_rate(cfg.heading, math.radians(4.0), 0.0, 2.0)
    assert nu_dot[2] == pytest.approx(cfg.rate_k_per_s * (r_d - 0.05), rel=1e-6)
    assert nu_dot[0] == pytest.approx(cfg.speed.k_per_s * 0.5, rel=1e-6)


def test_a_heading_wobble_down_a_current_does_not_rev_the_jet_but_a_turn_keeps_its_thrust() -> None:
    """2.2 m/s over ground down a 0.8 m/s current is 1.4 m/s through the water, where the jet has
    little yaw authority: a heading wobble (3 deg off, swinging away at 11 deg/s, the boat already
    carried to 3 m/s) that saturates the nozzle gets the turn-scaled thrust of a slow boat, not the
    full yaw priority of a boat making way (which held the throttle at 0.8-1.0 and drove the boat
    to 5-6 m/s on a 2.2 m/s leg in usv sitl).
    Without an estimate, or up the current, the boat makes way: full yaw priority.  A U-turn down the
    current keeps the thrust that turns it (no throttle cap, unlike a boat slow over ground)."""
    model = toy_model()
    nav = nav_from(0.0, 0, 0, 0.0, np.array([3.0, 0.0, -0.2]))

    def throttle(course_deg: float, current: tuple[float, float] | None) -> float:
        ctl = ActiveModelController(model, ActiveModelConfig(), delta_nu=lambda: (0.0, 0.0, 0.0),
                                    current=None if current is None else (lambda: current))
        target = ControlTarget(course_rad=math.radians(course_deg), speed_mps=2.2, is_heading=True)
        return ctl.update(nav, target, 0.01, NO_SATURATION).throttle

    making_way = throttle(3.0, None)
    assert making_way > 0.75                                    # full yaw priority
    assert throttle(3.0, (-0.8, 0.0)) == pytest.approx(making_way)  # up the current: making way too
    assert throttle(3.0, (0.8, 0.0)) < making_way - 0.2          # down it: the wobble does not rev the jet
    u_turn = throttle(178.0, None)
    assert throttle(178.0, (0.8, 0.0)) == pytest.approx(u_turn)  # a real turn keeps its thrust
    slow = ActiveModelController(model, ActiveModelConfig(), delta_nu=lambda: (0.0, 0.0, 0.0))
    slow_target = ControlTarget(math.radians(178.0), 1.4, is_heading=True)
    slow_turn = slow.update(nav, slow_target, 0.01, NO_SATURATION)
    assert slow_turn.throttle < u_turn                           # slow over ground: capped


def test_a_u_turn_onto_a_leg_turns_with_all_the_thrust_it_asks_for_and_faster() -> None:
    """A U-turn onto a leg (``ControlTarget.u_turn``) started from station keeping bow into a current:
    commanded 0 over ground, 1.2 m/s through the water.  An ordinary turn there is a slow boat's:
    capped at ``turn_throttle_max`` and asking at most ``turn_rate_max_radps``; the U-turn gets all
    the thrust its yaw row asks for, toward ``u_turn_rate_max_radps`` (at the cap the jet turned at
    20-35 deg/s on a circle 2.5-4.5 m wide and swung 3.5 m past its leg in a 1.2 m/s current)."""
    cfg = ActiveModelConfig()
    half_turn = math.radians(150.0)
    assert desired_turn_rate(cfg.heading, half_turn, 0.0, 1.2) == pytest.approx(
        cfg.heading.turn_rate_max_radps)
    assert desired_turn_rate(cfg.heading, half_turn, 0.0, 1.2, u_turn=True) == pytest.approx(
        cfg.heading.u_turn_rate_max_radps)
    assert cfg.heading.u_turn_rate_max_radps > cfg.heading.turn_rate_max_radps
    model = toy_model()
    nav = nav_from(0.0, 0, 0, 0.0, np.array([1.2, 0.0, 0.0]))

    def output(u_turn: bool) -> tuple[float, float]:
        ctl = ActiveModelController(model, cfg, delta_nu=lambda: (0.0, 0.0, 0.0))
        target = ControlTarget(half_turn, 0.0, is_heading=True, u_turn=u_turn)
        out = ctl.update(nav, target, 0.01, NO_SATURATION)
        return out.throttle, out.nozzle_rad

    turn_throttle, turn_nozzle = output(False)
    u_turn_throttle, u_turn_nozzle = output(True)
    assert turn_throttle == pytest.approx(cfg.turn_throttle_max, abs=1e-6)
    assert u_turn_throttle > turn_throttle + 0.2
    assert turn_nozzle == pytest.approx(cfg.nozzle_max_rad)
    assert u_turn_nozzle == pytest.approx(cfg.nozzle_max_rad)


def test_a_heading_wobble_while_slowing_down_to_stop_does_not_rev_the_jet() -> None:
    """Slowing down at the end of the last leg (GUIDED, RTL: ``ControlTarget.stopping``) from 3 m/s
    to 2.2, a heading wobble that saturates the nozzle gets the turn-scaled thrust of a slow boat:
    with the full yaw priority of a boat making way the wobbles held the throttle at 0.5-0.9 and the
    boat reached its point at 2.5 m/s (usv bench nav).  Slowing down for a corner keeps that
    priority (the turn), and so does a real turn while stopping."""
    model = toy_model()
    nav = nav_from(0.0, 0, 0, 0.0, np.array([3.0, 0.0, -0.2]))

    def throttle(course_deg: float, stopping: bool) -> float:
        ctl = ActiveModelController(model, ActiveModelConfig(), delta_nu=lambda: (0.0, 0.0, 0.0))
        target = ControlTarget(course_rad=math.radians(course_deg), speed_mps=2.2, is_heading=True,
                               stopping=stopping)
        return ctl.update(nav, target, 0.01, NO_SATURATION).throttle

    for_a_corner = throttle(3.0, stopping=False)
    assert for_a_corner > 0.75
    assert throttle(3.0, stopping=True) < for_a_corner - 0.2
    assert throttle(150.0, stopping=True) == pytest.approx(throttle(150.0, stopping=False))


def test_active_model_keeps_steering_thrust_when_asked_to_turn_hard_and_slow_down() -> None:
    """A water jet does not turn without thrust: at the nozzle limit the yaw request wins, so a
    hard turn entered too fast still gets the yaw acceleration it asks for (the boat used to cut
    the throttle to slow down and lose its turn at square corners)."""
    model = toy_model()
    cfg = ActiveModelConfig(compensate_model_error=False, nozzle_max_rad=math.radians(40))
    ctl = ActiveModelController(model, cfg)
    nu = np.array([3.0, 0.0, 0.0])
    target = ControlTarget(course_rad=math.radians(3.0), speed_mps=2.0, is_heading=True)
    out = ctl.update(nav_from(0.0, 0, 0, 0.0, nu), target, 0.01, NO_SATURATION)
    assert out.nozzle_rad == pytest.approx(cfg.nozzle_max_rad) and out.throttle < 1.0
    r_d = desired_turn_rate(cfg.heading, math.radians(3.0), 0.0, 3.0)
    nu_dot = model.derivative(nu, out.throttle, out.nozzle_rad)
    assert nu_dot[2] == pytest.approx(cfg.rate_k_per_s * r_d, rel=1e-6)


def _low_speed_throttle(heading_err_deg: float, planned_rate_radps: float = 0.0,
                        circling: bool = False) -> float:
    """Throttle the active model asks for while nearly stopped (station keeping), with a yaw
    disturbance the idle jet cannot hold at full nozzle."""
    model = toy_model()
    ctl = ActiveModelController(model, ActiveModelConfig(), delta_nu=lambda: (0.0, 0.0, 0.6))
    target = ControlTarget(math.radians(heading_err_deg), 0.0, planned_rate_radps, is_heading=True,
                           circling=circling)
    return ctl.update(nav_from(0.0, 0, 0, 0.0, np.zeros(3)), target, 0.01, NO_SATURATION).throttle


def test_active_model_turns_at_low_speed_with_thrust_but_does_not_rev_for_a_wobble() -> None:
    """Near standstill the yaw row adds thrust in proportion to how much of a turn guidance asks
    for: none to speak of for a 2 degree wobble (revving the jet then pushed the boat off its
    station), up to ``turn_throttle_max`` to turn round, and beyond that only
    for a turn the guidance plans (circling a point at the turning radius)."""
    cfg = ActiveModelConfig()
    wobble, turn_round = _low_speed_throttle(2.0), _low_speed_throttle(150.0)
    planned = _low_speed_throttle(2.0, planned_rate_radps=cfg.heading.turn_rate_max_radps)
    assert wobble < 0.1
    assert turn_round == pytest.approx(cfg.turn_throttle_max, abs=1e-6)
    assert planned > 0.6


def test_active_model_gives_a_hold_orbit_the_thrust_to_come_round() -> None:
    """A hold orbit is one continuous turn: the boat pushed off it with its heading 100 deg off the
    orbit's gets the yaw row's thrust, not the low-speed cap (at the cap it came round in 6-8 m
    loops); a 2 degree wobble on the orbit still does not rev the jet."""
    cfg = ActiveModelConfig()
    assert _low_speed_throttle(100.0, circling=True) > cfg.turn_throttle_max + 0.2
    assert _low_speed_throttle(2.0, circling=True) < 0.1


def _closed_loop(ctl: object, model: QLPVModel, disturbance: np.ndarray, heading_cmd: float,
                 speed_cmd: float, duration_s: float) -> tuple[list[float], list[float]]:
    """Controller + actuator mapper on a qLPV plant with an additive disturbance (Eq. 5)."""
    mapper = ActuatorMapper(ActuatorLimits(nozzle_max_rad=math.radians(30)))
    nu = np.array([speed_cmd, 0.0, 0.0])
    psi, dt, sat = 0.0, 0.01, NO_SATURATION
    throttle = 0.0
    headings, speeds = [], []
    for k in range(int(duration_s / dt)):
        nav = nav_from(k * dt, 0, 0, psi, nu)
        out = ctl.update(nav, ControlTarget(heading_cmd, speed_cmd, is_heading=True), dt, sat)  # type: ignore[attr-defined]
        noz, throttle, sat = mapper.apply(out.nozzle_rad, out.throttle, dt)
        nu = model.step(nu, throttle, noz, dt, disturbance)
        psi += nu[2] * dt
        headings.append(wrap_pi(heading_cmd - psi))
        speeds.append(speed_cmd - nu[0])
    return headings, speeds


def test_model_error_compensation_removes_the_steady_offset_of_the_nominal_law() -> None:
    model = toy_model()
    disturbance = np.array([-0.2, 0.0, 0.3])  # e.g. a wind moment and drag the model does not know
    nominal = ActiveModelController(model, ActiveModelConfig(compensate_model_error=False))
    h_nom, s_nom = _closed_loop(nominal, model, disturbance, 0.5, 3.0, 30.0)
    compensated = ActiveModelController(model, ActiveModelConfig(),
                                        delta_nu=lambda: (float(disturbance[0]), 0.0, float(disturbance[2])))
    h_cmp, s_cmp = _closed_loop(compensated, model, disturbance, 0.5, 3.0, 30.0)
    assert abs(h_nom[-1]) > math.radians(1.0) and abs(s_nom[-1]) > 0.05
    assert abs(h_cmp[-1]) < math.radians(0.05) and abs(s_cmp[-1]) < 0.005


def test_turn_rate_feedforward_removes_the_heading_overshoot_of_the_active_model() -> None:
    """Command-filtered backstepping: feeding d/dt r_d forward keeps the heading from overshooting
    a step that the law without it overshoots (plant == model, no disturbance)."""
    model = toy_model()
    overshoot = {}
    for tau in (0.0, 0.2):
        cfg = ActiveModelConfig(compensate_model_error=False, rate_k_per_s=4.0, rate_ff_tau_s=tau)
        ctl = ActiveModelController(model, cfg)
        errors, _ = _closed_loop(ctl, model, np.zeros(3), 1.0, 5.0, 15.0)
        overshoot[tau] = max(0.0, -min(errors))
    assert overshoot[0.0] > math.radians(0.2)
    assert overshoot[0.2] < 0.5 * overshoot[0.0]


def test_pid_family_removes_the_steady_offset_with_integral_action() -> None:
    model = toy_model()
    cfg = PidConfig(cruise_throttle=0.5, cruise_speed_mps=3.0, speed_ref_mps=3.0)
    h, s = _closed_loop(PidController(cfg), model, np.array([-0.2, 0.0, 0.15]), 0.5, 3.0, 60.0)
    assert abs(h[-1]) < math.radians(0.5) and abs(s[-1]) < 0.05


def test_active_model_refuses_a_model_without_control_authority() -> None:
    model = toy_model(yaw_gain=0.0)
    with pytest.raises(ValueError, match="authority"):
        ActiveModelController(model)


def test_water_relative_law_steers_a_boat_carried_by_a_current_as_the_same_boat_in_still_water() -> None:
    """With the current-augmented filter (delta_nu of the model through the water) the active-model
    law evaluates the qLPV model on nu_r = nu - R(psi)^T V_c, V_c the current that filter estimated
    with delta_nu (``model_current``): a boat making 3 m/s through the water while a 1.2 m/s
    current carries it sideways gets the nozzle and throttle of the same boat in still water.  On
    over-ground velocities the current's 1.2 m/s reads as sway, whose coupling into yaw (the toy
    model's N_v) moves the nozzle; so it does when only the vehicle's current estimate
    (``current``, what guidance holds by) is there: the model is evaluated against the current its
    own delta_nu belongs to."""
    model = toy_model()
    current = (0.0, 1.2)  # toward east; the bow points north, so the current is all sway
    in_current = nav_from(0.0, 0, 0, 0.0, np.array([3.0, 1.2, 0.05]))
    still = nav_from(0.0, 0, 0, 0.0, np.array([3.0, 0.0, 0.05]))
    target = ControlTarget(course_rad=math.radians(10.0), speed_mps=3.5, is_heading=True)

    def output(nav: NavState, vehicle_current: bool, model_current: bool) -> tuple[float, float]:
        ctl = ActiveModelController(model, ActiveModelConfig(), delta_nu=lambda: (0.0, 0.0, 0.0),
                                    current=(lambda: current) if vehicle_current else None,
                                    model_current=(lambda: current) if model_current else None)
        out = ctl.update(nav, target, 0.01, NO_SATURATION)
        return out.nozzle_rad, out.throttle

    reference = output(still, vehicle_current=False, model_current=False)
    for vehicle_current in (True, False):
        water_relative = output(in_current, vehicle_current, model_current=True)
        assert water_relative == pytest.approx(reference, abs=1e-9)
    over_ground = output(in_current, vehicle_current=True, model_current=False)
    assert abs(over_ground[0] - reference[0]) > math.radians(2.0)


def test_a_turns_sideslip_does_not_lead_the_heading_past_the_next_leg() -> None:
    """Coming out of a turn onto a leg heading 180 deg the hull still slips 25 deg (course 175,
    bow 200): removed in full, that crab would hold the bow at 205 deg, 19 past the 186 deg that
    holds the leg through the current guidance has observed (steady crab -6 deg).  With the steady
    crab known the removed crab stays within the margin of it; without, or for a heading, as before."""
    crab = CrabEstimator(tau_s=0.3)
    slip = [3.0, 3.0 * math.tan(math.radians(-25.0)), 0.5]
    for k in range(40):
        beta_rad = crab.update(nav_from(0.1 * k, 0.0, 0.0, math.radians(200.0), np.array(slip)), 0.1)
    assert beta_rad == pytest.approx(math.radians(-25.0), abs=1e-3)
    leg = ControlTarget(math.radians(180.0), 4.0, leg=True)
    assert math.degrees(crab.heading_command(leg)) == pytest.approx(205.0, abs=0.1)
    steady = ControlTarget(math.radians(180.0), 4.0, leg=True, steady_crab_rad=math.radians(-6.0))
    expected_deg = 180.0 + 6.0 + math.degrees(STEADY_CRAB_MARGIN_RAD)
    assert math.degrees(crab.heading_command(steady)) == pytest.approx(expected_deg, abs=0.1)
    heading = ControlTarget(math.radians(180.0), 4.0, is_heading=True, steady_crab_rad=math.radians(-6.0))
    assert math.degrees(crab.heading_command(heading)) == pytest.approx(180.0)
    # on the leg in steady running the measured crab is the steady one: nothing is clamped
    for k in range(40):
        crab.update(nav_from(4.0 + 0.1 * k, 0.0, 0.0, math.radians(186.0),
                             np.array([4.0, 4.0 * math.tan(math.radians(-6.0)), 0.0])), 0.1)
    assert crab.heading_command(steady) == pytest.approx(crab.heading_command(leg))


def test_on_a_leg_a_heading_wobble_across_a_current_is_not_read_as_a_yaw_moment() -> None:
    """Running north at 4 m/s through the water in a 1.2 m/s current toward north-east (the sway
    over ground is the current's): the over-ground model's sway-yaw coupling depends on the
    heading, so a 2 deg wobble changes the yaw moment it predicts although the sway through the
    water did not change.  On a leg the law takes that fast change out (``coupling_tau_s``); in
    steady running it is the chapter's law again (the slow part is left to delta_nu), and off a
    leg (a heading target) or with the correction off it is unchanged."""
    theta = toy_model().theta.copy()
    theta[2, QLPV_FEATURES.index("v")] = 2.0  # a strong sway-yaw coupling
    model = QLPVModel(theta=theta, name="toy", thrust_speed_coeff=0.05)
    current = (1.2 * math.cos(math.radians(45.0)), 1.2 * math.sin(math.radians(45.0)))

    def nav_at(t_s: float, psi: float) -> NavState:
        u_c = current[0] * math.cos(psi) + current[1] * math.sin(psi)  # R(psi)^T V_c
        v_c = -current[0] * math.sin(psi) + current[1] * math.cos(psi)
        return nav_from(t_s, 0, 0, psi, np.array([4.0 + u_c, v_c, 0.0]))

    def nozzles(tau_s: float, target: ControlTarget) -> list[float]:
        ctl = ActiveModelController(model, ActiveModelConfig(coupling_tau_s=tau_s),
                                    delta_nu=lambda: (0.0, 0.0, 0.0), current=lambda: current)
        out = []
        for k in range(700):
            psi = math.radians(2.0) if k >= 300 else 0.0  # the wobble at 3 s
            out.append(ctl.update(nav_at(0.01 * k, psi), target, 0.01, NO_SATURATION).nozzle_rad)
        return out

    steady = nav_at(0.0, 0.0)
    course = math.atan2(steady.vel_east_mps, steady.vel_north_mps)  # made good at heading 0
    leg = ControlTarget(course, 4.0, leg=True)
    heading = ControlTarget(0.0, 4.0, is_heading=True)
    before, after = nozzles(0.0, leg), nozzles(0.5, leg)
    assert abs(before[299]) < math.radians(55.0)               # not at the nozzle's stop
    assert after[:300] == pytest.approx(before[:300])          # steady: the chapter's law
    assert abs(after[300] - before[300]) > math.radians(0.5)   # the wobble: the fictitious moment is gone
    assert after[-1] == pytest.approx(before[-1], abs=1e-3)    # 4 s on: the slow part is delta_nu's again
    assert nozzles(0.5, heading) == pytest.approx(nozzles(0.0, heading))
