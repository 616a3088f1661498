"""Campaign throughput (``usv campaign``): simulated seconds per wall second, per worker and in total.

``sitl``: a small campaign of the sampling mission (the tests' short-leg plan, weak currents) run by
:func:`sim_bridge.campaign.runner.run_campaign` on a Dask LocalCluster with :data:`WORKERS` worker
processes, as ``usv campaign run`` does.  ``sim_s_per_wall_s_total`` divides the simulated seconds
of every run by the campaign's wall time (cluster start-up included); ``sim_s_per_wall_s_per_worker``
divides each run's simulated seconds by its own wall time (what one worker process delivers);
``run_wall_s_median`` is one run's wall time.

``maneuver``: an open-loop turn campaign in currents, one run at a time (``per_run``, a scalar plant
and the GPS-INS per run, in this process) and vectorised (``batch``: every run in one
:class:`~sim_bridge.plant.BatchPlant`); the ratio says what the batch mode buys.
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from sim_bridge.campaign import maneuver
from sim_bridge.campaign.results import read_rows
from sim_bridge.campaign.runner import run_campaign
from sim_bridge.campaign.spec import parse_campaign

WORKERS = 2
SITL_CAMPAIGN = """
[campaign]
name = "bench_sampling"
seed = 5

[mission]
script = "water_sampling"
options = { points = ["8,0", "8,8", "0,8", "-4,4"], volume = 50.0, speed = 2.0, timeout = 300 }

[distributions]
current_speed_mps = { uniform = [0.0, 0.4] }
current_toward_deg = { uniform = [0.0, 360.0] }
"""


def _sitl(runs: int, workers: int) -> dict[str, Any]:
    tmp = Path(tempfile.mkdtemp(prefix="usv-bench-campaign-"))
    try:
        spec_file = tmp / "bench.toml"
        spec_file.write_text(SITL_CAMPAIGN, encoding="utf-8")
        outcome = run_campaign(spec_file, runs, tmp / "out", workers=workers, progress=False)
        rows = read_rows(tmp / "out")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    per_run = [float(r["sim_time_s"]) / float(r["wall_s"]) for r in rows if r["sim_time_s"] and r["wall_s"]]
    return {"runs": runs, "workers": workers, "sim_s_total": outcome.sim_s, "campaign_wall_s": outcome.wall_s,
            "sim_s_per_wall_s_total": round(outcome.sim_s / outcome.wall_s, 1),
            "sim_s_per_wall_s_per_worker": round(statistics.median(per_run), 1) if per_run else None,
            "run_wall_s_median": (round(statistics.median(float(r["wall_s"]) for r in rows), 2) if rows
                                  else None),
            "runs_with_errors": sum(bool(r["error"]) for r in rows)}


def _maneuver(runs: int) -> dict[str, Any]:
    spec = parse_campaign({"campaign": {"name": "bench_turn", "seed": 1},
                           "mission": {"maneuver": "turn", "options": {"duration_s": 30.0, "warmup_s": 5.0}},
                           "distributions": {"current_speed_mps": {"uniform": [0.0, 1.2]},
                                             "current_toward_deg": {"uniform": [0.0, 360.0]}}})
    samples = [spec.sample(i) for i in range(runs)]
    single = samples[: max(1, runs // 20)]
    t0 = time.perf_counter()
    for s in single:
        maneuver.run_sample(spec, s)
    single_wall = time.perf_counter() - t0
    t0 = time.perf_counter()
    rows = maneuver.run_batch(spec, samples)
    batch_wall = time.perf_counter() - t0
    sim_per_run = rows[0]["sim_time_s"]
    per_run_rate = sim_per_run * len(single) / single_wall
    batch_rate = sim_per_run * runs / batch_wall
    return {"runs": runs, "sim_s_per_run": sim_per_run,
            "per_run_sim_s_per_wall_s": round(per_run_rate, 1),
            "batch_sim_s_per_wall_s": round(batch_rate, 1),
            "batch_speedup_over_per_run": round(batch_rate / per_run_rate, 1)}


def run(quick: bool) -> dict[str, Any]:
    sitl = _sitl(2, 1) if quick else _sitl(4 * WORKERS, WORKERS)
    return {"sitl": sitl, "maneuver": _maneuver(40 if quick else 400)}
