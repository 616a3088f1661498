"""USV_CMD_NAV_LAUNCH_AT (31000): "fire the rope launcher at a point", in AUTO and at upload.

param1 bearing (deg; NaN: keep the heading on arrival), param2 hold time (s; 0/NaN:
USV_LNCH_HOLD_S), param3 range to the target (m; 0/NaN: none), param5/6 the point.  With a range
the target is that far from the launch point on the bearing, and the bow is aimed at the target
from wherever the boat holds (a boat keeping station drifts a few metres; on the bearing alone
the throw would miss by the drift).  The upload check refuses a bearing outside [0, 360]
(INVALID_PARAM1), a hold outside USV_LNCH_HOLD_S's range (INVALID_PARAM2), a range that is
negative, not finite or beyond the rope's :data:`MAX_RANGE_M` (INVALID_PARAM3) and coordinates off
the globe (INVALID_PARAM5_X / 6_Y).
"""

from __future__ import annotations

import asyncio
import math

from companion.control.target import ControlTarget
from companion.guidance.geo import LocalFrame, wrap_pi
from companion.messages import NavState, Severity
from companion.mission import validate as v
from companion.mission.items import MissionItem
from companion.modes.auto_items import AutoRun, NavItem, Phase
from companion.modes.navigation import StationTask
from companion.payloads.launcher.device import RopeLauncher
from companion.payloads.launcher.params import PARAMS
from companion.payloads.mission_checks import check_coordinates, in_range, is_default, param_range
from companion.payloads.registry import PayloadEnv

LAUNCH_MAX_DIST_M = 8.0
"""Farther than this from the launch point, the boat goes back to it before turning to fire."""
LAUNCH_MAX_SPEED_MPS = 1.8
"""'Stopped' for a water jet holding a heading: steerage way is about 1.5 m/s in SITL."""
MAX_RANGE_M = 150.0
"""The rope launcher's farthest throw (chapter section 4.1)."""


def check_launch_at(item: MissionItem) -> v.ItemProblem | None:
    """USV_CMD_NAV_LAUNCH_AT: bearing, hold time, coordinates."""
    s = item.seq
    bearing = item.param1
    if not math.isnan(bearing) and not (math.isfinite(bearing) and 0.0 <= bearing <= 360.0):
        return v.ItemProblem(v.INVALID_PARAM1, f"item {s}: bearing {bearing:g} deg not in 0-360 (NaN = keep)")
    hold = param_range(PARAMS, "USV_LNCH_HOLD_S")
    if not is_default(item.param2) and not in_range(item.param2, hold):
        return v.ItemProblem(v.INVALID_PARAM2,
                             f"item {s}: hold {item.param2:g} s not in {hold[0]:g}-{hold[1]:g} s")
    target_m = item.param3
    if not is_default(target_m) and not (math.isfinite(target_m) and 0.0 < target_m <= MAX_RANGE_M):
        return v.ItemProblem(v.INVALID_PARAM3, f"item {s}: range {target_m:g} m not in 0-{MAX_RANGE_M:g} m "
                                               "(0 or NaN: fire on the bearing)")
    return check_coordinates(item)


async def mission_fire(launcher: RopeLauncher, env: PayloadEnv, mission_seq: int) -> str | None:
    """Arm and fire for a mission item (the uploaded and started item is the operator's explicit
    intent; every physical interlock still applies); the refusal (announced) or None when fired."""
    reason = launcher.arm(env.ctx.params.get("USV_LNCH_ARM_S"))
    if reason is None:
        reason = await launcher.fire(mission_seq=mission_seq)
    if reason is not None:
        env.announce(reason, Severity.WARNING)
    else:
        last = launcher.last_launch
        heading = f" hdg {last.heading_deg:.0f}" if last and last.heading_deg is not None else ""
        env.announce(f"launcher: FIRED{heading}", Severity.WARNING)
    return reason


class _HeadingTask:
    """Point the bow at ``heading_rad`` at ``speed_mps`` while staying near the launch point.

    Steered by the station-keeping family (``hold_station``; ``USV_STN_CTRL``, PID by default):
    near standstill the active-model law chattered the nozzle and the bow held within 10 deg for
    at most 1.25-1.5 s in the flood of ``tests/missions`` (0.5 m/s across, 5 m/s wind, Hs 0.3 m);
    with PID 2.25 s, stopped near the point 47 % of the time instead of 28-31 %."""

    def __init__(self, heading_rad: float, inner: StationTask, speed_mps: float) -> None:
        self.heading_rad = heading_rad
        self.speed_mps = speed_mps
        self.inner = inner
        self.frame: LocalFrame = inner.frame
        self.point = inner.point
        self.distance_m = 0.0
        self.cross_track_m = 0.0

    def step(self, nav: NavState, dt_s: float) -> ControlTarget:
        self.inner.step(nav, dt_s)
        self.distance_m = self.inner.distance_m
        return ControlTarget(self.heading_rad, self.speed_mps, is_heading=True, hold_station=True)


class LaunchAtItem(NavItem):
    """Go to the point, bow on the bearing, slowed to steerage way, hold, fire, go on.

    A water jet cannot reverse and needs thrust to steer, so "stop" means the slowest speed at
    which it still holds a heading: the controller is asked for zero speed on the bearing and the
    launcher fires once the bow has stayed within ``USV_LNCH_HDG_DEG`` at no more than
    :data:`LAUNCH_MAX_SPEED_MPS` for the hold time.
    """

    def __init__(self, run: AutoRun, item: MissionItem, launcher: RopeLauncher, env: PayloadEnv) -> None:
        super().__init__(run, item)
        self.launcher = launcher
        self.env = env
        self.bearing_rad = 0.0
        self.target_ne: tuple[float, float] | None = None
        """The target (north, east metres from the launch point) when the item gives its range."""
        self.steer: _HeadingTask | None = None
        self.fire: asyncio.Task[str | None] | None = None

    def arrive(self, nav: NavState) -> bool:
        run = self.run
        run.phase = Phase.ACTION
        p1 = self.item.param1
        self.bearing_rad = math.radians(p1) if math.isfinite(p1) else nav.heading_rad
        station = StationTask(run.host.params, self.point, self.bearing_rad)
        range_m = self.item.param3
        if math.isfinite(range_m) and range_m > 0.0:
            self.target_ne = (range_m * math.cos(self.bearing_rad), range_m * math.sin(self.bearing_rad))
        run.task = station
        self.steer = _HeadingTask(self.bearing_rad, station, speed_mps=0.0)
        return False

    def _aim_rad(self, nav: NavState) -> float:
        """The bearing to fire on: to the target from where the boat is (a range was given), else
        the item's bearing."""
        if self.target_ne is None or self.steer is None:
            return self.bearing_rad
        north_m, east_m = self.steer.frame.to_ne(nav.lat_deg, nav.lon_deg)
        return math.atan2(self.target_ne[1] - east_m, self.target_ne[0] - north_m)

    def hold(self, nav: NavState) -> bool:
        if self.fire is not None:
            return self.fire.done()
        run, params = self.run, self.run.host.params
        assert self.steer is not None
        aim_rad = self._aim_rad(nav)
        self.steer.heading_rad = aim_rad
        err = abs(wrap_pi(aim_rad - nav.heading_rad))
        hold = self.item.param2 if self.item.param2 > 0 else params.get_or("USV_LNCH_HOLD_S", 3.0)
        station = self.steer.inner
        if station.distance_m > LAUNCH_MAX_DIST_M:
            run.since_s = nav.t_s  # carried off the point while turning: station-keep back to it
            run.task = station
            return False
        run.task = self.steer  # steer for the bearing asking for zero speed: only steerage way
        tolerance_rad = math.radians(params.get_or("USV_LNCH_HDG_DEG", 10.0))
        if err > tolerance_rad or nav.speed_over_ground_mps > LAUNCH_MAX_SPEED_MPS:
            run.since_s = nav.t_s
            return False
        if nav.t_s - run.since_s < hold:
            return False
        fire = mission_fire(self.launcher, self.env, self.item.seq)
        self.fire = asyncio.get_running_loop().create_task(fire)
        return False

    def cancel(self) -> None:
        if self.fire is not None and not self.fire.done():
            self.fire.cancel()
