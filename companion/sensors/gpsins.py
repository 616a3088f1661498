"""Parser of the GPS-INS serial stream (XW-GI5630 sentence set, see :mod:`sim_bridge.gpsins`).

Sentences understood (NMEA framing and XOR checksum, :mod:`companion.sensors.nmea`):

* ``$GTIMU,GPSWeek,GPSTime,GyroX,GyroY,GyroZ,AccX,AccY,AccZ,Tpr`` (deg/s, g; right-forward-up
  axes, so the clockwise yaw rate r = -GyroZ) -> kept for the next ``$GPFPD``;
* ``$GPFPD,GPSWeek,GPSTime,Heading,Pitch,Roll,Lat,Lon,Alt,Ve,Vn,Vu,Baseline,NSV1,NSV2,Status``
  -> one :class:`~companion.messages.NavState` (body velocities u, v from Ve/Vn and heading);
* ``$PUSVE,RPM,RUNNING`` -> :class:`~companion.messages.EngineState` on ``engine``;
* ``$PUSVP,PRESSURE_MPA,SHOTS,ML1,ML2,ML3,ML4,PUMP,VALVE`` -> ``payload_sensors``;
* ``$PUSVRC,SOURCE,CH1..CH8`` -> :class:`~companion.messages.RcInput` on ``rc_in``.

A payload may declare more sentences of the box (``extra_sentences``: name -> handler of the
fields).  Bad checksums, garbage and malformed fields (also NaN, speeds beyond
:data:`MAX_SPEED_MPS`, rates beyond :data:`MAX_GYRO_DEGPS`) are counted in
:attr:`GpsInsParser.errors` and dropped; nothing raises.  A ``$GPFPD`` without a ``$GTIMU`` in the
last :data:`IMU_STALE_S` has ``attitude_valid`` false (stale IMU).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from companion.angles import wrap_2pi
from companion.bus import Bus
from companion.clock import Clock
from companion.guidance.geo import valid_lat_lon
from companion.messages import (
    ENGINE_TOPIC,
    PAYLOAD_SENSORS_TOPIC,
    RC_IN_TOPIC,
    ControlSource,
    EngineState,
    FixType,
    NavState,
    PayloadSensors,
    RcInput,
)
from companion.sensors.nmea import LineFramer

TWO_PI = 2.0 * math.pi
MAX_SPEED_MPS = 50.0
"""Velocities beyond this (the boat's top speed is 10 m/s) are a fault of the unit, not motion."""
MAX_GYRO_DEGPS = 400.0
"""Beyond the XW-GI's +-100 deg/s range with room: a larger rate is garbage."""
IMU_STALE_S = 0.5
"""A navigation sample without a ``$GTIMU`` for this long has no valid attitude rates."""

NavCallback = Callable[[NavState, str], object]
"""Called with each navigation sample and its GPS time field (the lockstep ACK)."""


class GpsInsParser:
    """Feeds bytes, publishes engine/payload/RC messages, hands nav samples to ``on_nav``."""

    def __init__(self, clock: Clock, bus: Bus, on_nav: NavCallback,
                 extra_sentences: Mapping[str, Callable[[list[str]], None]] | None = None) -> None:
        self.clock = clock
        self.on_nav = on_nav
        self.framer = LineFramer()
        self.field_errors = 0
        self.nav_samples = 0
        self._gyro_z_degps = 0.0
        self._imu_t_s: float | None = None
        self._engine = bus.topic(ENGINE_TOPIC)
        self._rc = bus.topic(RC_IN_TOPIC)
        self._payload = bus.topic(PAYLOAD_SENSORS_TOPIC)
        self._payload_type = PayloadSensors
        self._handlers: dict[str, Callable[[list[str]], None]] = {
            "GPFPD": self._gpfpd, "GTIMU": self._gtimu, "PUSVE": self._pusve,
            "PUSVP": self._pusvp, "PUSVRC": self._pusvrc,
        }
        for name, handler in (extra_sentences or {}).items():
            self._handlers.setdefault(name, handler)

    @property
    def errors(self) -> int:
        return self.framer.stats.errors + self.field_errors

    def feed(self, data: bytes) -> None:
        for body in self.framer.feed(data):
            fields = body.split(",")
            handler = self._handlers.get(fields[0])
            if handler is None:
                continue  # other sentences (GGA, RMC ...) are not needed
            try:
                handler(fields)
            except (ValueError, IndexError):
                self.field_errors += 1

    def _gtimu(self, f: list[str]) -> None:
        if len(f) != 10:
            raise ValueError("GTIMU field count")
        gyro_z_degps = float(f[5])
        if not abs(gyro_z_degps) <= MAX_GYRO_DEGPS:  # also NaN
            raise ValueError("gyro out of range")
        self._gyro_z_degps = gyro_z_degps
        self._imu_t_s = self.clock.now_s()

    def _gpfpd(self, f: list[str]) -> None:
        if len(f) != 16:
            raise ValueError("GPFPD field count")
        heading = math.radians(float(f[3]))
        if not (0.0 <= heading <= TWO_PI + 1e-9):
            raise ValueError("heading out of range")
        ve, vn = float(f[9]), float(f[10])
        lat, lon = float(f[6]), float(f[7])
        if not valid_lat_lon(lat, lon):
            raise ValueError("position out of range")
        if not (abs(ve) <= MAX_SPEED_MPS and abs(vn) <= MAX_SPEED_MPS):  # also NaN
            raise ValueError("velocity out of range")
        pitch_deg, roll_deg, alt_m = float(f[4]), float(f[5]), float(f[8])
        if not (abs(pitch_deg) <= 90.0 and abs(roll_deg) <= 180.0 and math.isfinite(alt_m)):
            raise ValueError("attitude or altitude out of range")
        now_s = self.clock.now_s()
        imu_fresh = self._imu_t_s is not None and now_s - self._imu_t_s <= IMU_STALE_S
        status = int(f[15], 16)
        gnss_ok = bool(status & 0x01)
        c, s = math.cos(heading), math.sin(heading)
        # positional, in NavState's field order (keywords cost more on this 100 Hz path)
        nav = NavState(now_s, lat, lon, alt_m, wrap_2pi(heading),
                       math.radians(roll_deg), math.radians(pitch_deg), vn, ve,
                       c * vn + s * ve, -s * vn + c * ve, -math.radians(self._gyro_z_degps),
                       FixType.FIX_3D if gnss_ok else FixType.NO_FIX, int(f[13]), gnss_ok, imu_fresh)
        self.nav_samples += 1
        self.on_nav(nav, f[2])

    def _pusve(self, f: list[str]) -> None:
        self._engine.publish(EngineState(t_s=self.clock.now_s(), rpm=float(f[1]), running=f[2] == "1"))

    def _pusvp(self, f: list[str]) -> None:
        if len(f) != 9:
            raise ValueError("PUSVP field count")
        self._payload.publish(self._payload_type(
            t_s=self.clock.now_s(), cylinder_pressure_mpa=float(f[1]),
            bottle_volume_ml=tuple(map(float, f[3:7]))))

    def _pusvrc(self, f: list[str]) -> None:
        if len(f) != 10:
            raise ValueError("PUSVRC field count")
        source = ControlSource.COMPANION if f[1] == "1" else ControlSource.RC
        self._rc.publish(RcInput(t_s=self.clock.now_s(), channels_us=tuple(map(int, f[2:])),
                                 source=source))
