"""When a ground station counts as lost: its silence on the vehicle clock and on the wall clock.

A ground station sends HEARTBEAT at 1 Hz of *wall* time (QGC, MAVProxy, MAVSDK, pymavlink
scripts), also against a simulator running faster than real time: under ``usv sitl --speedup
10`` its heartbeats arrive every 10 simulated seconds, longer than FS_GCS_TIMEOUT.  A failsafe
timed on the vehicle clock alone would fire between two heartbeats of a healthy ground station.

The rule (:meth:`GcsPresence.silent_for`): a ground station is silent for ``timeout_s`` when

1. it has sent nothing for ``timeout_s`` of vehicle time (simulated seconds in SITL), and
2. if it paces its heartbeats by the wall clock while the vehicle clock runs faster (its
   heartbeats arrive more than :data:`VEHICLE_PACED_MAX_S` vehicle-seconds apart), it has
   also missed :data:`MISSED_HEARTBEATS` of its own heartbeat periods of wall time (3 s at
   1 Hz), never asking for more than ``timeout_s`` of wall time.

On a boat both clocks are one, so the rule is exactly ``timeout_s``; a test ground station that
paces its heartbeats by simulated time is judged by simulated time alone.  The periods are the
median of the last :data:`PERIOD_SAMPLES` intervals between HEARTBEATs (after a single heartbeat:
1 Hz of wall time).  Which clock paces the station is read only from intervals in which the vehicle
clock ran at least :data:`PACE_EVIDENCE_RATIO` times faster than the wall clock: while the clocks
run together (a boat, or a simulator that stalled while it started and then caught up) any
station looks paced by the vehicle clock, and taking that for evidence fired the failsafe on a
healthy 1 Hz station in the first seconds of ``usv sitl --speedup 20`` under load.  Without
evidence the wall-clock condition applies, which changes nothing while the clocks run together.
Anything else the ground station sends (a command, a mission upload, MANUAL_CONTROL) shows it is there
too: it ends the silence but does not change the periods.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass

from companion.clock import Clock

MISSED_HEARTBEATS = 3
"""Wall-clock heartbeat periods a faster-than-real-time vehicle waits for (MAVSDK and QGC call a
link lost after about 3 s without heartbeats)."""
NOMINAL_PERIOD_S = 1.0
"""MAVLink's heartbeat period (wall clock), assumed until two heartbeats have been heard."""
VEHICLE_PACED_MAX_S = 1.5
"""Heartbeats at most this many vehicle-seconds apart: the station keeps pace with the vehicle
clock, and vehicle time alone judges it."""
PERIOD_SAMPLES = 5
PACE_EVIDENCE_RATIO = 2.0
"""An interval tells which clock paces the station only if the vehicle clock ran this many times
faster than the wall clock during it."""


@dataclass(frozen=True, slots=True)
class Silence:
    """How long one ground station has been silent, and its usual heartbeat period, on both clocks."""

    vehicle_s: float
    wall_s: float
    period_vehicle_s: float
    period_wall_s: float

    def exceeds(self, timeout_s: float) -> bool:
        """The ground station counts as lost after ``timeout_s`` (the module's rule)."""
        if self.vehicle_s <= timeout_s:
            return False
        if self.period_vehicle_s <= VEHICLE_PACED_MAX_S:
            return True
        return self.wall_s > min(timeout_s, MISSED_HEARTBEATS * self.period_wall_s)


class GcsPresence:
    """Heartbeats of the ground station on one link, stamped on the vehicle and the wall clock."""

    def __init__(self, clock: Clock, wall: Clock) -> None:
        self.clock, self.wall = clock, wall
        self.heard_s: float | None = None
        """Vehicle time of the last sign of life (``None``: never heard)."""
        self._heard_wall_s = 0.0
        self._last_heartbeat: tuple[float, float] | None = None
        self._intervals: deque[tuple[float, float]] = deque(maxlen=PERIOD_SAMPLES)

    def heard(self, *, heartbeat: bool) -> None:
        """Note a message that shows the station is alive (``heartbeat``: a GCS HEARTBEAT)."""
        now = (self.clock.now_s(), self.wall.now_s())
        self.heard_s, self._heard_wall_s = now
        if heartbeat:
            if self._last_heartbeat is not None:
                self._intervals.append((now[0] - self._last_heartbeat[0], now[1] - self._last_heartbeat[1]))
            self._last_heartbeat = now

    def silence(self) -> Silence | None:
        """The current silence (``None``: never heard)."""
        if self.heard_s is None:
            return None
        period_vehicle_s, period_wall_s = math.inf, NOMINAL_PERIOD_S  # pace unknown: the wall rule
        if self._intervals:
            period_wall_s = statistics.median(i[1] for i in self._intervals)
            evidence = [v for v, w in self._intervals if v >= PACE_EVIDENCE_RATIO * w]
            if evidence:
                period_vehicle_s = statistics.median(evidence)
        return Silence(self.clock.now_s() - self.heard_s, self.wall.now_s() - self._heard_wall_s,
                       period_vehicle_s, period_wall_s)
