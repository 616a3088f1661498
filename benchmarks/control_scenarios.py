"""The control figures of issue 6, measured on the simulated plant for one controller family.

Each scenario returns a dict of measured figures; :mod:`benchmarks.control` runs them for both
controller families with the same plant and seeds and prints them side by side.  Definitions:

- course keeping: 5 m/s, 3 m/s wind, waves Hs 0.3 m; a 90 degree heading step.  Overshoot is
  the largest excursion past the new heading; steady RMS is over the windows before the step and
  from 15 s after it.
- speed: a 2 -> 6 m/s step in the same weather; overshoot in percent of the step size, steady
  RMS of the surge speed over ground from 15 s after the step.
- path following: a 50 m square at 5 m/s with 0.5 m/s current across the north-south legs,
  3 m/s wind and waves.  Cross-track error is the distance to the square; "mid-leg" keeps the
  samples 10 m after each leg start to 10 m before its end.
- point tracking (chapter Fig. 12-13): four sampling points, each circled at the commanded radius
  for ``sample_s`` with 0.3 m/s current; sampling starts 10 s after the boat first reaches the
  circle.  Radial error is |distance - radius|; also the largest distance from the point.
- station keeping (not an issue figure; LOITER, GUIDED and RTL hold a point this way): a 1.2 m/s
  flood current, 3 m/s wind and waves; the boat starts stopped on the point, across the current,
  and :class:`~companion.guidance.station.StationKeeper` holds it bow into the current.  Distance
  from the point, largest and RMS, once settled (the second half of the run).
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np

from benchmarks.control_rig import Environment, Rig
from companion.control.active_model import throttle_for_thrust
from companion.control.target import ControlTarget
from companion.guidance.circle import CircleTracker
from companion.guidance.geo import distance_to_segment_m, wrap_pi
from companion.guidance.los import LosFollower, LosType
from companion.guidance.params import circle_gains, leg_config, los_gains, station_gains
from companion.guidance.station import StationKeeper
from companion.guidance.waypoints import LegNavigator
from companion.models.qlpv import QLPVModel

WEATHER = {"wind_mps": 3.0, "wind_from_deg": 45.0, "waves_hs_m": 0.3}


def _rms(x: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x else float("nan")


def course_keeping(ctrl_type: int, model: QLPVModel, seed: int, quick: bool = False) -> dict[str, Any]:
    rig = Rig(ctrl_type, Environment(seed=seed, **WEATHER), model)
    hold_s = 10.0 if quick else 20.0
    target = ControlTarget(0.0, 5.0, is_heading=True)
    for _ in range(int(25.0 / 0.01)):
        rig.step(target)
    steady: list[float] = []
    for _ in range(int(hold_s / 0.01)):
        steady.append(math.degrees(wrap_pi(rig.step(target).heading_rad)))
    target = ControlTarget(math.pi / 2, 5.0, is_heading=True)
    after: list[float] = []
    for _ in range(int((15.0 + hold_s) / 0.01)):
        after.append(math.degrees(wrap_pi(rig.step(target).heading_rad - math.pi / 2)))
    n15 = int(15.0 / 0.01)
    settle = next((i * 0.01 for i in range(len(after)) if all(abs(e) < 2.0 for e in after[i:n15])), None)
    return {"overshoot_deg": round(max(0.0, max(after)), 2),
            "steady_rms_deg": round(_rms(steady + after[n15:]), 3),
            "settling_2deg_s": None if settle is None else round(settle, 2)}


def speed_step(ctrl_type: int, model: QLPVModel, seed: int, quick: bool = False) -> dict[str, Any]:
    rig = Rig(ctrl_type, Environment(seed=seed, **WEATHER), model)
    hold_s = 10.0 if quick else 20.0
    for _ in range(int(25.0 / 0.01)):
        rig.step(ControlTarget(0.0, 2.0, is_heading=True))
    target = ControlTarget(0.0, 6.0, is_heading=True)
    speeds = [rig.step(target).u_mps for _ in range(int((15.0 + hold_s) / 0.01))]
    n15 = int(15.0 / 0.01)
    rise = next((i * 0.01 for i, u in enumerate(speeds) if u >= 2.0 + 0.9 * 4.0), None)
    return {"overshoot_pct": round(max(0.0, (max(speeds) - 6.0) / 4.0 * 100.0), 2),
            "steady_rms_mps": round(_rms([u - 6.0 for u in speeds[n15:]]), 4),
            "rise_10_90_s": None if rise is None else round(rise, 2)}


def _frozen_throttle_run(rig: Rig, target: ControlTarget, throttle: float, hold_s: float,
                         oracle_gain: float = 0.0) -> list[float]:
    """Hold ``throttle`` (heading still controlled) for ``hold_s``; with ``oracle_gain`` > 0 add
    the throttle that cancels that fraction of the first-order wave surge force, known exactly
    0.01 s ahead, with the engine lag inverted (thr + tau_e d thr/dt) through the same actuator
    limits (range and slew rate).  Returns the surge speeds."""
    plant = rig.plant
    env, mass = plant.env, plant.derived.mass_kg
    b_u = float(rig.model.b_matrix()[0, 1])
    tau_e = plant.params.engine_tau_s

    def first_order_wave_accel(t_s: float, ahead_s: float) -> float:
        st = plant.state
        d = ahead_s * st.u_mps
        fx, _, _ = env.wave_force(t_s + ahead_s, st.north_m + d * math.cos(st.psi_rad),
                                  st.east_m + d * math.sin(st.psi_rad), st.psi_rad, mass)
        return (fx - env.wave_drift_n * math.cos(env.wave_toward_rad - st.psi_rad)) / mass

    def cancelling_throttle(accel: float) -> float:
        thrust = max(0.0, throttle * throttle - oracle_gain * accel / b_u)
        return throttle_for_thrust(rig.model, thrust, plant.state.u_mps)

    target_dt = 0.01
    speeds = []
    for _ in range(int(hold_s / target_dt)):
        out = rig.controller.update(rig.nav(), target, target_dt, rig.mapper.saturation)
        thr = throttle
        if oracle_gain > 0.0:
            t_now = plant.state.t_s
            thr0 = cancelling_throttle(first_order_wave_accel(t_now, 0.0))
            thr1 = cancelling_throttle(first_order_wave_accel(t_now, target_dt))
            thr = thr0 + tau_e * (thr1 - thr0) / target_dt
        nozzle, thr_applied, _ = rig.mapper.apply(out.nozzle_rad, thr, target_dt)
        plant.step(target_dt, nozzle, thr_applied, True)
        speeds.append(plant.state.u_mps)
    return speeds


def _detrended(speeds: list[float]) -> np.ndarray:
    t = np.arange(len(speeds))
    return np.asarray(speeds) - np.polyval(np.polyfit(t, speeds, 1), t)


ORACLE_GAINS = (0.05, 0.1, 0.15, 0.25)
"""Fractions of the wave surge force the oracle tries to cancel (the best one is reported)."""


def speed_wave_floor(model: QLPVModel, seed: int, quick: bool = False) -> dict[str, Any]:
    """What the waves alone do to the surge speed: 6 m/s in the speed-step weather, then the
    throttle frozen (heading still held) for ``hold_s``.  The standard deviation of the surge
    speed about its trend and its largest excursion (in % of the 2 -> 6 m/s step) are the floor
    below which no speed controller can push the steady RMS and the overshoot figures.

    Also the best any speed controller could do within the actuators: from the same state, an
    oracle that knows the first-order wave surge force exactly and ahead and inverts the 0.4 s
    engine lag, through the same throttle range and slew rate (best of ``ORACLE_GAINS``)."""
    rig = Rig(0, Environment(seed=seed, **WEATHER), model)
    hold_s = 10.0 if quick else 20.0
    target = ControlTarget(0.0, 6.0, is_heading=True)
    for _ in range(int(40.0 / 0.01)):
        rig.step(target)
    throttle = rig.throttle
    oracle = min((_detrended(_frozen_throttle_run(copy.deepcopy(rig), target, throttle, hold_s, g))
                  for g in ORACLE_GAINS), key=lambda r: float(np.std(r)))
    resid = _detrended(_frozen_throttle_run(rig, target, throttle, hold_s))
    return {"surge_rms_mps": round(float(np.std(resid)), 4),
            "surge_peak_pct": round(float(np.max(resid)) / 4.0 * 100.0, 2),
            "throttle_at_6mps": round(throttle, 3),
            "oracle_rms_mps": round(float(np.std(oracle)), 4),
            "oracle_peak_pct": round(float(np.max(oracle)) / 4.0 * 100.0, 2)}


def square(ctrl_type: int, model: QLPVModel, seed: int, quick: bool = False) -> dict[str, Any]:
    env = Environment(seed=seed, current_mps=0.5, current_toward_deg=90.0, **WEATHER)
    rig = Rig(ctrl_type, env, model)
    side = 50.0
    corners = [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side), (0.0, 0.0), (side, 0.0)]
    n_scored = 2 if quick else 4
    route = [(-30.0, 0.0), *corners[: n_scored + 2]]
    scored_legs = [(corners[i], corners[i + 1]) for i in range(4)]
    p = rig.params
    nav_leg = LegNavigator(LosFollower(los_gains(p), LosType(int(p.get("USV_LOS_TYPE")))),
                           leg_config(p, speed_mps=5.0, accept_radius_m=2.0))
    mid: list[float] = []
    whole: list[float] = []
    for i in range(n_scored + 1):
        nav_leg.set_leg(route[i], route[i + 1], route[i + 2])
        for _ in range(int(60.0 / 0.01)):
            nav = rig.nav()
            pos = rig.pos_ne()
            cog = math.atan2(nav.vel_east_mps, nav.vel_north_mps)
            st = nav_leg.update(pos, nav.speed_over_ground_mps, 0.01, cog)
            if st.reached:
                break
            rig.step(st.target)
            if i >= 1:
                whole.append(min(distance_to_segment_m(pos, a, b) for a, b in scored_legs))
                if 10.0 <= st.errors.along_m <= st.errors.leg_length_m - 10.0:
                    mid.append(abs(st.errors.cross_m))
    return {"mid_leg_rms_m": round(_rms(mid), 3), "mid_leg_max_m": round(max(mid), 3),
            "whole_rms_m": round(_rms(whole), 3), "whole_max_m": round(max(whole), 3),
            "duration_s": round(rig.t_s, 1)}


def point_tracking(ctrl_type: int, model: QLPVModel, seed: int, quick: bool = False,
                   radius_m: float | None = None, speed_mps: float | None = None,
                   sample_s: float = 40.0) -> dict[str, Any]:
    env = Environment(seed=seed, current_mps=0.3, current_toward_deg=30.0)
    rig = Rig(ctrl_type, env, model)
    p = rig.params
    radius = radius_m if radius_m is not None else p.get("USV_TURN_RAD")
    speed = speed_mps if speed_mps is not None else p.get("USV_CIRC_SPD")
    points = [(30.0, 0.0), (30.0, 30.0), (0.0, 30.0), (0.0, 0.0)][: 2 if quick else 4]
    per_point: list[dict[str, float]] = []
    for centre in points:
        tracker = CircleTracker(centre, radius, clockwise=True, gains=circle_gains(p))
        t_capture: float | None = None
        radial: list[float] = []
        dist: list[float] = []
        for _ in range(int((90.0 + sample_s) / 0.01)):
            nav = rig.nav()
            out = tracker.update(rig.pos_ne(), nav.speed_over_ground_mps, 0.01)
            far = out.distance_m > radius + 10.0
            rig.step(ControlTarget(out.course_rad, 3.0 if far else speed, out.course_rate_radps))
            if t_capture is None and out.distance_m <= radius + 0.5:
                t_capture = rig.t_s
            if t_capture is not None and rig.t_s >= t_capture + 10.0:
                radial.append(abs(out.radial_error_m))
                dist.append(out.distance_m)
                if rig.t_s >= t_capture + 10.0 + sample_s:
                    break
        per_point.append({"radial_max_m": max(radial) if radial else float("nan"),
                          "radial_rms_m": _rms(radial), "dist_max_m": max(dist) if dist else float("nan")})
    return {"radius_m": radius, "speed_mps": speed,
            "radial_max_m": round(max(pp["radial_max_m"] for pp in per_point), 3),
            "radial_rms_m": round(float(np.mean([pp["radial_rms_m"] for pp in per_point])), 3),
            "dist_max_m": round(max(pp["dist_max_m"] for pp in per_point), 3)}


def station_keeping(ctrl_type: int, model: QLPVModel, seed: int, quick: bool = False) -> dict[str, Any]:
    env = Environment(seed=seed, current_mps=1.2, current_toward_deg=0.0, **WEATHER)
    rig = Rig(ctrl_type, env, model, psi0_rad=math.pi / 2)
    keeper = StationKeeper((0.0, 0.0), station_gains(rig.params), rig.psi0_rad)
    run_s = 60.0 if quick else 120.0
    dist: list[float] = []
    for _ in range(int(run_s / 0.01)):
        out = keeper.update(rig.pos_ne(), 0.01)
        rig.step(ControlTarget(out.heading_rad, out.surge_speed_mps, is_heading=True))
        if rig.t_s >= run_s / 2:
            dist.append(out.distance_m)
    return {"max_m": round(max(dist), 3), "rms_m": round(_rms(dist), 3)}


SCENARIOS = {"course": course_keeping, "speed": speed_step, "square": square, "points": point_tracking}
