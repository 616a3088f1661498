"""``usv sitl --truth-log FILE``: the simulated boat's true state as CSV, for benchmarks.

A ground station sees the vehicle's own estimate (GPS-INS with noise); a benchmark wants the
truth.  One row every ``period_s`` of simulated time (default 0.05 s, 20 Hz), written by the
simulator's side only, so the companion cannot tell it is being watched.  Columns:

``t_s``            simulated time (s); the companion's ``time_boot_ms`` counts the same clock
``lat_deg``, ``lon_deg``  true position, converted to geodetic degrees as the GPS-INS does
``north_m``, ``east_m``   true position relative to the simulator's home (m)
``heading_deg``    true heading, clockwise from north
``sog_mps``        true speed over ground
``pump_on``, ``valve``    the sampler: pump relay (0/1) and open bottle valve (0 closed, 1-4)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TextIO

from companion.app import BaseService
from companion.clock import SimClock
from sim_bridge.simboat import SimulatedBoat

COLUMNS = ("t_s", "lat_deg", "lon_deg", "north_m", "east_m", "heading_deg", "sog_mps", "pump_on", "valve")
FLUSH_EVERY_ROWS = 20


class TruthLog(BaseService):
    """Writes one CSV row of the boat's true state every ``period_s`` of simulated time."""

    name = "truth-log"

    def __init__(self, boat: SimulatedBoat, clock: SimClock, path: Path, period_s: float = 0.05) -> None:
        self.boat, self.clock, self.path, self.period_s = boat, clock, Path(path), period_s
        self._fh: TextIO | None = None
        self.rows = 0

    async def start(self) -> None:
        self._fh = self.path.open("w", encoding="utf-8")
        self._fh.write(",".join(COLUMNS) + "\n")

    def row(self) -> str:
        boat = self.boat
        s = boat.plant.state
        lat_deg, lon_deg = boat.gpsins.lat_lon(s.north_m, s.east_m)
        return (f"{boat.t_s:.2f},{lat_deg:.9f},{lon_deg:.9f},{s.north_m:.4f},{s.east_m:.4f},"
                f"{math.degrees(s.psi_rad) % 360.0:.2f},{s.speed_mps:.3f},{int(boat.sampler.pump_on)},"
                f"{boat.sampler.valve}\n")

    async def run(self) -> None:
        assert self._fh is not None
        while True:
            self._fh.write(self.row())
            self.rows += 1
            if self.rows % FLUSH_EVERY_ROWS == 0:
                self._fh.flush()
            # absolute deadlines (half a physics step early) so rows do not drift off the grid
            await self.clock.sleep(self.rows * self.period_s - 0.005 - self.clock.now_s())

    async def stop(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None
