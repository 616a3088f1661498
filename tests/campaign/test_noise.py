"""The GPS-INS noise scale a campaign varies: every noise level of Table 2 times the scale."""

from __future__ import annotations

import math

import pytest

from sim_bridge.gpsins import GpsInsModel
from sim_bridge.plant import PlantState


def _errors(scale: float) -> list[tuple[float, float, float]]:
    model = GpsInsModel(seed=4, noise_scale=scale)
    state = PlantState(north_m=30.0, east_m=-20.0, psi_rad=1.0, u_mps=2.0, u_r_mps=2.0)
    out = []
    for _ in range(200):
        m = model.measure(state, 0.01)
        true_vn = 2.0 * math.cos(1.0)
        heading_error_deg = (m.heading_deg - math.degrees(1.0) + 180) % 360 - 180
        out.append((m.north_m - 30.0, m.vn_mps - true_vn, heading_error_deg))
    return out


def test_noise_scales_every_error_and_zero_is_the_truth() -> None:
    one, two, zero = _errors(1.0), _errors(2.0), _errors(0.0)
    for a, b in zip(one, two, strict=True):
        assert b == pytest.approx([2.0 * x for x in a], rel=1e-6, abs=1e-9)
    assert max(abs(x) for row in zero for x in row) < 1e-6
    assert max(abs(row[1]) for row in one) > 0.05  # the device's 0.1 m/s velocity noise is there
    with pytest.raises(ValueError, match="noise scale"):
        GpsInsModel(seed=1, noise_scale=-1.0)
