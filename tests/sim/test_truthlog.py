"""``usv sitl --truth-log``: the simulated boat's true state, one CSV row per 0.05 s of simulated time,
as the GPS-INS would report it without noise."""

from __future__ import annotations

import asyncio
import csv
from pathlib import Path

import pytest

from companion.clock import SimClock
from sim_bridge.simboat import SimulatedBoat
from sim_bridge.truthlog import COLUMNS, TruthLog


async def test_truth_log_rows_every_0_05_s_with_the_true_position(tmp_path: Path) -> None:
    boat = SimulatedBoat(seed=3)
    clock = SimClock()
    log = TruthLog(boat, clock, tmp_path / "truth.csv")
    await log.start()
    task = asyncio.create_task(log.run())
    await asyncio.sleep(0)  # the first row, at t = 0 (in usv sitl the log starts before the simulator)
    boat.pulses = (1500, 1500, 1900, 1000, 1900, 1900, 1100, 1900)  # ignition on, throttle full, pump on
    for _ in range(300):  # 3 s of simulated time
        boat.advance()
        clock.advance_to(boat.t_s)
        await asyncio.sleep(0)
    task.cancel()
    await log.stop()

    with (tmp_path / "truth.csv").open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == COLUMNS
    times = [float(r["t_s"]) for r in rows]
    assert times[:3] == [0.0, 0.05, 0.1]
    assert len(rows) == 61 and times[-1] == pytest.approx(3.0)
    last = rows[-1]
    s = boat.plant.state
    assert float(last["north_m"]) == pytest.approx(s.north_m, abs=1e-4)
    assert float(last["east_m"]) == pytest.approx(s.east_m, abs=1e-4)
    assert float(last["sog_mps"]) == pytest.approx(s.speed_mps, abs=1e-3) and s.speed_mps > 0.1
    lat, lon = boat.gpsins.lat_lon(float(last["north_m"]), float(last["east_m"]))
    assert float(last["lat_deg"]) == pytest.approx(lat, abs=1e-8)
    assert float(last["lon_deg"]) == pytest.approx(lon, abs=1e-8)
    assert last["pump_on"] == "1"
