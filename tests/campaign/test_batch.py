"""Open-loop manoeuvre campaigns: the vectorised batch plant gives what one run at a time gives."""

from __future__ import annotations

import pytest

from sim_bridge.campaign import maneuver
from sim_bridge.campaign.spec import parse_campaign


def _spec(kind: str, **dists: object) -> object:
    return parse_campaign({"campaign": {"name": "m", "seed": 3},
                           "mission": {"maneuver": kind, "options": {"duration_s": 20.0, "warmup_s": 5.0,
                                                                      "amplitude_rad": 0.5}},
                           "distributions": {"current_speed_mps": {"uniform": [0.0, 1.0]},
                                             "current_toward_deg": {"uniform": [0.0, 360.0]}, **dists}})


@pytest.mark.parametrize("kind", ["turn", "sine"])
def test_batch_runs_match_single_runs(kind: str) -> None:
    spec = _spec(kind)
    assert maneuver.batch_applies(spec)  # type: ignore[arg-type]
    samples = [spec.sample(i) for i in range(4)]  # type: ignore[attr-defined]
    batch = maneuver.run_batch(spec, samples)  # type: ignore[arg-type]
    for sample, b in zip(samples, batch, strict=True):
        one = maneuver.run_sample(spec, sample)  # type: ignore[arg-type]
        for name in maneuver.FIGURES:
            assert b[name] == pytest.approx(one[name], rel=1e-4, abs=1e-3), (name, sample)
    # different currents drift the turning circle differently: the figures are per boat
    assert len({round(b["displacement_m"], 2) for b in batch}) == len(batch)


def test_batch_does_not_apply_with_wind_or_varying_payload() -> None:
    assert not maneuver.batch_applies(_spec("turn", wind_speed_mps=3.0))  # type: ignore[arg-type]
    assert not maneuver.batch_applies(_spec("turn", payload_kg={"choice": [0, 30]}))  # type: ignore[arg-type]
    assert maneuver.batch_applies(_spec("zigzag", payload_kg=30.0))  # type: ignore[arg-type]


@pytest.mark.integration
def test_usv_bench_reports_campaign_throughput(usv_env: dict[str, str]) -> None:
    import json
    import subprocess

    from tests.conftest import usv_command

    proc = subprocess.run([*usv_command(), "bench", "campaign", "--quick"], capture_output=True, text=True,
                          env=usv_env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    figures = json.loads(proc.stdout)["benchmarks"]["campaign"]
    sitl, man = figures["sitl"], figures["maneuver"]
    assert sitl["runs_with_errors"] == 0 and sitl["sim_s_total"] > 2 * 20.0
    assert sitl["sim_s_per_wall_s_total"] > 0 and sitl["sim_s_per_wall_s_per_worker"] > 0
    assert man["batch_sim_s_per_wall_s"] > 0 and man["per_run_sim_s_per_wall_s"] > 0
