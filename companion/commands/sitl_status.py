"""``usv sitl --status-every``: one status line every so many simulated seconds.

The simulated boat's line (:class:`sim_bridge.runtime.SimStatus`: frames, speed, position), the
companion's mode, and the water current twice: what the simulator applies (truth) and what the
companion estimates (topic ``water_current``, the current-augmented filter; ``none`` with the
chapter's filter), so a user sees the estimate converge::

    usv sitl: t=60.0 s mode=LOITER ... current: sim 0.50 m/s toward 90 deg,
        estimate 0.49 m/s toward 91 deg (confidence 1.00)    [one line]
"""

from __future__ import annotations

import math

from companion.app import BaseService
from companion.bus import Bus
from companion.messages import WATER_CURRENT_TOPIC, CurrentEstimate
from companion.vehicle import Vehicle
from sim_bridge.runtime import SimulatorService

STALE_S = 1.0
"""An estimate older than this (simulated time) is shown as stale."""


def describe_estimate(est: CurrentEstimate | None, now_s: float) -> str:
    """``0.49 m/s toward 91 deg (confidence 0.98)``, ``none``, or the estimate marked stale."""
    if est is None:
        return "none"
    text = (f"{est.speed_mps:.2f} m/s toward {math.degrees(est.toward_rad) % 360.0:.0f} deg "
            f"(confidence {est.confidence:.2f})")
    return text if now_s - est.t_s <= STALE_S else f"{text}, stale {now_s - est.t_s:.0f} s"


class SitlStatus(BaseService):
    """Prints :meth:`line` every ``every_s`` of simulated time."""

    name = "sitl-status"

    def __init__(self, sim: SimulatorService, bus: Bus, vehicle: Vehicle, every_s: float) -> None:
        self.sim, self.vehicle, self.every_s = sim, vehicle, every_s
        self._current = bus.topic(WATER_CURRENT_TOPIC)

    def line(self) -> str:
        boat = self.sim.boat
        s = boat.plant.state
        cn, ce = boat.plant.env.current_ned_mps()
        true_speed = math.hypot(cn, ce)
        true_toward = math.degrees(math.atan2(ce, cn)) % 360.0
        return (f"usv sitl: t={boat.t_s:.1f} s mode={self.vehicle.modes.current.name} "
                f"armed={int(self.vehicle.armed)} speed={s.speed_mps:.2f} m/s north={s.north_m:.1f} m "
                f"east={s.east_m:.1f} m current: sim {true_speed:.2f} m/s toward {true_toward:.0f} deg, "
                f"estimate {describe_estimate(self._current.latest(), boat.t_s)}")

    async def run(self) -> None:
        while True:
            await self.sim.clock.sleep(self.every_s)
            print(self.line(), flush=True)
