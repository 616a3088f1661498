"""Guidance parameters (LOS path following, point tracking, station keeping) and builders.

ArduPilot-named parameters (WP_RADIUS, WP_SPEED, LOIT_RADIUS, CRUISE_SPEED) belong to the MAVLink
parameter module and are read by name; the ones here are this project's own.
"""

from __future__ import annotations

import math
from typing import Protocol

from companion.guidance.circle import CircleGains
from companion.guidance.los import LosGains, LosType
from companion.guidance.station import StationGains
from companion.guidance.waypoints import LegConfig
from companion.params import ParamDef

PARAMS: tuple[ParamDef, ...] = (
    ParamDef("USV_LOS_TYPE", int(LosType.ILOS), 0, 1, "",
             "Path following law (Fossen 2021 sec. 12.4): 0 = integral LOS, 1 = adaptive LOS. Both crab "
             "into a cross-current instead of drifting off the line.", is_int=True,
             choices=((0, "ILOS"), (1, "ALOS"))),
    ParamDef("USV_LOS_DELTA", 9.0, 1.0, 100.0, "m", "LOS look-ahead distance Delta on the line."),
    ParamDef("USV_LOS_DMIN", 4.0, 1.0, 100.0, "m",
             "LOS look-ahead far off the line (time-varying look-ahead, Lekkas and Fossen 2012): after a "
             "corner the boat converges onto the new leg within a few metres. >= USV_LOS_DELTA: constant."),
    ParamDef("USV_LOS_DGAM", 1.0, 0.0, 100.0, "1/m^2",
             "How fast the look-ahead shrinks from USV_LOS_DELTA to USV_LOS_DMIN with the cross-track error "
             "(exp(-gamma y_e^2))."),
    ParamDef("USV_LOS_KI", 0.04, 0.0, 1.0, "1/m",
             "ILOS integral gain Ki. With models.ukf = 'current' (the law on water-relative velocities) 0 "
             "flies the legs closer: the course loop removes the measured crab, and an integral wound up on "
             "each corner's overshoot held the boat 0.2-0.4 m off the next leg (docs/tuning.md)."),
    ParamDef("USV_ALOS_GAMMA", 0.002, 0.0, 0.1, "rad/(m s)", "ALOS crab-angle adaptation gain gamma."),
    ParamDef("USV_LOS_CFF", 0, 0, 1, "",
             "Crab feed-forward: 1 = steer legs and circles at the heading that makes good the desired "
             "course "
             "through the current estimated from over-ground velocity and heading (companion/guidance/"
             "current.py); 0 = the controllers remove the measured crab angle.", is_int=True,
             choices=((0, "measured crab"), (1, "current feed-forward"))),
    ParamDef("USV_WP_TURN_SPD", 2.0, 0.5, 10.0, "m/s",
             "Speed through corners sharper than 30 degrees (the boat slows down before them)."),
    ParamDef("USV_WP_DRIFT", 1, 0, 1, "",
             "Corner planning on the water-relative path: 1 = where a corner's turn starts is planned in "
             "the water (the bow turns from the old leg's crab heading to the new leg's while the current "
             "carries the boat), with guidance's observed current once it has converged; 0 = calm-water "
             "anticipation only.", is_int=True, choices=((0, "calm water"), (1, "current-aware"))),
    ParamDef("USV_WP_UTURN", 1, 0, 1, "",
             "U-turn onto a leg (heading more than 135 deg off it, e.g. AUTO started with the bow into the "
             "current): 1 = turn toward the inside of the route (the next corner's side), 0 = whichever way "
             "the heading error's sign says.", is_int=True, choices=((0, "shorter way"), (1, "inside"))),
    ParamDef("USV_WP_UTURN_SPD", 1.0, 0.3, 5.0, "m/s",
             "Speed through the water of a U-turn onto a leg (USV_WP_UTURN), until the bow is within 45 deg "
             "of the leg: a jet turns on its smallest circle slowly (about 1.3 m radius at 1 m/s). With the "
             "bow into a current the boat is commanded this minus the current over ground (not below 0)."),
    ParamDef("USV_WP_UTURN_OFS", 2.0, 0.0, 5.0, "m",
             "A U-turn onto a leg (USV_WP_UTURN 1) started while keeping station bow into a current stronger "
             "than USV_HOLD_CREEP: the boat first moves this far sideways, away from the turn, so the turn "
             "(about two turning radii wide) spans the leg's line instead of running out to one side of it "
             "(companion/guidance/sidestep.py). 0: turn where the boat is."),
    ParamDef("USV_WP_JOIN", 70.0, 0.0, 90.0, "deg",
             "AUTO entered while the boat orbits a hold point (RTL, LOITER or GUIDED in a current weaker "
             "than USV_HOLD_CREEP): keep orbiting until the course over ground and the course through the "
             "water are both within this of the first leg (turning toward it, not past it), at most one "
             "orbit or 20 s, then start the leg from there, as an aircraft leaves a holding pattern. 0: "
             "start the leg at once. From rest, a straight run or off the orbit (more than 2 m from its "
             "circle) AUTO always starts at once."),
    ParamDef("USV_WP_YAW_LAG", 2.5, 0.0, 10.0, "s",
             "Time the boat needs to build up its turn rate; turns at corners start this much earlier."),
    ParamDef("USV_CIRC_K", 1.0, 0.1, 20.0, "", "Point tracking: convergence gain onto the circle."),
    ParamDef("USV_CIRC_KI", 0.0, 0.0, 1.0, "1/s", "Point tracking: integral gain on the radial error."),
    ParamDef("USV_CIRC_HOLD_C", 0.4, 0.0, 5.0, "m/s",
             "Circle items (sampling, LOITER_TURNS) in a current at least this strong (observed) keep "
             "station on the circle, bow into the current, instead of circling (companion/guidance/stem.py). "
             "Below USV_HOLD_CREEP the hold point is 30 deg downstream of the line across the current and "
             "the boat creeps upstream along a chord; a hold the boat creeps or runs off is given up for "
             "circling (README). 0.7 (the idle creep): circle in every current the jet cannot stem. "
             "0: always circle."),
    ParamDef("USV_CIRC_SPD", 1.6, 0.5, 10.0, "m/s", "Point tracking: speed while circling a point."),
    ParamDef("USV_TURN_RAD", 2.0, 0.5, 50.0, "m",
             "Smallest circle the boat holds under control (default and minimum radius of point tracking). "
             "At full nozzle the simulated boat turns on about 1.3 m; 2 m leaves steering margin."),
    ParamDef("USV_STN_P", 0.25, 0.01, 2.0, "1/s", "Station keeping: ground speed per metre of error."),
    ParamDef("USV_STN_I", 0.04, 0.0, 0.5, "1/s^2", "Station keeping: current-estimate integral gain."),
    ParamDef("USV_STN_VMAX", 2.0, 0.2, 10.0, "m/s", "Station keeping: largest approach speed."),
)


class ParamReader(Protocol):
    def get(self, name: str) -> float: ...


def los_gains(p: ParamReader) -> LosGains:
    return LosGains(lookahead_m=p.get("USV_LOS_DELTA"), lookahead_min_m=p.get("USV_LOS_DMIN"),
                    lookahead_gamma_per_m2=p.get("USV_LOS_DGAM"), ki=p.get("USV_LOS_KI"),
                    gamma=p.get("USV_ALOS_GAMMA"), beta_max_rad=math.radians(30.0))


def leg_config(p: ParamReader, speed_mps: float, accept_radius_m: float,
               corner_cut_max_m: float | None = None) -> LegConfig:
    return LegConfig(speed_mps=speed_mps, accept_radius_m=accept_radius_m, corner_cut_max_m=corner_cut_max_m,
                     turn_speed_mps=p.get("USV_WP_TURN_SPD"), yaw_lag_s=p.get("USV_WP_YAW_LAG"),
                     turn_rate_max_radps=math.radians(p.get("USV_TURN_MAX")))


def circle_gains(p: ParamReader) -> CircleGains:
    return CircleGains(k_orbit=p.get("USV_CIRC_K"), ki_per_s=p.get("USV_CIRC_KI"))


def station_gains(p: ParamReader) -> StationGains:
    return StationGains(kp_per_s=p.get("USV_STN_P"), ki_per_s2=p.get("USV_STN_I"),
                        v_max_mps=p.get("USV_STN_VMAX"))
