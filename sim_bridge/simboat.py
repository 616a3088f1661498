"""The simulated boat's hardware: plant + GPS-INS + payloads + RC behind byte interfaces.

:class:`SimulatedBoat` is transport-agnostic and synchronous.  Per physics step:

1. :meth:`sample` returns the bytes the GPS-INS (and engine/payload/RC modules) write at
   the current time, and remembers the GPS time of the ``$GPFPD`` sample as ``pending``;
2. :meth:`receive` takes servo-controller bytes (``$PUSVS`` frames) and clears ``pending``
   when the frame answering that sample arrives (lockstep);
3. :meth:`advance` decodes the latest pulses with the boat's fixed wiring (nozzle ch 1,
   throttle 3, valve 4, ignition 5, selector 6, launcher 7, pump 8; 1100-1900 us), applies
   the RC/companion selector, and steps plant and payloads by ``step_s``.
"""

from __future__ import annotations

import math

from companion.actuators.servo import N_CHANNELS, decode_frame
from companion.sensors.nmea import LineFramer
from sim_bridge.disturbances import DisturbanceSpec
from sim_bridge.gpsins import GpsInsModel, SensorFaults, engine_sentence
from sim_bridge.hull import BoatParams
from sim_bridge.payload import (
    TRIGGER_THRESHOLD_US,
    Launcher,
    RcTransmitter,
    Sampler,
    payload_sentence,
    rc_sentence,
)
from sim_bridge.plant import BoatPlant

PHYSICS_STEP_S = 0.01
CH_NOZZLE, CH_THROTTLE, CH_VALVE, CH_IGNITION, CH_SELECTOR, CH_LAUNCHER, CH_PUMP = 0, 2, 3, 4, 5, 6, 7
SAFE_PULSES = (1500, 1500, 1100, 1000, 1100, 1100, 1100, 1100)
"""What the servos see before any frame arrives: nozzle centred, engine off."""
NO_DRIFT = (0.0, 0.0)


class SimulatedBoat:
    def __init__(self, *, seed: int = 1, disturbances: DisturbanceSpec | None = None,
                 params: BoatParams | None = None, home_lat_deg: float = 41.77, home_lon_deg: float = 123.43,
                 psi0_rad: float = 0.0, gnss_rate_hz: int = 100, start_unix_s: float = 1.7e9,
                 step_s: float = PHYSICS_STEP_S, noise_scale: float = 1.0) -> None:
        self.step_s = step_s
        self.plant = BoatPlant(params, disturbances, seed, psi0_rad=psi0_rad)
        self.gpsins = GpsInsModel(seed, home_lat_deg, home_lon_deg, gnss_rate_hz, start_unix_s, noise_scale)
        self._sample_every = max(1, round(1.0 / (gnss_rate_hz * step_s)))
        """Physics steps per GPS-INS sample (as :meth:`GpsInsModel.due`)."""
        self.launcher = Launcher()
        self.sampler = Sampler()
        self.rc = RcTransmitter()
        self.framer = LineFramer()
        self.pulses: tuple[int, ...] = SAFE_PULSES
        self.pending: str | None = None
        self.step_index = 0
        self.frames_received = 0
        self.bad_frames = 0

    @property
    def faults(self) -> SensorFaults:
        return self.gpsins.faults

    @property
    def t_s(self) -> float:
        return self.step_index * self.step_s

    @property
    def source_companion(self) -> bool:
        return self.pulses[CH_SELECTOR] > 1500 and not self.rc.override

    def sample(self) -> bytes:
        """Sensor bytes at the current time ('' when no sample is due or the device is silent)."""
        self.pending = None
        i = self.step_index
        every = self._sample_every
        if i % every or self.faults.silent:
            return b""
        s = self.plant.state
        gpsins = self.gpsins
        imu, fpd, stamp = gpsins.sentences(gpsins.measure(s, self.step_s * every))
        if self.faults.imu_silent:
            imu = b""
        corrupted = gpsins.corrupt(fpd)
        if corrupted is fpd and not self.faults.nan_velocity:  # the companion drops NaN samples: no ACK
            self.pending = stamp
        if i % 10:
            return imu + corrupted
        channels = self.rc.channels_us(self.plant.params.nozzle_max_rad)
        return b"".join((imu, engine_sentence(s.engine_rpm, s.engine_running),
                         payload_sentence(self.launcher, self.sampler),
                         rc_sentence(self.source_companion, channels), corrupted))

    def receive(self, data: bytes) -> None:
        for body in self.framer.feed(data):
            frame = decode_frame(body)
            if frame is None:
                self.bad_frames += 1
                continue
            self.frames_received += 1
            self.pulses = frame.pulse_us
            if frame.ack and frame.ack == self.pending:
                self.pending = None

    def advance(self) -> None:
        """Apply the current pulses and step the physics by one step."""
        p = self.pulses
        if self.source_companion:
            noz = (p[CH_NOZZLE] - 1500) / 400.0 * self.plant.params.nozzle_max_rad
            thr = (p[CH_THROTTLE] - 1100) / 800.0
            ign = p[CH_IGNITION] > 1500
        else:
            noz, thr, ign = self.rc.nozzle_rad, self.rc.throttle, self.rc.ignition_on
        dt = self.step_s
        t = self.t_s
        self.plant.step(dt, noz, thr, ign)
        s = self.plant.state
        drift = NO_DRIFT
        if self.launcher.buoys or p[CH_LAUNCHER] > TRIGGER_THRESHOLD_US:  # only lifebuoys drift
            env = self.plant.env
            cn, ce = env.current_ned_mps()
            wind = env.wind_speed_mps
            wto = env.spec.wind_from_rad + math.pi
            drift = (cn + 0.03 * wind * math.cos(wto), ce + 0.03 * wind * math.sin(wto))
        self.launcher.step(dt, t + dt, p[CH_LAUNCHER], s.north_m, s.east_m, s.psi_rad, drift)
        self.sampler.step(dt, p[CH_PUMP], p[CH_VALVE])
        self.step_index += 1


assert len(SAFE_PULSES) == N_CHANNELS
