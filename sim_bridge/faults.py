"""``usv sitl --fault KIND@START[-END]``: the simulator's sensor faults on a schedule.

``KIND`` is a boolean field of :class:`~sim_bridge.gpsins.SensorFaults` (:data:`KINDS`), START and
END seconds of simulated time (without END the fault stays).  The schedule runs on the simulator's
side only: the companion learns of the fault from the bytes, as on the boat.  Example:
``usv sitl --fault gps_outage@60-120 --fault imu_silent@200-205``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from companion.app import BaseService
from companion.clock import SimClock
from companion.config import ConfigError
from sim_bridge.gpsins import SensorFaults

KINDS = ("gps_outage", "silent", "gyro_stuck", "frozen", "nan_velocity", "imu_silent")
"""The faults a schedule can switch (SensorFaults' on/off fields)."""


@dataclass(frozen=True, slots=True)
class ScheduledFault:
    kind: str
    start_s: float
    end_s: float = math.inf


def parse_fault(text: str) -> ScheduledFault:
    """``KIND@START[-END]`` -> :class:`ScheduledFault`; :class:`ConfigError` naming what is accepted."""
    accepted = f"KIND@START[-END] with KIND one of {', '.join(KINDS)} and times in simulated seconds"
    kind, _, when = text.partition("@")
    start, _, end = when.partition("-")
    try:
        start_s, end_s = float(start), float(end) if end else math.inf
    except ValueError:
        raise ConfigError(f"--fault: invalid value {text!r}; accepted: {accepted}") from None
    if kind not in KINDS or not (math.isfinite(start_s) and 0.0 <= start_s < end_s):
        raise ConfigError(f"--fault: invalid value {text!r}; accepted: {accepted}")
    return ScheduledFault(kind, start_s, end_s)


class FaultSchedule(BaseService):
    """Switches the faults of ``faults`` on and off at their times (simulated clock)."""

    name = "fault-schedule"

    def __init__(self, faults: SensorFaults, clock: SimClock, schedule: list[ScheduledFault]) -> None:
        self.faults, self.clock = faults, clock
        self.events = sorted([(f.start_s, f.kind, True) for f in schedule]
                             + [(f.end_s, f.kind, False) for f in schedule if math.isfinite(f.end_s)])

    async def run(self) -> None:
        for at_s, kind, on in self.events:
            await self.clock.sleep(max(0.0, at_s - self.clock.now_s()))
            setattr(self.faults, kind, on)
        await super().run()
