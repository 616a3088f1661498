"""Simulated payloads (chapter section 4) and RC transmitter, with the sentences they emit.

* :class:`Launcher`: 30 MPa pneumatic rope/lifebuoy launcher.  A trigger-channel pulse above
  ``TRIGGER_THRESHOLD_US`` held for ``TRIGGER_HOLD_S`` fires once per pulse if the cylinder
  holds at least ``MIN_FIRE_MPA`` and a lifebuoy is loaded: a :class:`LaunchEvent` (time,
  position, bearing = heading, range up to 150 m scaled by pressure), the cylinder pressure
  drops, and a :class:`Lifebuoy` lands in the water at that bearing and range, inflates
  after 5 s and drifts with the current and 3 % of the wind.
* :class:`Sampler`: pump relay plus a bottle valve (1000 us closed, 1200/1400/1600/1800 us
  = bottle 1..4); while the pump runs with a valve open, that bottle fills at
  ``FLOW_ML_PER_S`` up to its capacity.
* :class:`RcTransmitter`: the operator's sticks and the selector (override) switch.

``$PUSVP,PRESSURE_MPA,SHOTS_FIRED,ML1,ML2,ML3,ML4,PUMP,VALVE*HH`` reports the payloads and
``$PUSVRC,SOURCE,CH1..CH8*HH`` the RC receiver (SOURCE 1 = companion drives the servos).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from companion.sensors.nmea import frame

TRIGGER_THRESHOLD_US = 1700
TRIGGER_HOLD_S = 0.2
MIN_FIRE_MPA = 10.0
FULL_MPA = 30.0
SHOT_DROP_MPA = 22.0
MAX_RANGE_M = 150.0
FLOW_ML_PER_S = 25.0
BOTTLE_ML = 500.0
INFLATE_S = 5.0


@dataclass(frozen=True, slots=True)
class LaunchEvent:
    t_s: float
    north_m: float
    east_m: float
    bearing_rad: float
    range_m: float
    pressure_before_mpa: float


@dataclass(slots=True)
class Lifebuoy:
    north_m: float
    east_m: float
    t_launch_s: float
    inflated: bool = False


class Launcher:
    def __init__(self, pressure_mpa: float = FULL_MPA, buoys: int = 1) -> None:
        self.pressure_mpa = pressure_mpa
        self.buoys_loaded = buoys
        self.events: list[LaunchEvent] = []
        self.buoys: list[Lifebuoy] = []
        self.misfires = 0
        self._high_s = 0.0
        self._fired_this_pulse = False

    def step(self, dt_s: float, t_s: float, trigger_us: int, north_m: float, east_m: float, psi_rad: float,
             drift_ned_mps: tuple[float, float]) -> None:
        if trigger_us > TRIGGER_THRESHOLD_US:
            self._high_s += dt_s
            if self._high_s >= TRIGGER_HOLD_S and not self._fired_this_pulse:
                self._fired_this_pulse = True
                self._fire(t_s, north_m, east_m, psi_rad)
        else:
            self._high_s = 0.0
            self._fired_this_pulse = False
        for b in self.buoys:
            if t_s - b.t_launch_s >= INFLATE_S:
                b.inflated = True
            b.north_m += drift_ned_mps[0] * dt_s
            b.east_m += drift_ned_mps[1] * dt_s

    def _fire(self, t_s: float, north_m: float, east_m: float, psi_rad: float) -> None:
        if self.pressure_mpa < MIN_FIRE_MPA or self.buoys_loaded <= 0:
            self.misfires += 1
            return
        p = self.pressure_mpa
        rng = MAX_RANGE_M * min(1.0, (p - 5.0) / (FULL_MPA - 5.0))
        ev = LaunchEvent(t_s, north_m, east_m, psi_rad, rng, p)
        self.events.append(ev)
        self.pressure_mpa = max(0.0, p - SHOT_DROP_MPA)
        self.buoys_loaded -= 1
        self.buoys.append(Lifebuoy(north_m + rng * math.cos(psi_rad), east_m + rng * math.sin(psi_rad), t_s))


@dataclass
class Sampler:
    bottles_ml: list[float] = field(default_factory=lambda: [0.0] * 4)
    capacity_ml: float = BOTTLE_ML
    pump_on: bool = False
    valve: int = 0

    def step(self, dt_s: float, pump_us: int, valve_us: int) -> None:
        self.pump_on = pump_us > 1500
        self.valve = max(0, min(4, round((valve_us - 1000) / 200.0)))
        if self.pump_on and self.valve:
            i = self.valve - 1
            self.bottles_ml[i] = min(self.capacity_ml, self.bottles_ml[i] + FLOW_ML_PER_S * dt_s)


@dataclass
class RcTransmitter:
    """Operator's transmitter. ``override`` True puts the boat under RC (selector switch)."""

    override: bool = False
    nozzle_rad: float = 0.0
    throttle: float = 0.0
    ignition_on: bool = False
    connected: bool = True

    def channels_us(self, nozzle_max_rad: float) -> tuple[int, ...]:
        noz = round(1500 + 400 * max(-1.0, min(1.0, self.nozzle_rad / nozzle_max_rad)))
        thr = round(1100 + 800 * max(0.0, min(1.0, self.throttle)))
        return (noz, 1500, thr, 1500, 1900 if self.ignition_on else 1100, 1900 if self.override else 1100,
                1100, 1100)


def payload_sentence(launcher: Launcher, sampler: Sampler) -> bytes:
    b = sampler.bottles_ml
    return frame(b"PUSVP,%.2f,%d,%.1f,%.1f,%.1f,%.1f,%d,%d" % (
        launcher.pressure_mpa, len(launcher.events), b[0], b[1], b[2], b[3], 1 if sampler.pump_on else 0,
        sampler.valve))


def rc_sentence(source_companion: bool, channels_us: tuple[int, ...]) -> bytes:
    return frame(b"PUSVRC,%d,%d,%d,%d,%d,%d,%d,%d,%d" % (1 if source_companion else 0, *channels_us))
