"""``usv campaign run``: the runs of a campaign on Dask distributed, saved as they finish.

Local by default: a :class:`distributed.LocalCluster` of ``--workers`` single-threaded worker
processes (default: one per core).  ``--scheduler ADDRESS`` submits the same runs to an existing
cluster (``dask scheduler`` + ``dask worker`` processes on any machines that have this package
installed); results come back to this process, which alone writes the output directory, so workers
need no shared file system.  Each run is one task (:func:`execute`); its row is appended to
``results.csv`` as soon as it arrives (:mod:`sim_bridge.campaign.results`), and runs already there
are not submitted again.  Open-loop manoeuvre campaigns that fit the batch plant run vectorised in
this process instead (:func:`sim_bridge.campaign.maneuver.run_batch`), in chunks of
:data:`BATCH_CHUNK` runs, each chunk saved when done.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import sys
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from companion.config import ConfigError
from sim_bridge.campaign import maneuver
from sim_bridge.campaign.results import ResultsDir
from sim_bridge.campaign.spec import CampaignSpec, load_campaign

BATCH_CHUNK = 256


def execute(spec: CampaignSpec, index: int) -> dict[str, Any]:
    """One run (a Dask task): the sample's conditions, its figures, track, timing and worker."""
    sample = spec.sample(index)
    t0 = time.perf_counter()
    try:
        if spec.kind == "mission":
            from sim_bridge.campaign import mission_run

            out = mission_run.run_sample(spec, sample)
        else:
            out = maneuver.run_sample(spec, sample)
    except Exception as exc:  # the run's own failure (the simulation or the companion): a result
        out = {"success": False, "failures": "error", "error": f"{type(exc).__name__}: {exc}",
               "wall_s": round(time.perf_counter() - t0, 3)}
    try:
        from distributed import get_worker

        worker = get_worker().address
    except (ImportError, ValueError):
        worker = f"{socket.gethostname()}:{os.getpid()}"
    return {**sample.as_row(), **out, "worker": worker}


@dataclass
class CampaignOutcome:
    """What one ``usv campaign run`` did."""

    runs: int
    already_done: int
    ran: int
    lost: int
    successes: int
    sim_s: float
    wall_s: float
    batch: bool
    workers: int


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int | None) -> Iterator[Any]:
    """A Dask client: on the cluster at ``scheduler``, else on a new local cluster of ``workers``
    single-threaded processes (default one per core)."""
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.WARNING)  # no INFO lines between progress updates
    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except OSError as exc:
            raise ConfigError(f"--scheduler {scheduler}: no Dask scheduler answered ({exc})") from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=40) as cluster, Client(cluster) as client:
        yield client


def _progress(total: int, initial: int, enabled: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="run", disable=not enabled, file=sys.stderr,
                dynamic_ncols=True)


def run_campaign(path: Path | str, runs: int, out: Path | str, *, scheduler: str | None = None,
                 workers: int | None = None, progress: bool = True) -> CampaignOutcome:
    """Run runs 0..``runs``-1 of the campaign file at ``path`` that ``out`` does not hold yet."""
    if runs < 1:
        raise ConfigError(f"--runs {runs}: must be at least 1")
    if workers is not None and workers < 1:
        raise ConfigError(f"--workers {workers}: must be at least 1")
    spec = load_campaign(path)
    results = ResultsDir(Path(out), spec.source_text)
    done = results.finished()
    todo = [i for i in range(runs) if i not in done]
    already = runs - len(todo)
    print(f"campaign {spec.name}: {already} of {runs} runs already in {out}; {len(todo)} to run",
          file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    stats: dict[str, int] = {"ran": 0, "lost": 0, "ok": 0}
    sim_s = [0.0]

    def save(row: dict[str, Any]) -> None:
        row["finished_unix_s"] = round(time.time(), 3)
        results.append([row])
        stats["ran"] += 1
        stats["ok"] += bool(row.get("success"))
        sim_s[0] += float(row.get("sim_time_s") or 0.0)

    use_batch = spec.batch is True or (spec.batch == "auto" and maneuver.batch_applies(spec))
    if spec.batch is True and not maneuver.batch_applies(spec):
        raise ConfigError("[mission] batch = true: the batch plant needs a manoeuvre with no wind, no waves, "
                          "a steady current and one payload mass (use batch = \"auto\" or false)")
    n_workers = 1
    with _progress(runs, already, progress) as bar:
        if use_batch:
            for start in range(0, len(todo), BATCH_CHUNK):
                chunk = todo[start:start + BATCH_CHUNK]
                samples = [spec.sample(i) for i in chunk]
                for sample, row in zip(samples, maneuver.run_batch(spec, samples), strict=True):
                    save({**sample.as_row(), **row, "worker": "batch"})
                bar.update(len(chunk))
        elif todo:
            from distributed import as_completed

            with dask_client(scheduler, workers) as client:
                n_workers = len(client.scheduler_info()["workers"]) or (workers or 1)
                tag = uuid.uuid4().hex[:8]
                futures = [client.submit(execute, spec, i, key=f"campaign-{spec.name}-{tag}-{i}", pure=False)
                           for i in todo]
                for fut in as_completed(futures):
                    try:
                        row = fut.result()
                    except Exception as exc:  # a lost worker: no row, the next rerun does the run again
                        stats["lost"] += 1
                        print(f"campaign: run {fut.key} lost: {type(exc).__name__}: {exc}", file=sys.stderr,
                              flush=True)
                        continue
                    save(row)
                    bar.update(1)
    return CampaignOutcome(runs=runs, already_done=already, ran=stats["ran"], lost=stats["lost"],
                           successes=stats["ok"], sim_s=round(sim_s[0], 1),
                           wall_s=round(time.perf_counter() - t0, 2), batch=use_batch, workers=n_workers)
