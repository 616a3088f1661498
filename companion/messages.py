"""Frozen message dataclasses exchanged over the bus.

Every message carries ``t_s`` (seconds of the :mod:`companion.clock` time base) and uses SI
units with the unit in the field name.  Angles are radians, heading/course are measured
clockwise from true north in [0, 2*pi), body velocities follow Fossen's notation
nu = [u, v, r] (surge m/s, sway m/s positive to starboard, yaw rate rad/s positive
clockwise seen from above).  Every bus topic is a :class:`~companion.bus.TopicKey` constant
at the end of this module (its name paired with its message type, all of them in
:data:`TOPICS`), so publishers and subscribers agree on them in one place.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any

from companion.bus import TopicKey

BOTTLE_COUNT = 4
"""Chapter section 4.2: four sampling bottles and one pump."""


class FixType(enum.IntEnum):
    """GNSS fix quality, numbered as MAVLink's GPS_FIX_TYPE."""

    NO_GPS = 0
    NO_FIX = 1
    FIX_2D = 2
    FIX_3D = 3
    DGPS = 4
    RTK_FLOAT = 5
    RTK_FIXED = 6


class Severity(enum.IntEnum):
    """MAV_SEVERITY of a STATUSTEXT (RFC 5424 levels, 0 the most severe)."""

    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7


class ModeNumber(enum.IntEnum):
    """The vehicle's modes as ArduPilot Rover's custom-mode numbers (heartbeat ``custom_mode``);
    a mode Rover lacks takes a number Rover does not use (>= 20)."""

    MANUAL = 0
    HOLD = 4
    LOITER = 5
    AUTO = 10
    RTL = 11
    GUIDED = 15
    CRUISE = 20


class ControlSource(enum.IntEnum):
    """Who drives the servos, as set by the boat's RC/GCS selector switch servo."""

    RC = 0
    COMPANION = 1


@dataclass(frozen=True, slots=True)
class NavState:
    """Navigation solution of the GPS-INS (chapter Table 2), one sample."""

    t_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    heading_rad: float
    roll_rad: float
    pitch_rad: float
    vel_north_mps: float
    vel_east_mps: float
    u_mps: float
    v_mps: float
    r_radps: float
    fix_type: FixType = FixType.FIX_3D
    satellites: int = 12
    position_valid: bool = True
    attitude_valid: bool = True

    @property
    def speed_over_ground_mps(self) -> float:
        return float((self.vel_north_mps**2 + self.vel_east_mps**2) ** 0.5)

    @property
    def course_over_ground_rad(self) -> float:
        """Course over ground, clockwise from north (rad, -pi..pi), from the velocity."""
        return math.atan2(self.vel_east_mps, self.vel_north_mps)


@dataclass(frozen=True, slots=True)
class EngineState:
    """Engine module output: shaft speed and whether the engine runs."""

    t_s: float
    rpm: float
    running: bool


@dataclass(frozen=True, slots=True)
class PayloadSensors:
    """The payload box's sensors (``$PUSVP``): cylinder pressure and the water in each bottle."""

    t_s: float
    cylinder_pressure_mpa: float
    bottle_volume_ml: tuple[float, ...] = (0.0,) * BOTTLE_COUNT


@dataclass(frozen=True, slots=True)
class ActuatorCommand:
    """What the controller (or a manual/RC source) wants the actuators to do, in SI units."""

    t_s: float
    nozzle_rad: float = 0.0
    throttle: float = 0.0
    ignition_on: bool = False
    source: ControlSource = ControlSource.COMPANION


@dataclass(frozen=True, slots=True)
class ServoOutputs:
    """Pulse widths in microseconds per output channel (1-based channel i at index i-1)."""

    t_s: float
    pulse_us: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class RcInput:
    """RC receiver channels in microseconds and the selector switch position."""

    t_s: float
    channels_us: tuple[int, ...]
    source: ControlSource = ControlSource.COMPANION


@dataclass(frozen=True, slots=True)
class Setpoint:
    """Guidance output: desired course and speed over ground."""

    t_s: float
    course_rad: float
    speed_mps: float


@dataclass(frozen=True, slots=True)
class ModelError:
    """UKF estimate of the model error delta_nu (chapter Eq. 5) and its covariance diagonal."""

    t_s: float
    delta_nu: tuple[float, float, float]
    delta_nu_var: tuple[float, float, float] = (0.0, 0.0, 0.0)
    innovation_nis: float = 0.0
    water_ne_mps: tuple[float, float] | None = None
    """The current (north, east m/s) this delta_nu was estimated against when it is the error of
    the model on the velocity through the water (a current-augmented filter), else ``None``
    (delta_nu over the ground, the chapter's filter)."""


@dataclass(frozen=True, slots=True)
class CurrentEstimate:
    """UKF estimate of the water current (issue 14), earth frame, oceanographic convention.

    ``toward_rad`` is the direction the water flows toward, clockwise from north in [0, 2*pi);
    the variances are those of the north and east components; ``confidence`` (0..1) is how
    clearly the estimate stands out of its own uncertainty (moving water rather than the
    model's error; :func:`companion.models.current_ukf.current_weight`).
    """

    t_s: float
    north_mps: float
    east_mps: float
    speed_mps: float
    toward_rad: float
    north_var_m2ps2: float
    east_var_m2ps2: float
    confidence: float

    @classmethod
    def from_components(cls, t_s: float, north_mps: float, east_mps: float, north_var_m2ps2: float,
                        east_var_m2ps2: float, confidence: float) -> CurrentEstimate:
        toward = math.atan2(east_mps, north_mps) % (2.0 * math.pi)
        return cls(t_s, north_mps, east_mps, math.hypot(north_mps, east_mps), toward, north_var_m2ps2,
                   east_var_m2ps2, confidence)


@dataclass(frozen=True, slots=True)
class StatusText:
    """A human-readable event for the operator (becomes MAVLink STATUSTEXT)."""

    t_s: float
    severity: Severity
    text: str


@dataclass(frozen=True, slots=True)
class VehicleStatus:
    """Arming state and the current mode (ArduPilot Rover custom-mode number)."""

    t_s: float
    armed: bool
    mode: int
    flags: tuple[str, ...] = field(default_factory=tuple)


@dataclass(frozen=True, slots=True)
class Home:
    """Home position (return point of RTL)."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0


@dataclass(frozen=True, slots=True)
class GuidedTarget:
    """Where GUIDED goes (DO_REPOSITION / SET_POSITION_TARGET_GLOBAL_INT)."""

    lat_deg: float
    lon_deg: float
    speed_mps: float | None = None
    radius_m: float | None = None
    t_s: float = 0.0


@dataclass(frozen=True, slots=True)
class PayloadCommand:
    """What the payloads want from their actuators right now.

    ``launcher_trigger``: trigger servo at its firing pulse (``trigger_pulse_us``) instead of
    its safe pulse; ``pump_on`` with ``valve_bottle`` (1-4, 0 = all valves closed).
    """

    t_s: float
    launcher_trigger: bool = False
    trigger_pulse_us: int = 1100
    pump_on: bool = False
    valve_bottle: int = 0


@dataclass(frozen=True, slots=True)
class ManualControlInput:
    """One MANUAL_CONTROL from a ground station, normalised (None: axis not sent)."""

    t_s: float
    steering: float | None
    """-1..1 from ``y / 1000``; positive turns to starboard."""
    throttle: float | None
    """0..1 from ``z / 1000`` (negative z is idle: no reverse on a water jet)."""


@dataclass(frozen=True, slots=True)
class FenceState:
    """The geofence as the operator sees it (SYS_STATUS geofence bits, FENCE_STATUS)."""

    t_s: float
    present: bool
    """A FENCE plan with at least one zone is stored."""
    enabled: bool
    """FENCE_ENABLE = 1."""
    breached: bool
    """In a breach episode: the boat or its predicted stop point within FENCE_MARGIN of a boundary."""
    breach_count: int
    breach_time_s: float | None
    """Clock time the last breach episode began."""
    clearance_m: float
    """Distance to the nearest boundary (negative: outside); inf without zones."""


@dataclass(frozen=True, slots=True)
class NavHealthState:
    """What the GPS-INS checks of the NavHealth stage found (SYS_STATUS health bits)."""

    t_s: float
    gps_ok: bool
    """A fresh GNSS fix with finite, changing values."""
    ins_ok: bool
    """Attitude and rates fresh, finite and not frozen."""
    fault: str
    """What is wrong (empty when both are fine)."""
    degraded_action: str = ""
    """The degraded mode in force: "dead reckoning", "hold", "engine stop" or empty."""


NAV_TOPIC = TopicKey("nav", NavState)
"""Every GPS-INS sample (published by the pipeline before its stages run)."""
ENGINE_TOPIC = TopicKey("engine", EngineState)
ACTUATOR_CMD_TOPIC = TopicKey("actuator_cmd", ActuatorCommand)
"""What the controller (or MANUAL, HOLD) asks of nozzle, throttle and ignition."""
SERVO_OUT_TOPIC = TopicKey("servo_out", ServoOutputs)
RC_IN_TOPIC = TopicKey("rc_in", RcInput)
SETPOINT_TOPIC = TopicKey("setpoint", Setpoint)
MODEL_ERROR_TOPIC = TopicKey("model_error", ModelError)
"""The UKF's delta_nu (Eq. 5-11)."""
WATER_CURRENT_TOPIC = TopicKey("water_current", CurrentEstimate)
"""The current-augmented UKF's estimate of the water current (``models.ukf = "current"``)."""
STATUS_TEXT_TOPIC = TopicKey("status_text", StatusText)
VEHICLE_STATUS_TOPIC = TopicKey("vehicle_status", VehicleStatus)
PAYLOAD_SENSORS_TOPIC = TopicKey("payload_sensors", PayloadSensors)
"""Published by the sensor driver that parses the boat's payload sentence (``$PUSVP``)."""
PAYLOAD_CMD_TOPIC = TopicKey("payload_cmd", PayloadCommand)
"""Published by the payloads (:class:`~companion.payloads.topics.PayloadOutputs`); their servo
channels read it for every frame, observers (logs, tests) see it here."""
MANUAL_CONTROL_TOPIC = TopicKey("manual_control", ManualControlInput)
"""MAVLink MANUAL_CONTROL from a ground station (:mod:`companion.mavlink.manual_control`)."""
FENCE_TOPIC = TopicKey("fence", FenceState)
"""Published by the geofence stage (:mod:`companion.fence.guard`) at its check rate."""
NAV_HEALTH_TOPIC = TopicKey("nav_health", NavHealthState)
"""Published by the NavHealth stage when the GPS-INS health changes and at 1 Hz."""

TOPICS: tuple[TopicKey[Any], ...] = (
    NAV_TOPIC, ENGINE_TOPIC, ACTUATOR_CMD_TOPIC, SERVO_OUT_TOPIC, RC_IN_TOPIC, SETPOINT_TOPIC,
    MODEL_ERROR_TOPIC, WATER_CURRENT_TOPIC, STATUS_TEXT_TOPIC, VEHICLE_STATUS_TOPIC, PAYLOAD_SENSORS_TOPIC,
    PAYLOAD_CMD_TOPIC, MANUAL_CONTROL_TOPIC, FENCE_TOPIC, NAV_HEALTH_TOPIC,
)
"""Every topic of the product."""
