"""One campaign run of a mission script's plan: headless lockstep SITL, no ground station.

The whole companion (:func:`companion.runtime.build_companion`, no MAVLink links) runs against the
simulated boat in one process (:class:`sim_bridge.sitl.SitlHarness`, lockstep, as fast as the CPU
allows).  The mission is driven in-process through the code a MAVLink ground station reaches:

* the plan is the script's own (``missions/water_sampling.py`` / ``missions/rescue.py``:
  ``plan`` / ``plan_from`` with the campaign's ``[mission] options`` parsed by the script's parser),
  installed with :meth:`companion.mavlink.mission_service.MissionService.install`, the end of a
  MAVLink upload (per-item and whole-plan validation, item 0's convention, storage, STATUSTEXT);
* arming and AUTO are :meth:`companion.vehicle.Vehicle.arm` / ``set_mode``, what COMMAND_LONG
  MAV_CMD_COMPONENT_ARM_DISARM and SET_MODE call.

What is not exercised: the MAVLink wire protocol itself (framing, retries, ACKs), which the
``tests/missions`` scripts cover against ``usv sitl``.

Figures come from the simulator's truth log (:class:`sim_bridge.truthlog.TruthLog`, 20 Hz) through
:mod:`benchmarks.nav_metrics`, the functions ``usv bench nav`` uses; the rescue's launch figures and
success criteria from ``missions/rescue.py`` (:func:`missions.rescue.launch_errors`,
:func:`missions.rescue.launch_failures`).  Success repeats the scripts' criteria (see
``missions/README.md``) with the script's tolerances from the campaign's options.

* ``circle_error_max_m`` / ``_rms_m``: :func:`benchmarks.nav_metrics.sampling` (Fig. 13's distance
  from the commanded circle, from the first time within radius + 0.5 m of each point until the item
  is done); ``fill_distance_max_m`` the truth's largest distance from a point while its bottle filled;
* ``path_deviation_max_m``, ``mid_leg_cross_track_*``: :func:`benchmarks.nav_metrics.square` on the
  plan's legs (sampling: home -> P1 -> ... -> P4, circling included in the deviation; rescue: home ->
  slow-down waypoint -> launch point);
* ``loiter_error_max_m`` (rescue): :func:`benchmarks.nav_metrics.arrival`'s largest distance from the
  launch point after first coming within ``--launch-tol`` of it, until the hold ends (or the run
  stops): station keeping while aiming, firing and holding;
* launch figures from the simulator's launch event (true position and heading when the launcher
  fired); samples from the vehicle's own sample log, as the script judges them.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from benchmarks import nav_metrics
from companion.config import default_config
from companion.guidance.geo import LocalFrame
from companion.messages import STATUS_TEXT_TOPIC, ModeNumber, Severity, StatusText
from companion.mission.items import MissionItem, MissionType
from companion.vehicle import MissionState
from sim_bridge.campaign.spec import CampaignSpec, Sample
from sim_bridge.sitl import SitlHarness
from sim_bridge.truthlog import TruthLog

if TYPE_CHECKING:
    from missions.common import WaterCurrent

SETTLE_S = 2.0
"""Simulated seconds before arming (first fixes, home)."""
POLL_S = 0.5
"""Simulated seconds between two looks at the mission's progress."""
TRACK_PERIOD_S = 0.25
"""Period of the track kept for the report's plots (s)."""


def companion_item(item: Any) -> MissionItem:
    """A MAVSDK ``mission_raw.MissionItem`` (what the scripts upload) as the vehicle stores it."""
    return MissionItem(seq=int(item.seq), frame=int(item.frame), command=int(item.command),
                       param1=float(item.param1), param2=float(item.param2), param3=float(item.param3),
                       param4=float(item.param4), x=int(item.x), y=int(item.y), z=float(item.z),
                       current=int(item.current), autocontinue=int(item.autocontinue),
                       mission_type=int(item.mission_type))


class Plan:
    """A script's plan for this run: items, item time limits, and what the figures need."""

    def __init__(self, spec: CampaignSpec, frame: LocalFrame, here_ne: tuple[float, float],
                 turn_radius_m: float, drift: WaterCurrent | None = None) -> None:
        self.script = spec.script
        self.args = spec.script_args()
        self.limits_s: dict[int, float] = {}
        if spec.script == "water_sampling":
            from missions import water_sampling

            self.points_ne: list[tuple[float, float]] = [(float(p[0]), float(p[1])) for p in self.args.points]
            self.radius_m = float(self.args.radius or turn_radius_m)
            raw = water_sampling.plan(frame, self.points_ne, self.radius_m, self.args)
        else:
            from missions import rescue

            at, offset = self.args.casualty_at, self.args.casualty
            self.casualty_ne: tuple[float, float] = (frame.to_ne(*at) if at else
                                                     (float(offset[0]), float(offset[1])))
            self.geometry = rescue.plan_from(frame, here_ne, self.casualty_ne, self.args, drift)
            raw = self.geometry["items"]
            self.limits_s = {self.geometry["seq"]["launch"]: float(self.args.aim_timeout)}
        self.items = [companion_item(i) for i in raw]


def _nan_to_none(x: float) -> float | None:
    return None if not math.isfinite(x) else x


async def fly(spec: CampaignSpec, sample: Sample, workdir: Path,
              settle_s: float = SETTLE_S) -> dict[str, Any]:
    """Fly ``sample``; the run's figures (see :data:`sim_bridge.campaign.results.COLUMNS`) and track.
    ``settle_s``: simulated seconds adrift before arming (a boat that has been in the water a while
    arms on a settled current estimate)."""
    config = default_config().with_overrides({"links.udp_targets": [], "links.tcp_listen": "",
                                              "links.serial": [], "links.tlog": False, **spec.config})
    state_dir = workdir / "state"
    harness = SitlHarness(seed=sample.seed, wind=sample.wind, current=sample.current, waves=sample.waves,
                          payload_kg=sample.payload_kg, noise_scale=sample.sensor_noise_scale,
                          full_stack=True, config=config, params=spec.params, state_dir=state_dir)
    out: dict[str, Any] = {}
    failures: list[str] = []
    texts: list[StatusText] = []
    async with harness as h:
        assert h.services is not None
        truth_path = workdir / "truth.csv"
        truth_log = TruthLog(h.boat, h.clock, truth_path)
        await truth_log.start()
        truth_task = asyncio.create_task(truth_log.run())
        try:
            h.ctx.bus.topic(STATUS_TEXT_TOPIC).add_listener(texts.append)
            vehicle = h.services.vehicle
            await h.run_for(settle_s)
            reason = vehicle.arm()
            if reason is not None or vehicle.home is None:
                raise RunFailed(f"arming refused: {reason}")
            home = (vehicle.home.lat_deg, vehicle.home.lon_deg)
            frame = LocalFrame(*home)
            from missions.common import WaterCurrent

            def drift() -> WaterCurrent | None:
                """The vehicle's estimate, as the script reads it (USV_CURRENT_ESTIMATE)."""
                est = vehicle.water_current
                return None if est is None else WaterCurrent(est.north_mps, est.east_mps, est.confidence)

            if spec.script == "rescue":  # the script waits so for a confident estimate
                from missions.rescue import CURRENT_WAIT_S, confident

                await h.run_until(lambda: confident(drift()), CURRENT_WAIT_S, POLL_S)
            nav = vehicle.nav()
            assert nav is not None
            plan = Plan(spec, frame, frame.to_ne(nav.lat_deg, nav.lon_deg), h.ctx.params.get("USV_TURN_RAD"),
                        drift())
            problem = h.services.mavlink.missions.install(MissionType.MISSION, plan.items)
            if problem is not None:
                raise RunFailed(f"mission refused: {problem.reason}")
            reached: dict[int, float] = {}
            vehicle.reached_listeners.append(lambda seq: _first(reached, seq, h.clock.now_s()))
            t0 = h.clock.now_s()
            reason = vehicle.set_mode(ModeNumber.AUTO)
            if reason is not None:
                raise RunFailed(f"AUTO refused: {reason}")
            failsafes = 0
            current_since: dict[int, float] = {}
            stop_reason = ""

            def done() -> bool:
                nonlocal failsafes, stop_reason
                now = h.clock.now_s()
                failsafes += vehicle.in_failsafe
                if vehicle.mission_state == MissionState.COMPLETE:
                    return True
                if vehicle.modes.current.number != ModeNumber.AUTO:
                    stop_reason = f"left AUTO for {vehicle.modes.current.name} at item {vehicle.current_seq}"
                    return True
                seq = vehicle.current_seq
                since = current_since.setdefault(seq, now)
                if seq in plan.limits_s and now - since > plan.limits_s[seq]:
                    stop_reason = f"item {seq} not done after {plan.limits_s[seq]:.0f} s"
                    return True
                return False

            await h.run_until(done, float(plan.args.timeout), POLL_S)
            t_end = h.clock.now_s()
            complete = vehicle.mission_state == MissionState.COMPLETE
            if not complete:
                failures.append(stop_reason or f"mission not complete after {plan.args.timeout:.0f} s")
            out.update(mission_complete=complete, mission_time_s=round(t_end - t0, 2),
                       failsafe_events=_failsafe_events(texts, failsafes))
            launches = list(h.launcher.events)
            records = [(r.bottle, r.distance_m) for r in h.services.payloads.samplelog.samples("complete")]
            lat_lon = h.boat.gpsins.lat_lon
            wp_radius_m = h.ctx.params.get("WP_RADIUS")
        finally:
            truth_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await truth_task
            await truth_log.stop()
        sim_s = h.clock.now_s()
    truth = nav_metrics.Truth(truth_path, home)
    out.update(_figures(plan, truth, t0, t_end, reached, failures, launches, records, lat_lon, frame))
    home_m = math.hypot(*truth.at(t_end))
    out["home_distance_m"] = round(home_m, 2)
    if complete and home_m > wp_radius_m:
        failures.append(f"ended {home_m:.1f} m from home (WP_RADIUS {wp_radius_m:g} m)")
    out.update(sim_time_s=round(sim_s, 2), success=not failures, failures="; ".join(failures),
               warnings=sum(t.severity <= Severity.WARNING for t in texts),
               messages=" | ".join(t.text for t in texts if t.severity <= Severity.WARNING)[:300])
    keep = truth.window(t0, t_end)[:: max(1, round(TRACK_PERIOD_S / 0.05))]
    out["track"] = {"north_m": np.round(truth.n[keep], 2).tolist(),
                    "east_m": np.round(truth.e[keep], 2).tolist(),
                    "marks_ne": [list(p) for p in _marks(plan)]}
    return out


def _first(times: dict[int, float], key: int, t_s: float) -> None:
    times.setdefault(key, t_s)


class RunFailed(Exception):
    """A step before the mission could start failed (the run's error)."""


def _failsafe_events(texts: list[StatusText], failsafe_polls: int) -> int:
    """STATUSTEXTs at CRITICAL or worse (failsafes announce themselves so), at least 1 if the
    vehicle was seen in failsafe."""
    critical = sum(t.severity <= Severity.CRITICAL for t in texts)
    return max(critical, 1 if failsafe_polls else 0)


def _marks(plan: Plan) -> list[tuple[float, float]]:
    if plan.script == "water_sampling":
        return list(plan.points_ne)
    return [tuple(plan.geometry["launch_ne"]), plan.casualty_ne]


def _figures(plan: Plan, truth: nav_metrics.Truth, t0: float, t_end: float, reached: dict[int, float],
             failures: list[str], launches: list[Any], records: list[tuple[int, float | None]], lat_lon: Any,
             frame: LocalFrame) -> dict[str, Any]:
    """Tracking figures from :mod:`benchmarks.nav_metrics`; success criteria of the script.  Samples
    are judged as the script judges them, on the vehicle's own sample records (``records``: bottle
    and the largest distance from the point while the pump ran, complete samples only); the truth's
    largest distance while pumping is ``fill_distance_max_m``."""
    args = plan.args
    out: dict[str, Any] = {}
    if plan.script == "water_sampling":
        n = len(plan.points_ne)
        smp = nav_metrics.sampling(truth, t0, t_end, plan.points_ne, {k: reached[k] for k in range(1, n + 1)
                                                                       if k in reached}, plan.radius_m, [])
        legs = nav_metrics.square(truth, t0, reached.get(n, t_end), plan.points_ne,
                                  {k: reached[k] for k in range(1, n + 1) if k in reached})
        within = [b for b, d in records if d is not None and d <= args.accept_radius]
        out.update(circle_error_max_m=smp["circle_error_max_m"], circle_error_rms_m=smp["circle_error_rms_m"],
                   fill_distance_max_m=_nan_to_none(smp["fill_distance_max_m"]), samples_taken=len(records),
                   samples_within_tol=len(within))
        if len(records) < n:
            failures.append(f"{len(records)} of {n} bottles filled")
        if len(within) < len(records):
            failures.append(f"{len(records) - len(within)} sample(s) taken beyond {args.accept_radius:g} m")
        for item in smp["items"]:
            if not item["circle_error_max_m"] <= args.max_track_error:
                failures.append(f"P{item['item']}: sampling-circle error {item['circle_error_max_m']} m "
                                f"(limit {args.max_track_error:g} m)")
    else:
        from missions import rescue

        geo = plan.geometry
        launch_seq = geo["seq"]["launch"]
        corners = [(geo["slow_ne"], geo["seq"]["slow"]), (geo["launch_ne"], launch_seq)]
        if geo["detour_ne"] is not None:  # the waypoint round the casualty, just before the slow-down one
            corners.insert(0, (geo["detour_ne"], geo["seq"]["slow"] - 1))
        times = {k: reached[seq] for k, (_, seq) in enumerate(corners, 1) if seq in reached}
        legs = nav_metrics.square(truth, t0, reached.get(launch_seq, t_end), [ne for ne, _ in corners], times)
        report: dict[str, Any] = {"launched": bool(launches)}
        if launches:
            ev = launches[0]
            at_ne = frame.to_ne(*lat_lon(ev.north_m, ev.east_m))
            report.update(rescue.launch_errors(at_ne, math.degrees(ev.bearing_rad), plan.casualty_ne,
                                               geo["launch_ne"]))
            out.update(launch_distance_error_m=report["distance_error_m"],
                       launch_bearing_error_deg=report["bearing_error_deg"])
        launch_failures = rescue.launch_failures(report, args)
        failures += launch_failures
        out.update(launches=len(launches), launches_within_tol=int(bool(launches) and not launch_failures))
        if launch_seq in reached:
            hold_end = reached.get(geo["seq"]["hold"], t_end)
            wp = nav_metrics.arrival(truth, reached[launch_seq], hold_end, geo["launch_ne"], args.launch_tol)
            out["loiter_error_max_m"] = _nan_to_none(wp["after_arrival_max_m"])
    out.update(path_deviation_max_m=legs["side_max_m"], mid_leg_cross_track_rms_m=_nan_to_none(
        legs["mid_leg_rms_m"]), mid_leg_cross_track_max_m=_nan_to_none(legs["mid_leg_max_m"]))
    return out


def run_sample(spec: CampaignSpec, sample: Sample) -> dict[str, Any]:
    """Worker entry for one SITL run (a temporary directory for the state and truth log)."""
    t_wall, t_cpu = time.perf_counter(), time.thread_time()
    with tempfile.TemporaryDirectory(prefix="usv-campaign-") as tmp:
        try:
            out = asyncio.run(fly(spec, sample, Path(tmp)))
        except RunFailed as exc:
            out = {"success": False, "failures": str(exc), "error": str(exc)}
    out["wall_s"] = round(time.perf_counter() - t_wall, 3)
    out["cpu_s"] = round(time.thread_time() - t_cpu, 3)
    return out
