"""The water-current estimate for the ground station (issue 14): ``USV_CURRENT_ESTIMATE`` (the
boat's dialect) and the NAMED_VALUE_FLOAT pair ``CUR_SPD`` (m/s) / ``CUR_DIR`` (degrees toward,
clockwise from north) that QGroundControl and MAVProxy plot without the dialect.

Both read the estimator's latest :class:`~companion.messages.CurrentEstimate` from the bus topic
``water_current`` (the current-augmented filter publishes it every navigation sample); an
estimate older than :data:`FRESH_S` is reported as none (NaN, estimator NONE) and the
NAMED_VALUE_FLOAT pair is not sent at all (a plot should show a gap, not a stale value).
"""

from __future__ import annotations

import math
from typing import Any

from companion.app import Context
from companion.link.dialect import boat_module, mav
from companion.messages import WATER_CURRENT_TOPIC, CurrentEstimate

FRESH_S = 1.0
"""An estimate older than this (clock time) is not reported."""

SPEED_NAME = b"CUR_SPD"
DIRECTION_NAME = b"CUR_DIR"


def fresh_current(ctx: Context) -> CurrentEstimate | None:
    """The latest current estimate on the bus, ``None`` without one or when it is stale."""
    est = ctx.bus.topic(WATER_CURRENT_TOPIC).latest()
    if est is None or ctx.clock.now_s() - est.t_s > FRESH_S:
        return None
    return est


def speed_std_mps(est: CurrentEstimate) -> float:
    """Standard deviation of the speed from the component variances (first-order propagation:
    var(|V|) = (V_N^2 var_N + V_E^2 var_E) / |V|^2; the mean of the two at zero speed)."""
    if est.speed_mps < 1e-6:
        return math.sqrt(max(0.0, 0.5 * (est.north_var_m2ps2 + est.east_var_m2ps2)))
    var = (est.north_mps**2 * est.north_var_m2ps2 + est.east_mps**2 * est.east_var_m2ps2) / est.speed_mps**2
    return math.sqrt(max(0.0, var))


def usv_current_estimate(ctx: Context, time_boot_ms: int) -> Any:
    """USV_CURRENT_ESTIMATE (NaN fields and estimator NONE while there is no fresh estimate)."""
    usv = boat_module()
    if usv is None:
        return None
    est = fresh_current(ctx)
    if est is None:
        nan = math.nan
        return usv.MAVLink_usv_current_estimate_message(time_boot_ms, nan, nan, nan, nan, nan, 0.0,
                                                        usv.USV_CURRENT_ESTIMATOR_NONE)
    return usv.MAVLink_usv_current_estimate_message(
        time_boot_ms, est.north_mps, est.east_mps, est.speed_mps, math.degrees(est.toward_rad) % 360.0,
        speed_std_mps(est), est.confidence, usv.USV_CURRENT_ESTIMATOR_UKF)


def named_current_values(ctx: Context, time_boot_ms: int) -> tuple[Any, ...] | None:
    """NAMED_VALUE_FLOAT CUR_SPD and CUR_DIR (both sent in one tick), ``None`` without an estimate."""
    est = fresh_current(ctx)
    if est is None:
        return None
    return (mav.MAVLink_named_value_float_message(time_boot_ms, SPEED_NAME, est.speed_mps),
            mav.MAVLink_named_value_float_message(time_boot_ms, DIRECTION_NAME,
                                                  math.degrees(est.toward_rad) % 360.0))
