"""Identification J tables (Eq. 12) on simulator logs, as ``usv identify`` computes them.

Training: the chapter's protocol (sine nozzle +-pi/3 at 30 % throttle, 10 s period), seed 1,
calm water.  Validation: sine with another seed in calm water, and sine, zig-zag and random
manoeuvres with other seeds in a 0.1 m/s current and Hs 0.05 m waves (stated, realistic
magnitudes for flood water).  For every validation: ``j[model][mode][dof]``, whether the
qLPV model beats both baselines in free run per DOF, and the active/no-model-error ratio
of the chapter's Table 4 (target <= 1/3).  Every model is estimated by least squares then
instrumental variables (``estimator``); the qLPV model by least squares alone is the row
``qlpv_ls``.  The chapter's Q is read as a rate (Q dt per step);
the per-step reading is reported for the sine validation too.  Per validation also: the
held-model-error bound (:mod:`companion.models.persistence`: the model error's persistence over
the horizon and the active/no-error ratio a perfect UKF would give on that log) and the ratio
with UKF noise identified from the training log (:mod:`companion.models.noise_fit`).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

from companion.models.base import DOF_NAMES
from companion.models.logs import Record, record_from_columns
from companion.models.noise_fit import fit_ukf_noise
from companion.models.pipeline import JTable, identify_models, ratios, validate
from companion.models.ukf import UKFSettings

CURRENT = "0.1,60"
WAVES = "0.05"
VALIDATIONS: tuple[tuple[str, str, int, str, str], ...] = (
    ("sine_calm", "sine", 2, "0,0", "0"),
    ("sine", "sine", 2, CURRENT, WAVES),
    ("zigzag", "zigzag", 3, CURRENT, WAVES),
    ("random", "random", 4, CURRENT, WAVES),
)


def simulated_record(
    kind: str, seed: int, current: str = "0,0", waves: str = "0", duration_s: float = 60.0
) -> Record:
    """A manoeuvre log from the simulator (chapter protocol: 30 % throttle, +-pi/3, 10 s)."""
    from sim_bridge.maneuvers import run_maneuver

    log = run_maneuver(
        kind, throttle=0.3, period_s=10.0, duration_s=duration_s, seed=seed, current=current, waves=waves
    )
    return record_from_columns(log.columns, f"{kind} seed {seed} current {current} waves {waves}")


def summary(table: JTable) -> dict[str, Any]:
    q = table["qlpv"]["free_run"]
    base = {d: min(table[m]["free_run"][d] for m in ("linearized", "nomoto_sideslip")) for d in DOF_NAMES}
    rat = ratios(table)
    return {
        "qlpv_beats_baselines_free_run": {d: bool(q[d] < base[d]) for d in DOF_NAMES},
        "qlpv_ls_beats_baselines_free_run": (
            {d: bool(table["qlpv_ls"]["free_run"][d] < base[d]) for d in DOF_NAMES}
            if "qlpv_ls" in table
            else None
        ),
        "active_over_qlpv_ahead": {d: round(rat["ahead"][d], 3) for d in DOF_NAMES},
        "active_at_most_one_third": {d: bool(rat["ahead"][d] <= 1 / 3) for d in DOF_NAMES},
        "j_percent": {
            m: {mode: {d: round(100 * v, 2) for d, v in row.items()} for mode, row in modes.items()}
            for m, modes in table.items()
        },
    }


HELD_OUT_SEEDS = (5, 6, 7)


def held_out_free_run(models: dict[str, Any]) -> dict[str, Any]:
    """Free-run J only (no UKF) on sine, zig-zag and random validations with further seeds (same
    current and waves), to show whether the wins on the four named validations are seed luck."""
    from companion.models.evaluate import free_run, j_of, reference

    out: dict[str, Any] = {}
    for kind in ("sine", "zigzag", "random"):
        for seed in HELD_OUT_SEEDS:
            rec = simulated_record(kind, seed, CURRENT, WAVES)
            meas = reference(rec)
            j = {n: j_of(free_run(m, rec), meas) for n, m in models.items()}
            base = {d: min(j["linearized"][d], j["nomoto_sideslip"][d]) for d in DOF_NAMES}
            out[f"{kind}_{seed}"] = {
                "qlpv_beats_baselines": {d: bool(j["qlpv"][d] < base[d]) for d in DOF_NAMES},
                "j_percent": {n: {d: round(100 * v[d], 2) for d in DOF_NAMES} for n, v in j.items()},
            }
    return out


GATE_LOGS: tuple[tuple[str, str, int, str, str], ...] = (
    ("sine_calm", "sine", 2, "0,0", "0"), ("sine", "sine", 2, CURRENT, WAVES),
    ("zigzag", "zigzag", 3, CURRENT, WAVES), ("random", "random", 4, CURRENT, WAVES),
    ("random_calm", "random", 7, "0,0", "0"), ("zigzag_0.5", "zigzag", 8, "0.5,120", "0.1"))
"""Logs of :func:`active_gate` (seed offset added per seed set)."""
GATE_TUNING_SEED_OFFSETS = (0, 30, 40, 50)
GATE_REPORTING_SEED_OFFSETS = (10, 20)
"""The gain's rules (companion.models.active_prediction) were chosen on the tuning offsets
(``active_gate(qlpv, GATE_TUNING_SEED_OFFSETS)``); the benchmark reports the reporting ones."""


def active_gate(qlpv: Any, seed_offsets: tuple[int, ...] = GATE_REPORTING_SEED_OFFSETS) -> dict[str, Any]:
    """Worst 1-s ratio active/plain over every DOF and log, per filter, gated and ungated
    (the held correction as Eq. 5 holds it), and the current filter's sway ratio in 0.5 m/s."""
    from companion.models.active_prediction import predict_active, predict_plain, run_filter
    from companion.models.current_ukf import current_filter_settings
    from companion.models.evaluate import j_of, reference

    filters = {"chapter": UKFSettings(), "current": current_filter_settings()}
    worst: dict[str, dict[str, Any]] = {}
    sway_in_flood: list[float] = []
    for off in seed_offsets:
        for name, kind, seed, current, waves in GATE_LOGS:
            rec = simulated_record(kind, seed + off, current, waves, duration_s=60.0)
            meas = reference(rec)
            for fname, settings in filters.items():
                run_ = run_filter(qlpv, rec, settings)
                idx, plain = predict_plain(qlpv, rec, run_, 1.0)
                j0 = j_of(plain, meas[idx])
                for gated in (True, False):
                    _, active = predict_active(qlpv, rec, run_, 1.0, gated=gated)
                    j1 = j_of(active, meas[idx])
                    ratio = {d: j1[d] / j0[d] for d in DOF_NAMES}
                    key = fname + ("" if gated else "_ungated")
                    top = max(ratio.values())
                    if top > worst.get(key, {}).get("ratio", -1.0):
                        worst[key] = {"ratio": round(top, 3), "log": f"{name} seed {seed + off}",
                                      "per_dof": {d: round(r, 3) for d, r in ratio.items()}}
                    if fname == "current" and gated and name == "zigzag_0.5":
                        sway_in_flood.append(round(ratio["v"], 3))
    return {"seed_offsets": list(seed_offsets), "logs": len(GATE_LOGS) * len(seed_offsets),
            "worst_active_over_plain": worst, "current_filter_sway_ratio_in_0.5_mps": sway_in_flood}


def run(quick: bool) -> dict[str, Any]:
    t0 = time.perf_counter()
    duration = 30.0 if quick else 90.0
    train = [simulated_record("sine", 1, duration_s=duration)]
    fits = identify_models(train)
    models = {n: f.model for n, f in fits.items()}
    # the qLPV model by least squares alone (before instrumental variables), reported alongside
    models["qlpv_ls"] = replace(identify_models(train, estimator="ls")["qlpv"].model, name="qlpv_ls")
    out: dict[str, Any] = {
        "train": train[0].name,
        "estimator": {n: f.method for n, f in fits.items()},
        "validation_disturbance": {"current": CURRENT, "waves_hs_m": WAVES},
        "q_discretization": "rate",
    }
    noise = fit_ukf_noise(models["qlpv"], train)
    out["ukf_identified"] = {"q_diag": [float(f"{q:.3g}") for q in noise.q_diag],
                             "r_diag": [float(f"{r:.3g}") for r in noise.r_diag]}
    for name, kind, seed, current, waves in VALIDATIONS[: 2 if quick else None]:
        rec = simulated_record(kind, seed, current, waves, duration_s=30.0 if quick else 60.0)
        val = validate(models, rec, identified_settings=noise)
        out[name] = summary(val.table)
        if val.held_bound is not None and val.active_identified is not None:
            out[name]["held_error_bound"] = val.held_bound.as_dict()
            ahead = val.table["qlpv"]["ahead"]
            out[name]["active_identified_noise_over_qlpv_ahead"] = {
                d: round(val.active_identified[d] / ahead[d], 3) for d in DOF_NAMES}
        if name == "sine":
            literal = validate(models, rec, settings=UKFSettings(q_discretization="per_step")).table
            out["sine_q_per_step"] = summary(literal)
    if not quick:
        out["held_out_free_run"] = held_out_free_run(models)
        out["active_gate"] = active_gate(models["qlpv"])
    out["seconds"] = round(time.perf_counter() - t0, 1)
    return out
