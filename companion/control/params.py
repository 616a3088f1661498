"""Control parameters (course, speed, actuator limits, controller family) and builders.

Units follow ArduPilot's habit for operator-facing values (degrees, percent); the builders
convert to SI for the controllers.
"""

from __future__ import annotations

import math
from typing import Protocol

from companion.control.active_model import ActiveModelConfig
from companion.control.actuator import ActuatorLimits
from companion.control.am_speed import AmSpeedConfig
from companion.control.pid_family import HeadingLoopConfig, PidConfig
from companion.params import ParamDef

CTRL_PID = 0
CTRL_ACTIVE_MODEL = 1
STN_CTRL_PID = 0
STN_CTRL_SELECTED = 1

PARAMS: tuple[ParamDef, ...] = (
    ParamDef("USV_CTRL_TYPE", CTRL_ACTIVE_MODEL, 0, 1, "",
             "Controller family: 0 = PID course/speed (baseline), 1 = active-model (qLPV inversion + "
             "UKF model-error compensation, chapter Fig. 6). May be changed while moving.",
             is_int=True, choices=((CTRL_PID, "PID"), (CTRL_ACTIVE_MODEL, "ActiveModel"))),
    ParamDef("USV_STN_CTRL", STN_CTRL_PID, 0, 1, "",
             "Controller family for station keeping (LOITER, GUIDED and RTL holding their point): 0 = PID "
             "whatever USV_CTRL_TYPE says, 1 = the USV_CTRL_TYPE family.  The active-model inversion "
             "evaluates the qLPV model on over-ground velocities, which a strong current makes wrong near "
             "standstill (usv bench control: station_keeping).",
             is_int=True, choices=((STN_CTRL_PID, "PID"), (STN_CTRL_SELECTED, "USV_CTRL_TYPE"))),
    ParamDef("USV_HDG_P", 2.0, 0.1, 5.0, "1/s",
             "Heading loop: desired turn rate per radian of heading error."),
    ParamDef("USV_TURN_MAX", 45.0, 5.0, 120.0, "deg/s", "Largest turn rate the heading loop asks for."),
    ParamDef("USV_UTURN_RATE", 60.0, 5.0, 180.0, "deg/s",
             "Largest turn rate the heading loop asks for in a U-turn onto a leg (USV_WP_UTURN), in place of "
             "USV_TURN_MAX; the active model then gives the yaw row all the thrust it asks for, so the jet "
             "turns on its smallest circle instead of drifting wide at the slow turn's low thrust."),
    ParamDef("USV_CRAB_TC", 0.3, 0.0, 10.0, "s",
             "Time constant of the crab-angle (course minus heading) filter used to steer a course."),
    ParamDef("USV_RATE_FF", 0.8, 0.0, 5.0, "rad/(rad/s)", "PID: nozzle angle per turn rate (feed-forward)."),
    ParamDef("USV_RATE_P", 1.0, 0.0, 10.0, "rad/(rad/s)", "PID: turn-rate proportional gain."),
    ParamDef("USV_RATE_I", 2.0, 0.0, 10.0, "rad/rad", "PID: turn-rate integral gain."),
    ParamDef("USV_RATE_D", 0.0, 0.0, 1.0, "rad/(rad/s^2)", "PID: turn-rate derivative gain."),
    ParamDef("USV_RATE_IMAX", 20.0, 0.0, 60.0, "deg", "PID: bound on the turn-rate integral."),
    ParamDef("USV_STR_SREF", 5.0, 0.5, 15.0, "m/s",
             "Speed at which the steering and heading gains apply as set (scaled by sqrt(U/ref) below)."),
    ParamDef("USV_SPD_P", 0.3, 0.0, 2.0, "1/(m/s)", "PID: speed proportional gain (throttle per m/s)."),
    ParamDef("USV_SPD_I", 0.1, 0.0, 2.0, "1/m", "PID: speed integral gain."),
    ParamDef("USV_SPD_IMAX", 40.0, 0.0, 100.0, "%", "PID: bound on the speed integral."),
    ParamDef("USV_CRUISE_THR", 50.0, 5.0, 100.0, "%",
             "PID: throttle that holds USV_CRUISE_SPD in calm water (feed-forward)."),
    ParamDef("USV_CRUISE_SPD", 5.0, 0.5, 10.0, "m/s", "PID: speed reached with USV_CRUISE_THR."),
    ParamDef("USV_AM_RATE_K", 6.0, 0.5, 20.0, "1/s", "Active model: turn-rate error bandwidth k_r."),
    ParamDef("USV_AM_SPD_K", 0.5, 0.1, 5.0, "1/s", "Active model: speed error bandwidth k_u."),
    ParamDef("USV_AM_BRAKE_K", 1.0, 0.1, 5.0, "1/s",
             "Active model: speed error bandwidth for the part of a speed excess above 0.3 m/s (braking "
             "for a corner, a waypoint or a station point)."),
    ParamDef("USV_AM_ACC_MAX", 1.5, 0.1, 5.0, "m/s^2", "Active model: largest commanded acceleration."),
    ParamDef("USV_AM_DEC_MAX", 1.0, 0.1, 5.0, "m/s^2", "Active model: largest commanded deceleration."),
    ParamDef("USV_AM_DNU", 1, 0, 1, "",
             "Active model: compensate the UKF model-error estimate delta_nu (1) or run the nominal law "
             "alone (0).", is_int=True, choices=((0, "Off"), (1, "On"))),
    ParamDef("USV_AM_DNU_TC", 1.0, 0.0, 10.0, "s",
             "Active model: low-pass time constant on delta_nu (wave filtering: do not chase wave forces)."),
    ParamDef("USV_AM_CPL_TC", 0.5, 0.0, 10.0, "s",
             "Active model on a leg: low-pass time constant that leaves the slow part of the current's "
             "yaw coupling to delta_nu and takes the fast part out of the model (stops snaking across a "
             "strong current); 0 = off."),
    ParamDef("USV_MAN_TIMEOUT", 1.0, 0.2, 10.0, "s",
             "MANUAL/CRUISE: pilot input (MAVLink MANUAL_CONTROL, else the RC receiver) older than this is "
             "ignored; in MANUAL the outputs then go safe (throttle idle, nozzle centred)."),
    ParamDef("USV_NOZ_MAX", 60.0, 5.0, 60.0, "deg", "Largest nozzle deflection either side."),
    ParamDef("USV_NOZ_RATE", 120.0, 10.0, 720.0, "deg/s", "Nozzle servo slew rate."),
    ParamDef("USV_THR_RATE", 100.0, 5.0, 1000.0, "%/s", "Throttle slew rate."),
)


class ParamReader(Protocol):
    def get(self, name: str) -> float: ...


def heading_config(p: ParamReader) -> HeadingLoopConfig:
    return HeadingLoopConfig(heading_p_per_s=p.get("USV_HDG_P"),
                             turn_rate_max_radps=math.radians(p.get("USV_TURN_MAX")),
                             u_turn_rate_max_radps=math.radians(p.get("USV_UTURN_RATE")),
                             crab_tau_s=p.get("USV_CRAB_TC"), speed_ref_mps=p.get("USV_STR_SREF"))


def actuator_limits(p: ParamReader) -> ActuatorLimits:
    return ActuatorLimits(nozzle_max_rad=math.radians(p.get("USV_NOZ_MAX")),
                          nozzle_rate_radps=math.radians(p.get("USV_NOZ_RATE")),
                          throttle_rate_per_s=p.get("USV_THR_RATE") / 100.0)


def pid_config(p: ParamReader) -> PidConfig:
    return PidConfig(heading=heading_config(p), rate_ff=p.get("USV_RATE_FF"), rate_p=p.get("USV_RATE_P"),
                     rate_i=p.get("USV_RATE_I"), rate_d=p.get("USV_RATE_D"),
                     rate_imax_rad=math.radians(p.get("USV_RATE_IMAX")), speed_ref_mps=p.get("USV_STR_SREF"),
                     speed_p=p.get("USV_SPD_P"), speed_i=p.get("USV_SPD_I"),
                     speed_imax=p.get("USV_SPD_IMAX") / 100.0,
                     cruise_throttle=p.get("USV_CRUISE_THR") / 100.0,
                     cruise_speed_mps=p.get("USV_CRUISE_SPD"),
                     nozzle_max_rad=math.radians(p.get("USV_NOZ_MAX")))


def active_model_config(p: ParamReader) -> ActiveModelConfig:
    return ActiveModelConfig(heading=heading_config(p), rate_k_per_s=p.get("USV_AM_RATE_K"),
                             speed=AmSpeedConfig(k_per_s=p.get("USV_AM_SPD_K"),
                                                 brake_k_per_s=p.get("USV_AM_BRAKE_K"),
                                                 accel_max_mps2=p.get("USV_AM_ACC_MAX"),
                                                 decel_max_mps2=p.get("USV_AM_DEC_MAX")),
                             compensate_model_error=bool(p.get("USV_AM_DNU")),
                             model_error_tau_s=p.get("USV_AM_DNU_TC"), coupling_tau_s=p.get("USV_AM_CPL_TC"),
                             nozzle_max_rad=math.radians(p.get("USV_NOZ_MAX")))
