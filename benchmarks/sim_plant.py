"""Physics steps per second: one boat (scalar RK4) and a batch of N boats as numpy arrays."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from sim_bridge.disturbances import spec_from_strings
from sim_bridge.plant import BatchPlant, BoatPlant


def _single(steps: int, **dist: str) -> float:
    plant = BoatPlant(disturbances=spec_from_strings(**dist))
    t0 = time.perf_counter()
    for i in range(steps):
        plant.step(0.01, 0.5 if (i // 300) % 2 else -0.5, 0.7, True)
    return steps / (time.perf_counter() - t0)


def run(quick: bool) -> dict[str, Any]:
    steps = 2000 if quick else 30000
    out: dict[str, Any] = {
        "step_s": 0.01,
        "integrator": "RK4",
        "one_boat_calm_steps_per_s": round(_single(steps)),
        "one_boat_wind_waves_current_steps_per_s": round(_single(steps, wind="6,90", current="0.5,0",
                                                                  waves="0.3,3")),
    }
    for n in (100, 1000) if not quick else (100,):
        batch = BatchPlant(n)
        noz = np.linspace(-1.0, 1.0, n)
        b_steps = max(200, steps // 10)
        t0 = time.perf_counter()
        for _ in range(b_steps):
            batch.step(0.01, noz, 0.7, True)
        rate = b_steps / (time.perf_counter() - t0)
        out[f"batch_{n}_steps_per_s"] = round(rate)
        out[f"batch_{n}_boat_steps_per_s"] = round(rate * n)
    out["one_boat_realtime_factor"] = round(out["one_boat_calm_steps_per_s"] * 0.01, 1)
    return out
