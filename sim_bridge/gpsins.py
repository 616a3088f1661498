"""Simulated XW-GI5630 GPS-INS (chapter Table 2): noisy measurements and the serial bytes.

Sentence set written on the simulated serial port (one sample = the sentences below, in
this order; the companion runs one control step per ``$GPFPD``):

``$GTIMU,GPSWeek,GPSTime,GyroX,GyroY,GyroZ,AccX,AccY,AccZ,Tpr*HH``
    XW-GI raw IMU: gyro deg/s and acceleration in g in the unit's right-forward-up
    axes (X starboard, Y forward, Z up; so yaw rate clockwise r = -GyroZ), temperature C.
``$GPFPD,GPSWeek,GPSTime,Heading,Pitch,Roll,Latitude,Longitude,Altitude,Ve,Vn,Vu,Baseline,NSV1,NSV2,Status*HH``
    XW-GI navigation solution: heading 0..360 deg clockwise from north, pitch/roll deg,
    latitude/longitude deg, altitude m, east/north/up velocity m/s, antenna baseline m,
    satellites on antennas 1 and 2, status as two hex digits.  Status bits as used here:
    0x01 GNSS position, 0x02 GNSS velocity, 0x08 dual-antenna heading (``0B`` = all good,
    ``00`` = INS only, e.g. during a GNSS outage).
``$PUSVE,RPM,RUNNING*HH`` (10 Hz)   engine module: shaft speed and running flag.
``$PUSVP,...`` and ``$PUSVRC,...`` (10 Hz)   payload and RC receiver, see :mod:`sim_bridge.payload`.

Noise (Table 2, 1 sigma): heading 0.2 deg, attitude 0.5 deg, position 2 cm + 1 ppm of
the distance from the start point (Gauss-Markov, 10 s correlation), velocity 0.1 m/s per
axis, gyro 0.05 deg/s white plus a seeded bias, gyro range +-100 deg/s.  Update rate
1, 5, 10 or 100 Hz.  Faults (:class:`SensorFaults`): GNSS outage, silent device,
corrupted bytes, heading bias, stuck gyro, frozen solution, NaN velocities, missing IMU sentences.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from companion.guidance.geo import LocalFrame
from companion.sensors.nmea import frame
from sim_bridge.noise import NormalStream
from sim_bridge.plant import PlantState

GPS_EPOCH_UNIX_S = 315964800.0
GPS_LEAP_S = 18.0
SUPPORTED_RATES_HZ = (1, 5, 10, 100)

GTIMU_FORMAT = b"GTIMU,%d,%s,%.4f,%.4f,%.4f,%.4f,%.4f,1.0000,35.0"
"""Week, time of week, gyro X/Y/Z deg/s, acceleration X/Y g (Z 1 g, temperature 35 C)."""
GPFPD_FORMAT = b"GPFPD,%d,%s,%.3f,%.3f,%.3f,%.8f,%.8f,0.00,%.3f,%.3f,0.000,2.000,%d,%d,%02X"
"""Week, time of week, heading, pitch, roll, latitude, longitude, (altitude 0), Ve, Vn,
(Vu 0, baseline 2 m), satellites on each antenna, status."""


@dataclass(slots=True)
class SensorFaults:
    """Injectable faults; tests and the harness flip these while the simulation runs."""

    gps_outage: bool = False
    silent: bool = False
    corrupt_fraction: float = 0.0
    heading_bias_deg: float = 0.0
    gyro_stuck: bool = False
    frozen: bool = False
    """The unit repeats its last solution (position, heading, velocity) with fresh time stamps."""
    nan_velocity: bool = False
    """Ve and Vn are written as ``nan`` (a unit whose filter diverged)."""
    imu_silent: bool = False
    """No ``$GTIMU`` sentences (stale IMU); the navigation solution keeps coming."""


class Measurement(NamedTuple):
    """One GPS-INS sample as the device reports it (noisy; immutable)."""

    t_s: float
    lat_deg: float
    lon_deg: float
    heading_deg: float
    pitch_deg: float
    roll_deg: float
    ve_mps: float
    vn_mps: float
    gyro_z_degps: float
    acc_x_g: float
    acc_y_g: float
    nsv: int
    status: int
    north_m: float
    east_m: float

    @property
    def psi_rad(self) -> float:
        return math.radians(self.heading_deg)

    @property
    def r_radps(self) -> float:
        return -math.radians(self.gyro_z_degps)

    @property
    def u_mps(self) -> float:
        c, s = math.cos(self.psi_rad), math.sin(self.psi_rad)
        return c * self.vn_mps + s * self.ve_mps

    @property
    def v_mps(self) -> float:
        c, s = math.cos(self.psi_rad), math.sin(self.psi_rad)
        return -s * self.vn_mps + c * self.ve_mps


class GpsInsModel:
    """Turns the true plant state into noisy measurements and XW-GI sentences."""

    def __init__(self, seed: int, home_lat_deg: float = 41.77, home_lon_deg: float = 123.43,
                 rate_hz: int = 100, start_unix_s: float = 1.7e9, noise_scale: float = 1.0) -> None:
        """``noise_scale``: every noise level of Table 2 times this (campaigns vary it; 1: the
        device's figures, bit-identical to the unscaled model)."""
        if not 0.0 <= noise_scale <= 100.0:
            raise ValueError(f"GPS-INS noise scale {noise_scale} outside [0, 100]")
        if rate_hz not in SUPPORTED_RATES_HZ:
            raise ValueError(f"GPS-INS rate {rate_hz} Hz not one of {SUPPORTED_RATES_HZ}")
        self.rng = np.random.default_rng([seed, 0x9125])
        self.home_lat_deg, self.home_lon_deg = home_lat_deg, home_lon_deg
        self._frame = LocalFrame(home_lat_deg, home_lon_deg)
        self.rate_hz = rate_hz
        self.start_unix_s = start_unix_s
        self.faults = SensorFaults()
        k = self.noise_scale = noise_scale
        self._sig_pos_m, self._sig_pos_ppm = 0.017 * k, 1e-6 * k
        self._sig_vel_mps, self._sig_hdg_deg, self._sig_att_deg = 0.1 * k, 0.2 * k, 0.5 * k
        self._sig_gyro_degps, self._sig_acc_g = 0.05 * k, 0.002 * k
        self.gyro_bias_degps = float(self.rng.normal(0.0, 0.1)) * k
        self._pos_err_n = self._pos_err_e = 0.0
        self._dr_pos: tuple[float, float] | None = None
        self._last_gyro = 0.0
        self._noise = NormalStream(self.rng)  # interleaves with corrupt()'s draws as before
        self.samples = 0
        self._last: Measurement | None = None

    def lat_lon(self, north_m: float, east_m: float) -> tuple[float, float]:
        """WGS-84 degrees of a position in metres north/east of home (no noise), on the tangent plane
        at home, so the companion's :class:`~companion.guidance.geo.LocalFrame` reads the same metres
        back (a receiver reports WGS-84; a sphere put a point 50 m off 0.1 m away, as much as a leg's
        cross-track target)."""
        return self._frame.to_lat_lon(north_m, east_m)

    def due(self, step_index: int, step_s: float) -> bool:
        """Whether a sample is output at this physics step (rate divides 1/step_s)."""
        every = max(1, round(1.0 / (self.rate_hz * step_s)))
        return step_index % every == 0

    def measure(self, s: PlantState, dt_s: float) -> Measurement:
        f = self.faults
        if f.frozen and self._last is not None:
            return self._last._replace(t_s=s.t_s)
        m = self._measure(s, dt_s)
        if f.nan_velocity:
            m = m._replace(ve_mps=math.nan, vn_mps=math.nan)
        self._last = m
        return m

    def _measure(self, s: PlantState, dt_s: float) -> Measurement:
        f = self.faults
        n = self._noise.draw
        # position: Gauss-Markov error, 2 cm CEP (~1.7 cm per axis) + 1 ppm of range
        a = math.exp(-dt_s / 10.0)
        sig = self._sig_pos_m + self._sig_pos_ppm * math.hypot(s.north_m, s.east_m)
        w = sig * math.sqrt(1.0 - a * a)
        err_n = self._pos_err_n = a * self._pos_err_n + w * n()
        err_e = self._pos_err_e = a * self._pos_err_e + w * n()
        psi, u, v = s.psi_rad, s.u_mps, s.v_mps
        c, sn = math.cos(psi), math.sin(psi)
        sig_vel = self._sig_vel_mps
        vn = u * c - v * sn + sig_vel * n()
        ve = u * sn + v * c + sig_vel * n()
        if f.gps_outage:
            # INS dead reckoning from the last fix: integrates noisy velocity, drifts
            if self._dr_pos is None:
                self._dr_pos = (s.north_m + err_n, s.east_m + err_e)
            north = self._dr_pos[0] + (vn + 0.05) * dt_s
            east = self._dr_pos[1] + (ve + 0.05) * dt_s
            self._dr_pos = (north, east)
            status, nsv = 0x00, 0
        else:
            self._dr_pos = None
            north, east = s.north_m + err_n, s.east_m + err_e
            status, nsv = 0x0B, 14
        heading = (math.degrees(psi) + self._sig_hdg_deg * n() + f.heading_bias_deg) % 360.0
        if not f.gyro_stuck:
            gz = -math.degrees(s.r_radps) + self.gyro_bias_degps + self._sig_gyro_degps * n()
            self._last_gyro = max(-100.0, min(100.0, gz))
        g = 9.81
        acc_x = (s.v_dot_mps2 + s.u_r_mps * s.r_radps) / g + self._sig_acc_g * n()
        acc_y = (s.u_dot_mps2 - s.v_r_mps * s.r_radps) / g + self._sig_acc_g * n()
        self.samples += 1
        pitch = self._sig_att_deg * n()
        lat_deg, lon_deg = self.lat_lon(north, east)
        return Measurement(s.t_s, lat_deg, lon_deg, heading, pitch,
                           self._sig_att_deg * n(), ve, vn,
                           self._last_gyro, acc_x, acc_y, nsv, status, north, east)

    def gps_time(self, t_s: float) -> tuple[int, float]:
        """GPS week and seconds of week of simulation time ``t_s``."""
        gps_s = self.start_unix_s + t_s - GPS_EPOCH_UNIX_S + GPS_LEAP_S
        week = int(gps_s // 604800.0)
        return week, gps_s - week * 604800.0

    def sentences(self, m: Measurement) -> tuple[bytes, bytes, str]:
        """(GTIMU bytes, GPFPD bytes, GPS time string of the sample)."""
        week, sow = self.gps_time(m.t_s)
        stamp = b"%.3f" % sow
        gyro_x = self._sig_gyro_degps * self._noise.draw()
        gyro_y = self._sig_gyro_degps * self._noise.draw()
        imu = frame(GTIMU_FORMAT % (week, stamp, gyro_x, gyro_y, m.gyro_z_degps, m.acc_x_g, m.acc_y_g))
        fpd = frame(GPFPD_FORMAT % (week, stamp, m.heading_deg, m.pitch_deg, m.roll_deg, m.lat_deg, m.lon_deg,
                                    m.ve_mps, m.vn_mps, m.nsv, m.nsv, m.status))
        return imu, fpd, stamp.decode("ascii")

    def corrupt(self, data: bytes) -> bytes:
        """Flip one byte with probability ``faults.corrupt_fraction`` (checksum then fails)."""
        if self.faults.corrupt_fraction <= 0.0 or self.rng.random() >= self.faults.corrupt_fraction:
            return data
        i = int(self.rng.integers(1, max(2, len(data) - 5)))
        return data[:i] + bytes([data[i] ^ 0x01]) + data[i + 1:]


def engine_sentence(rpm: float, running: bool) -> bytes:
    """``$PUSVE,RPM,RUNNING*HH``: the engine module's tachometer."""
    return frame(b"PUSVE,%.0f,%d" % (rpm, 1 if running else 0))
