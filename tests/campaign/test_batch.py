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
