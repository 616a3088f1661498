"""The water sampler: one pump, four bottles (chapter section 4.2).

A sample opens the valve of one bottle, runs the pump until the requested volume or fill
time is reached (or the bottle is full), then stops the pump and closes the valve.  Every
step is bounded by ``USV_SMPL_TMO_S``; a sample that does not finish in time, or is stopped
by the operator, leaves its bottle FAILED (not reused until reset).  A full bottle, or no
empty bottle left, refuses the request with a reason.

With an acceptance radius (mission item "sample here": 2.5 m in the chapter) the pump only
runs while the boat is inside the circle and pauses outside it, so all the water comes
from inside the circle: it stops :data:`PUMP_LEAD_S` before the boat, at its radial speed, would
cross the circle (the stop reaches the pump a few tenths of a second later).  The sample log
records the boat's position when the pump started and ``distance_m``, the LARGEST distance from
the commanded point while the pump ran.

The volume comes from the bottle level sensor when the payload sentence reports it (the rise
of the level since the sample started), else from ``USV_SMPL_FLOW`` times the pumping time.
"""

from __future__ import annotations

import asyncio
import enum
import logging
import math
from dataclasses import dataclass, field

from companion.app import Context
from companion.guidance.geo import LocalFrame, distance_m
from companion.messages import (
    BOTTLE_COUNT,
    NAV_TOPIC,
    PAYLOAD_SENSORS_TOPIC,
    STATUS_TEXT_TOPIC,
    NavState,
    PayloadSensors,
    Severity,
    StatusText,
)
from companion.payloads.samplelog import SampleLog, SampleRecord
from companion.payloads.topics import PayloadOutputs

log = logging.getLogger(__name__)

TICK_S = 0.1
"""Sampler control period (clock time)."""
PUMP_LEAD_S = 0.6
"""The pump stops when the boat, at its radial speed, would leave the acceptance circle within this
time: one sampler tick plus the navigation sample's age plus the pump command's way to the payload
(measured on ``usv bench nav``: without it the pump ran up to 6 cm outside the 2.5 m circle, with
0.4 s up to 1 cm)."""
PUMP_MARGIN_M = 0.1
"""... and it also stops this close to the circle (GPS noise on the distance, the pump's own
latency): with 0.05 m the pump stopped 5.4 cm inside the 2.5 m circle at worst on the bench."""
SENSOR_STALE_S = 3.0
LEFT_IN_BOTTLE_ML = 20.0
"""A bottle marked empty that reads more than this when its sample starts is announced (a
STATUSTEXT warning; the crew may not have emptied it, or the sensor reads an offset).  Either way
the sample's volume is what the level rose by: a reading left from the last mission does not count
as this sample's water."""


class BottleState(enum.IntEnum):
    """USV_BOTTLE_STATE of the dialect."""

    EMPTY = 0
    FILLING = 1
    FULL = 2
    FAILED = 3


@dataclass(frozen=True, slots=True)
class SampleRequest:
    """What to sample: bottle 1-4 or 0 = next empty; time or volume; optional commanded point."""

    bottle: int = 0
    fill_s: float | None = None
    volume_ml: float | None = None
    mission_seq: int | None = None
    target_lat_deg: float | None = None
    target_lon_deg: float | None = None
    accept_radius_m: float | None = None


@dataclass
class SampleJob:
    """Handle of a running sample: progress in percent and a future with the final record."""

    bottle: int
    request: SampleRequest
    sample_id: int = 0
    progress_pct: int = 0
    status: str = "filling"
    reason: str = ""
    done: asyncio.Future[SampleRecord | None] = field(
        default_factory=lambda: asyncio.get_running_loop().create_future()
    )
    task: asyncio.Task[None] | None = None

    async def wait(self) -> SampleRecord | None:
        """The final log record (status complete, failed or aborted)."""
        return await asyncio.shield(self.done)


class WaterSampler:
    """Pump/valve sequencing with timeouts, bottle bookkeeping and the durable sample log."""

    def __init__(self, ctx: Context, outputs: PayloadOutputs, samplelog: SampleLog) -> None:
        self.ctx = ctx
        self.outputs = outputs
        self.samplelog = samplelog
        saved = samplelog.bottles()
        self.bottle_state = [
            BottleState(s) if s != BottleState.FILLING else BottleState.FAILED for s, _ in saved
        ]
        self.bottle_volume_ml = [v for _, v in saved]
        self.active: SampleJob | None = None
        self.last_sample: SampleRecord | None = None
        if done := samplelog.samples("complete"):
            self.last_sample = done[-1]
        outputs.set(pump_on=False, valve_bottle=0)

    # -- queries --------------------------------------------------------------------------------
    def sensors(self) -> PayloadSensors | None:
        reading = self.ctx.bus.topic(PAYLOAD_SENSORS_TOPIC).latest()
        if reading is None or self.ctx.clock.now_s() - reading.t_s > SENSOR_STALE_S:
            return None
        return reading

    def sensed_volume_ml(self, bottle: int) -> float | None:
        reading = self.sensors()
        if reading is None or len(reading.bottle_volume_ml) < bottle:
            return None
        v = reading.bottle_volume_ml[bottle - 1]
        return v if math.isfinite(v) else None

    def pump_on(self) -> bool:
        return self.outputs.current.pump_on

    def choose_bottle(self, requested: int) -> int | str:
        """The bottle to fill (1-4) or the refusal reason."""
        if not 0 <= requested <= BOTTLE_COUNT:
            return f"sampler: bottle {requested} invalid (0-{BOTTLE_COUNT})"
        if requested == 0:
            for i, state in enumerate(self.bottle_state):
                if state == BottleState.EMPTY:
                    return i + 1
            return "sampler: no empty bottle left"
        state = self.bottle_state[requested - 1]
        if state == BottleState.FULL:
            return f"sampler: bottle {requested} full"
        if state != BottleState.EMPTY:
            return f"sampler: bottle {requested} {state.name.lower()}, reset it first"
        return requested

    # -- commands ---------------------------------------------------------------------------------
    def start(self, request: SampleRequest) -> SampleJob | str:
        """Start a sample; returns its job, or the refusal reason (nothing changes then)."""
        if self.active is not None:
            return f"sampler: busy filling bottle {self.active.bottle}"
        for name, value in (("fill time", request.fill_s), ("volume", request.volume_ml)):
            if value is not None and (not math.isfinite(value) or value < 0):
                return f"sampler: invalid {name} {value}"
        chosen = self.choose_bottle(request.bottle)
        if isinstance(chosen, str):
            return chosen
        capacity = self.ctx.params.get("USV_SMPL_BTL_ML")
        sensed = self.sensed_volume_ml(chosen)
        if sensed is not None and sensed >= 0.9 * capacity:
            self._set_bottle(chosen, BottleState.FULL, sensed)
            return f"sampler: bottle {chosen} full (sensor)"
        if request.volume_ml and request.volume_ml > capacity:
            return f"sampler: volume {request.volume_ml:.0f} mL > bottle {capacity:.0f} mL"
        job = SampleJob(bottle=chosen, request=request)
        nav = self._nav()
        job.sample_id = self.samplelog.begin_sample(
            t_unix_s=self.ctx.clock.unix_time_s(),
            bottle=chosen,
            lat_deg=nav.lat_deg if nav else None,
            lon_deg=nav.lon_deg if nav else None,
            mission_seq=request.mission_seq,
            target_lat_deg=request.target_lat_deg,
            target_lon_deg=request.target_lon_deg,
            distance_m=self._distance(nav, request),
            bottle_state=BottleState.FILLING,
        )
        self.bottle_state[chosen - 1] = BottleState.FILLING
        self.active = job
        job.task = asyncio.get_running_loop().create_task(self._run(job), name=f"sample-bottle-{chosen}")
        return job

    def stop_pump(self, reason: str = "stopped by operator") -> bool:
        """Stop the pump now; a running sample is aborted. Returns whether a sample was running."""
        self.outputs.set(pump_on=False, valve_bottle=0)
        job = self.active
        if job is None or job.task is None:
            return False
        job.status, job.reason = "aborted", f"sampler: {reason}"
        job.task.cancel()
        return True

    def reset(self, bottle: int = 0) -> str | None:
        """The crew emptied bottle ``bottle`` (0 = all): mark EMPTY. Refused while filling it."""
        if not 0 <= bottle <= BOTTLE_COUNT:
            return f"sampler: bottle {bottle} invalid (0-{BOTTLE_COUNT})"
        targets = range(1, BOTTLE_COUNT + 1) if bottle == 0 else [bottle]
        if self.active is not None and self.active.bottle in targets:
            return f"sampler: bottle {self.active.bottle} is filling"
        for b in targets:
            self._set_bottle(b, BottleState.EMPTY, 0.0)
        return None

    # -- internals --------------------------------------------------------------------------------
    def _nav(self) -> NavState | None:
        nav = self.ctx.bus.topic(NAV_TOPIC).latest()
        return nav if nav is not None and nav.position_valid else None

    @staticmethod
    def _distance(nav: NavState | None, request: SampleRequest) -> float | None:
        if nav is None or request.target_lat_deg is None or request.target_lon_deg is None:
            return None
        return distance_m(nav.lat_deg, nav.lon_deg, request.target_lat_deg, request.target_lon_deg)

    @staticmethod
    def _radial_speed(nav: NavState, request: SampleRequest) -> float:
        """How fast the boat moves away from the commanded point (m/s, negative: closing)."""
        if request.target_lat_deg is None or request.target_lon_deg is None:
            return 0.0
        n, e = LocalFrame(request.target_lat_deg, request.target_lon_deg).to_ne(nav.lat_deg, nav.lon_deg)
        d = math.hypot(n, e)
        return (n * nav.vel_north_mps + e * nav.vel_east_mps) / d if d > 1e-6 else 0.0

    def _set_bottle(self, bottle: int, state: BottleState, volume_ml: float) -> None:
        self.bottle_state[bottle - 1] = state
        self.bottle_volume_ml[bottle - 1] = volume_ml
        self.samplelog.set_bottle(bottle, int(state), volume_ml)

    async def _run(self, job: SampleJob) -> None:
        params = self.ctx.params
        req = job.request
        clock = self.ctx.clock
        by_volume = bool(req.volume_ml)
        fill_s = req.fill_s if req.fill_s else params.get("USV_SMPL_FILL_S")
        target_ml = req.volume_ml if by_volume else None
        capacity = params.get("USV_SMPL_BTL_ML")
        flow = params.get("USV_SMPL_FLOW")
        timeout_s = params.get("USV_SMPL_TMO_S")
        start_s = clock.now_s()
        start_sensed = self.sensed_volume_ml(job.bottle)
        if start_sensed is not None and start_sensed > LEFT_IN_BOTTLE_ML:
            self.ctx.bus.topic(STATUS_TEXT_TOPIC).publish(StatusText(
                t_s=clock.now_s(), severity=Severity.WARNING,
                text=f"sampler: bottle {job.bottle} not empty ({start_sensed:.0f} mL)"))
        pumped_s = 0.0
        volume = 0.0
        max_dist: float | None = None
        try:
            self.outputs.set(valve_bottle=job.bottle, pump_on=False)
            while True:
                nav = self._nav()
                dist = self._distance(nav, req)
                inside = req.accept_radius_m is None or (
                    dist is not None and nav is not None
                    and dist + PUMP_LEAD_S * max(0.0, self._radial_speed(nav, req)) + PUMP_MARGIN_M
                    <= req.accept_radius_m)
                if inside and dist is not None:
                    max_dist = dist if max_dist is None else max(max_dist, dist)
                if inside != self.outputs.current.pump_on:
                    self.outputs.set(pump_on=inside)
                await clock.sleep(TICK_S)
                if inside:
                    pumped_s += TICK_S
                sensed = self.sensed_volume_ml(job.bottle)
                if sensed is not None and start_sensed is not None:
                    volume = max(0.0, sensed - start_sensed)  # what this sample added
                    brimful = sensed >= capacity
                else:
                    volume = min(capacity, flow * pumped_s)
                    brimful = volume >= capacity
                if target_ml is not None:
                    job.progress_pct = min(99, int(100 * volume / target_ml))
                    finished = volume >= target_ml
                else:
                    job.progress_pct = min(99, int(100 * pumped_s / fill_s))
                    finished = pumped_s >= fill_s - 1e-9
                if finished or brimful:
                    job.status = "complete"
                    break
                if clock.now_s() - start_s >= timeout_s:
                    job.status, job.reason = "failed", f"sampler: timeout after {timeout_s:.0f} s"
                    break
        except asyncio.CancelledError:
            if job.status == "filling":
                job.status, job.reason = "aborted", "sampler: cancelled"
        finally:
            self.outputs.set(pump_on=False, valve_bottle=0)
            self._finish(job, volume, clock.now_s() - start_s, max_dist)

    def _finish(self, job: SampleJob, volume_ml: float, duration_s: float, max_dist: float | None) -> None:
        state = BottleState.FULL if job.status == "complete" else BottleState.FAILED
        self.bottle_state[job.bottle - 1] = state
        self.bottle_volume_ml[job.bottle - 1] = volume_ml
        record: SampleRecord | None = None
        try:
            self.samplelog.finish_sample(
                job.sample_id,
                status=job.status,
                volume_ml=volume_ml,
                duration_s=duration_s,
                distance_m=max_dist,
                bottle=job.bottle,
                bottle_state=int(state),
            )
            record = next((r for r in self.samplelog.samples() if r.id == job.sample_id), None)
        except Exception:  # the log must not take the sampler down; the pump is already off
            log.exception("sample log write failed")
        if job.status == "complete" and record is not None:
            self.last_sample = record
        job.progress_pct = 100 if job.status == "complete" else job.progress_pct
        self.active = None
        log.info("sample bottle %d %s %.0f mL (%s)", job.bottle, job.status, volume_ml, job.reason)
        if not job.done.done():
            job.done.set_result(record)
