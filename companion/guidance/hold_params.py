"""Parameters of holding a point in a current (LOITER, GUIDED and RTL on their point; issue 14)
and their builders (:mod:`companion.guidance.holding`)."""

from __future__ import annotations

from typing import Protocol

from companion.guidance.holding import CurrentStationGains, OrbitGains
from companion.params import ParamDef

HOLD_LEGACY, HOLD_CURRENT = 0, 1

PARAMS: tuple[ParamDef, ...] = (
    ParamDef("USV_HOLD_MODE", HOLD_CURRENT, 0, 1, "",
             "How LOITER, GUIDED and RTL hold their point: 1 = from the water-current estimate at once "
             "(bow into a current stronger than USV_HOLD_CREEP, else a drift-compensated orbit at "
             "USV_TURN_RAD; arrivals brake onto the point), 0 = as before issue 14 (the station keeper "
             "learns the current; LOITER orbits after seeing the boat creep).", is_int=True,
             choices=((HOLD_LEGACY, "learn the current"), (HOLD_CURRENT, "use the current estimate"))),
    ParamDef("USV_HOLD_CREEP", 0.7, 0.0, 3.0, "m/s",
             "Idle creep of the jet through the water (the simulated boat: 0.7 m/s, usv bench nav "
             "'idle_creep_mps'): a current stronger than this is stemmed bow-on, a weaker one orbited."),
    ParamDef("USV_HOLD_TRY", 0.25, 0.0, 3.0, "m/s",
             "LOITER and GUIDED first keep station bow into a current between this and USV_HOLD_CREEP "
             "(wind from ahead can hold the boat where the current alone cannot), and orbit once the "
             "current does not set the idling boat back. Not a boat already orbiting, nor again in a "
             "current where it failed (10 min); RTL orbits. At or above USV_HOLD_CREEP: never."),
    ParamDef("USV_HOLD_ORB_SPD", 1.0, 0.5, 5.0, "m/s",
             "Speed through the water on the holding orbit (raised with the current so the crab stays "
             "steerable)."),
    ParamDef("USV_HOLD_ORB_K", 1.5, 0.1, 10.0, "", "Holding orbit: convergence gain onto the circle."),
    ParamDef("USV_HOLD_ESTOP", 0, 0, 1, "",
             "LOITER in slack water (estimated current below USV_HOLD_SLACK): 1 = stop the engine and "
             "drift, restart and return when the drift reaches USV_HOLD_DRIFT, stop again on the point; "
             "0 = orbit the point (default).", is_int=True, choices=((0, "orbit"), (1, "engine stop"))),
    ParamDef("USV_HOLD_SLACK", 0.2, 0.0, 1.0, "m/s",
             "Current below which LOITER may stop the engine (USV_HOLD_ESTOP 1)."),
    ParamDef("USV_HOLD_DRIFT", 3.0, 1.0, 50.0, "m",
             "Engine-stop station keeping: drift this far from the point before restarting to return."),
    ParamDef("USV_HOLD_BRAKE", 12.0, 0.0, 100.0, "m",
             "GUIDED/RTL in a current stronger than USV_HOLD_CREEP: coming from downstream, the boat "
             "joins the line up the current into the point from this far below it and hands over to "
             "station keeping at 0.75 x this, so it arrives bow into the current instead of "
             "overshooting and looping back (from upstream the current sets it back onto the point)."),
)


class ParamReader(Protocol):
    def get(self, name: str) -> float: ...


def orbit_gains(p: ParamReader) -> OrbitGains:
    return OrbitGains(k_orbit=p.get("USV_HOLD_ORB_K"), water_speed_mps=p.get("USV_HOLD_ORB_SPD"))


def current_station_gains(p: ParamReader) -> CurrentStationGains:
    return CurrentStationGains(kp_per_s=p.get("USV_STN_P"), v_max_mps=p.get("USV_STN_VMAX"))
