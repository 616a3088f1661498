"""USV_CMD_NAV_SAMPLE_HERE (31001): "take a water sample at a point", in AUTO and at upload.

param1 bottle (0/NaN: next empty), param2 circle radius (m; 0/NaN: USV_SMPL_CIRC_M),
param3 fill time (s; 0/NaN: USV_SMPL_FILL_S), param4 volume (mL; 0/NaN: by time),
param5/6 the point.  AUTO goes there, circles the point and starts the sample once on the
circle; the pump runs only inside the acceptance radius (USV_SMPL_ACC_M, chapter 4.2: 2.5 m).
A refused sample is announced and the mission goes on.  The upload check refuses a bottle that
is not 0-4 (INVALID_PARAM1), a radius, fill time or volume outside its parameter's range
(INVALID_PARAM2/3/4) and coordinates off the globe.
"""

from __future__ import annotations

import math

from companion.messages import BOTTLE_COUNT, NavState, Severity
from companion.mission import validate as v
from companion.mission.items import MissionItem
from companion.modes.auto_items import AutoRun, NavItem, Phase
from companion.modes.circle_item import CircleTask
from companion.modes.navigation import estimator_current
from companion.payloads.mission_checks import check_coordinates, in_range, is_default, param_range
from companion.payloads.registry import PayloadEnv
from companion.payloads.sampler.device import SampleJob, SampleRequest, WaterSampler
from companion.payloads.sampler.params import PARAMS


def check_sample_here(item: MissionItem) -> v.ItemProblem | None:
    """USV_CMD_NAV_SAMPLE_HERE: bottle, circle radius, fill time, volume, coordinates."""
    s = item.seq
    bottle = item.param1
    if not math.isnan(bottle) and not (math.isfinite(bottle) and bottle == int(bottle)
                                       and 0 <= bottle <= BOTTLE_COUNT):
        return v.ItemProblem(v.INVALID_PARAM1, f"item {s}: bottle {bottle:g} not 0-4 (0 = next)")
    radius = param_range(PARAMS, "USV_SMPL_CIRC_M")
    if not is_default(item.param2) and not in_range(item.param2, radius):
        return v.ItemProblem(v.INVALID_PARAM2,
                             f"item {s}: radius {item.param2:g} m not in {radius[0]:g}-{radius[1]:g} m")
    fill = param_range(PARAMS, "USV_SMPL_FILL_S")
    if not is_default(item.param3) and not in_range(item.param3, fill):
        return v.ItemProblem(v.INVALID_PARAM3,
                             f"item {s}: fill {item.param3:g} s not in {fill[0]:g}-{fill[1]:g} s")
    most_ml = param_range(PARAMS, "USV_SMPL_BTL_ML")[1]
    if not is_default(item.param4) and not (math.isfinite(item.param4) and 0.0 < item.param4 <= most_ml):
        return v.ItemProblem(v.INVALID_PARAM4, f"item {s}: volume {item.param4:g} mL not in 0-{most_ml:g} mL")
    return check_coordinates(item)


def start_sample(sampler: WaterSampler, env: PayloadEnv, request: SampleRequest) -> SampleJob | str:
    """Start a sample for a mission item; a refusal is announced and returned."""
    result = sampler.start(request)
    if isinstance(result, str):
        env.announce(result, Severity.WARNING)
    else:
        env.announce(f"sampler: filling bottle {result.bottle}")
    return result


class SampleHereItem(NavItem):
    """Go to the point, circle it, take one sample on the circle, go on when it is done.  The item
    has no direction: the boat circles the way its bow goes round the point when it starts circling
    (after a hold on the circle given up, it would otherwise turn about, away from the circle)."""

    circles = True

    def __init__(self, run: AutoRun, item: MissionItem, sampler: WaterSampler, env: PayloadEnv) -> None:
        super().__init__(run, item)
        self.sampler = sampler
        self.env = env
        self.job: SampleJob | None = None

    def arrive(self, nav: NavState) -> bool:
        params = self.run.host.params
        default_radius_m = params.get_or("USV_SMPL_CIRC_M", params.get("USV_TURN_RAD"))
        radius = self.item.param2 if self.item.param2 > 0 else default_radius_m
        self.run.task = CircleTask(params, self.point, radius, clockwise=None, drift=self.run.drift,
                                   trials=self.run.host.station_trials,
                                   water_current=estimator_current(self.run.host),
                                   idling=self.run.host.control.mapper.idling)
        self.run.phase = Phase.ACTION
        return False

    def hold(self, nav: NavState) -> bool:
        task = self.run.task
        assert isinstance(task, CircleTask)
        if self.job is None:
            if task.on_circle_since_s is None:
                return False
            item = self.item
            accept = self.run.host.params.get_or("USV_SMPL_ACC_M", task.radius_m + 0.5)
            job = start_sample(self.sampler, self.env, SampleRequest(
                bottle=int(item.param1) if math.isfinite(item.param1) else 0,
                fill_s=item.param3 if item.param3 > 0 else None,
                volume_ml=item.param4 if item.param4 > 0 else None,
                mission_seq=item.seq, target_lat_deg=item.lat_deg, target_lon_deg=item.lon_deg,
                accept_radius_m=accept))
            if isinstance(job, str):
                return True  # refused (announced); continue the mission
            self.job = job
        return self.job.done.done()
