"""Campaign runs of an open-loop manoeuvre (no companion): one run at a time, or vectorised.

Per run: :func:`sim_bridge.maneuvers.run_maneuver` (the ``usv sim maneuver`` code: one
:class:`~sim_bridge.plant.BoatPlant` with wind, waves, current, payload and the GPS-INS), figures
from its noiseless ``*_true`` columns.

Batch (:func:`run_batch`): every pending run of the campaign in one
:class:`~sim_bridge.plant.BatchPlant`, each boat in its own steady current, stepped as numpy
arrays.  It applies when nothing but the current varies between runs and there is no wind, no waves
and no current variability (what the batch plant models), and the payload is the same in every
run (one hull).  The zig-zag then reverses on the TRUE heading (the per-run manoeuvre reverses
on the GPS-INS heading, with its noise); sine and turn have no feedback and match the per-run
manoeuvre to rounding (``tests/campaign``).  Both paths compute figures with :func:`figures`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from sim_bridge.campaign.spec import CampaignSpec, Sample
from sim_bridge.hull import BoatParams
from sim_bridge.maneuvers import run_maneuver
from sim_bridge.plant import BatchPlant

MANEUVER_OPTIONS = {"throttle": 0.5, "amplitude_rad": math.pi / 6, "period_s": 10.0, "duration_s": 60.0,
                    "warmup_s": 10.0}
"""Manoeuvre options and their defaults (``[mission] options``)."""
DT_S = 0.01
FIGURES = ("max_yaw_rate_degps", "mean_sog_mps", "path_extent_m", "displacement_m", "heading_change_deg")
"""Figures of a manoeuvre, over the manoeuvre proper (after the warm-up)."""


def options(spec: CampaignSpec) -> dict[str, float]:
    return {**MANEUVER_OPTIONS, **{k: float(v) for k, v in spec.options.items()}}


def figures(t_s: np.ndarray, north_m: np.ndarray, east_m: np.ndarray, psi_rad: np.ndarray,
            r_radps: np.ndarray, sog_mps: np.ndarray, warmup_s: float) -> dict[str, np.ndarray]:
    """Figures of N boats from arrays of shape (T, N) (one boat: (T, 1)); each figure shape (N,).

    ``max_yaw_rate_degps`` largest |r|, ``mean_sog_mps`` mean speed over ground, ``path_extent_m``
    farthest distance from where the manoeuvre began, ``displacement_m`` distance from there at
    the end (a turning circle drifts with the current), ``heading_change_deg`` total turn."""
    sel = np.ravel(t_s) >= warmup_s - 1e-9
    n, e = north_m[sel], east_m[sel]
    dist = np.hypot(n - n[0], e - e[0])
    turn = np.sum(np.abs(np.angle(np.exp(1j * np.diff(psi_rad[sel], axis=0)))), axis=0)
    return {"max_yaw_rate_degps": np.degrees(np.max(np.abs(r_radps[sel]), axis=0)),
            "mean_sog_mps": np.mean(sog_mps[sel], axis=0), "path_extent_m": np.max(dist, axis=0),
            "displacement_m": dist[-1], "heading_change_deg": np.degrees(turn)}


def run_sample(spec: CampaignSpec, sample: Sample) -> dict[str, Any]:
    """Worker entry: one manoeuvre with the sample's conditions."""
    t_wall, t_cpu = time.perf_counter(), time.thread_time()
    o = options(spec)
    log = run_maneuver(str(spec.maneuver), throttle=o["throttle"], amplitude_rad=o["amplitude_rad"],
                       period_s=o["period_s"], duration_s=o["duration_s"], warmup_s=o["warmup_s"],
                       seed=sample.seed, wind=sample.wind, current=sample.current, waves=sample.waves,
                       payload_kg=sample.payload_kg, dt_s=DT_S)
    col = {k: v[:, None] for k, v in log.columns.items()}
    figs = figures(col["t"], col["x_true"], col["y_true"], col["psi_true"], col["r_true"],
                   np.hypot(col["u_true"], col["v_true"]), o["warmup_s"])
    out: dict[str, Any] = {k: round(float(v[0]), 4) for k, v in figs.items()}
    keep = slice(None, None, 100)
    out.update(success=True, failures="", mission_complete=True,
               sim_time_s=round(float(log["t"][-1]) + DT_S, 2),
               track={"north_m": np.round(log["x_true"][keep], 2).tolist(),
                      "east_m": np.round(log["y_true"][keep], 2).tolist(), "marks_ne": []},
               wall_s=round(time.perf_counter() - t_wall, 3), cpu_s=round(time.thread_time() - t_cpu, 3))
    return out


def batch_applies(spec: CampaignSpec) -> bool:
    """Whether every run can share one batch plant (see the module docstring)."""
    if spec.kind != "maneuver":
        return False
    d = spec.distributions
    for name in ("wind_speed_mps", "wave_hs_m", "current_var"):
        if name in d and d[name].constant != 0.0:
            return False
    return "payload_kg" not in d or d["payload_kg"].constant is not None


def run_batch(spec: CampaignSpec, samples: Sequence[Sample]) -> list[dict[str, Any]]:
    """Every sample's manoeuvre in one vectorised plant; one result per sample, in order."""
    t_wall, t_cpu = time.perf_counter(), time.process_time()
    o = options(spec)
    n = len(samples)
    speed = np.array([s.current_speed_mps for s in samples])
    toward = np.radians([s.current_toward_deg for s in samples])
    payload = samples[0].payload_kg if samples else 0.0
    plant = BatchPlant(n, BoatParams().with_payload(payload),
                       current_ned_mps=(speed * np.cos(toward), speed * np.sin(toward)))
    steps = round((o["warmup_s"] + o["duration_s"]) / DT_S)
    amp, period, thr, warmup = o["amplitude_rad"], o["period_s"], o["throttle"], o["warmup_s"]
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("north", "east", "psi", "r", "sog")}
    t = np.arange(steps) * DT_S
    sign = np.ones(n)
    psi_ref: np.ndarray | None = None
    for i in range(steps):
        north, east, psi = plant.north_m, plant.east_m, plant.psi_rad
        c, s = np.cos(psi), np.sin(psi)
        u = plant.u_r_mps + c * plant_cn(plant) + s * plant_ce(plant)
        v = plant.v_r_mps - s * plant_cn(plant) + c * plant_ce(plant)
        for key, value in (("north", north), ("east", east), ("psi", psi), ("r", plant.r_radps),
                           ("sog", np.hypot(u, v))):
            cols[key].append(np.array(value, copy=True))
        tm = t[i] - warmup
        if tm < 0.0:
            delta: np.ndarray | float = 0.0
        elif spec.maneuver == "sine":
            delta = amp * math.sin(2.0 * math.pi * tm / period)
        elif spec.maneuver == "turn":
            delta = amp
        elif spec.maneuver == "zigzag":
            if psi_ref is None:
                psi_ref = psi.copy()
            dpsi = np.angle(np.exp(1j * (psi - psi_ref)))
            sign = np.where((sign > 0) & (dpsi >= amp), -1.0,
                            np.where((sign < 0) & (dpsi <= -amp), 1.0, sign))
            delta = sign * amp
        else:
            raise ValueError(f"batch mode has no {spec.maneuver!r} manoeuvre "
                             "(random needs one generator per boat)")
        plant.step(DT_S, delta, thr, True)
    arr = {k: np.stack(v) for k, v in cols.items()}
    figs = figures(t, arr["north"], arr["east"], arr["psi"], arr["r"], arr["sog"], warmup)
    wall, cpu = time.perf_counter() - t_wall, time.process_time() - t_cpu
    out = []
    for j in range(n):
        row: dict[str, Any] = {k: round(float(v[j]), 4) for k, v in figs.items()}
        row.update(success=True, failures="", mission_complete=True, sim_time_s=round(steps * DT_S, 2),
                   track={"north_m": np.round(arr["north"][::100, j], 2).tolist(),
                          "east_m": np.round(arr["east"][::100, j], 2).tolist(), "marks_ne": []},
                   wall_s=round(wall / n, 5), cpu_s=round(cpu / n, 5))
        out.append(row)
    return out


def plant_cn(plant: BatchPlant) -> np.ndarray | float:
    cur = plant.current_ned_mps
    return plant.env.current_ned_mps()[0] if cur is None else cur[0]


def plant_ce(plant: BatchPlant) -> np.ndarray | float:
    cur = plant.current_ned_mps
    return plant.env.current_ned_mps()[1] if cur is None else cur[1]
