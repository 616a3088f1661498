"""Per-sample GPS-INS fault detection (no actions: :mod:`.stage` decides what to do).

Faults, each from what the unit itself reports:

* **GPS lost**: no 3D fix or the position flagged invalid (status bit 0 clear; the INS then
  integrates its velocity: dead reckoning);
* **frozen solution**: position, heading and velocity repeated bit for bit for
  :data:`FROZEN_S` while the reported speed over ground is at least :data:`FROZEN_MIN_SPEED_MPS`
  (a unit that says it moves but whose position does not change; a boat lying still legitimately
  repeats itself only when the noise is off, so slow samples never count);
* **stale IMU**: no ``$GTIMU`` rates (the parser's ``attitude_valid``), or the yaw rate repeated
  bit for bit for :data:`GYRO_STUCK_S` while the heading change disagrees with it by more than
  :data:`GYRO_STUCK_TURN_RAD` (|delta psi - r * delta t|: a stuck gyro; a steady turn with a
  noiseless gyro agrees with its heading);
* **no data** (:meth:`NavFaultDetector.silent`): no usable sample for :data:`SILENT_S` (a silent
  unit, or one whose samples are all dropped as NaN or out of range by the parser).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.angles import wrap_pi
from companion.messages import FixType, NavState

FROZEN_S = 0.5
FROZEN_MIN_SPEED_MPS = 0.2
GYRO_STUCK_S = 1.0
GYRO_STUCK_TURN_RAD = math.radians(3.0)
SILENT_S = 1.0


@dataclass(frozen=True, slots=True)
class NavAssessment:
    """What one sample says about the unit: ``gps_ok`` (position usable), ``ins_ok`` (attitude,
    rates and velocity usable: the sample can drive the boat) and the fault text."""

    gps_ok: bool
    ins_ok: bool
    fault: str = ""


HEALTHY = NavAssessment(True, True)
"""The assessment of every good sample (one shared immutable value, not one built per sample)."""


class NavFaultDetector:
    """Keeps the little history the checks need (module doc)."""

    def __init__(self) -> None:
        self.last_sample_s: float | None = None
        self._same_since_s: float | None = None
        self._last_key: tuple[float, ...] | None = None
        self._gyro_since: tuple[float, float] | None = None  # (t_s, heading_rad) when r last changed
        self._last_r: float | None = None

    def assess(self, nav: NavState) -> NavAssessment:
        t_s = nav.t_s
        self.last_sample_s = t_s
        key = (nav.lat_deg, nav.lon_deg, nav.heading_rad, nav.vel_north_mps, nav.vel_east_mps)
        if key != self._last_key:
            self._last_key, self._same_since_s = key, t_s
        frozen = (self._same_since_s is not None and t_s - self._same_since_s >= FROZEN_S
                  and nav.speed_over_ground_mps >= FROZEN_MIN_SPEED_MPS)
        if nav.r_radps != self._last_r or self._gyro_since is None:
            self._last_r, self._gyro_since = nav.r_radps, (t_s, nav.heading_rad)
        since_s, heading0 = self._gyro_since
        window_s = t_s - since_s
        gyro_stuck = False
        if window_s >= GYRO_STUCK_S and math.isfinite(nav.r_radps):
            turned_rad = wrap_pi(nav.heading_rad - heading0)
            gyro_stuck = abs(turned_rad - nav.r_radps * window_s) > GYRO_STUCK_TURN_RAD
            if not gyro_stuck:  # consistent: look at the next window (a long steady turn never wraps)
                self._gyro_since = (t_s, nav.heading_rad)
        if frozen:
            return NavAssessment(False, False, "GPS-INS frozen")
        if not nav.attitude_valid:
            return NavAssessment(False, False, "IMU stale")
        if gyro_stuck:
            return NavAssessment(False, False, "gyro stuck")
        if not nav.position_valid or nav.fix_type < FixType.FIX_3D:
            return NavAssessment(False, True, "GPS lost")
        return HEALTHY

    def silent(self, now_s: float) -> bool:
        """No usable sample for :data:`SILENT_S` (or none yet is NOT silence: nothing to lose)."""
        return self.last_sample_s is not None and now_s - self.last_sample_s >= SILENT_S
