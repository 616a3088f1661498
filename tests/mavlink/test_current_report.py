"""USV_CURRENT_ESTIMATE and CUR_SPD / CUR_DIR from the estimator's topic (unit: bus and clock real,
no vehicle): what a ground station is told with a fresh estimate, a stale one and none."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from companion.clock import SimClock
from companion.config import default_config
from companion.link.dialect import mav
from companion.mavlink.current_report import named_current_values, speed_std_mps, usv_current_estimate
from companion.messages import WATER_CURRENT_TOPIC, CurrentEstimate
from companion.runtime import build_context
from mavlink_dialect import usv


def _ctx(tmp_path: Path):  # type: ignore[no-untyped-def]
    config = default_config().with_overrides({"vehicle.state_dir": str(tmp_path)})
    return build_context(config, SimClock())


def _packs(msg: object) -> None:
    """The message encodes (a NaN or an out-of-range field would raise here)."""
    msg.pack(usv.MAVLink(None, srcSystem=1, srcComponent=1))  # type: ignore[attr-defined]


def test_fresh_estimate_is_reported_in_degrees_toward_with_its_spread(tmp_path: Path) -> None:
    ctx = _ctx(tmp_path)
    ctx.clock.advance_to(10.0)
    ctx.bus.topic(WATER_CURRENT_TOPIC).publish(
        CurrentEstimate.from_components(9.9, -0.3, -0.4, 0.01**2, 0.02**2, 0.97))
    msg = usv_current_estimate(ctx, 10_000)
    _packs(msg)
    assert msg.estimator == usv.USV_CURRENT_ESTIMATOR_UKF
    assert (msg.current_north, msg.current_east) == pytest.approx((-0.3, -0.4))
    assert msg.speed == pytest.approx(0.5)
    assert msg.direction == pytest.approx(math.degrees(math.atan2(-0.4, -0.3)) % 360.0)  # 233.1 deg
    assert msg.speed_std == pytest.approx(math.sqrt((0.09 * 1e-4 + 0.16 * 4e-4) / 0.25))
    assert msg.confidence == pytest.approx(0.97)
    spd, direction = named_current_values(ctx, 10_000) or ()
    assert (spd.name, direction.name) == ("CUR_SPD", "CUR_DIR")
    assert spd.get_msgId() == direction.get_msgId() == mav.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT
    assert (spd.value, direction.value) == pytest.approx((0.5, 233.13), abs=0.01)


@pytest.mark.parametrize("published", [False, True])
def test_no_or_stale_estimate_says_none_and_plots_nothing(tmp_path: Path, published: bool) -> None:
    ctx = _ctx(tmp_path)
    if published:  # the estimate stopped 2 s ago (estimator skipping samples, filter switched)
        stale = CurrentEstimate.from_components(1.0, 0.5, 0.0, 1e-4, 1e-4, 1.0)
        ctx.bus.topic(WATER_CURRENT_TOPIC).publish(stale)
    ctx.clock.advance_to(3.0)
    msg = usv_current_estimate(ctx, 3000)
    _packs(msg)
    assert msg.estimator == usv.USV_CURRENT_ESTIMATOR_NONE and msg.confidence == 0.0
    assert all(math.isnan(x) for x in (msg.current_north, msg.current_east, msg.speed, msg.direction))
    assert named_current_values(ctx, 3000) is None


def test_speed_spread_in_slack_water_is_the_component_spread() -> None:
    est = CurrentEstimate.from_components(0.0, 0.0, 0.0, 0.02**2, 0.04**2, 0.0)
    assert speed_std_mps(est) == pytest.approx(math.sqrt(0.5 * (0.02**2 + 0.04**2)))
