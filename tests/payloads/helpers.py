"""A plain companion context on a simulated clock, for unit tests of one payload."""

from __future__ import annotations

import asyncio
from pathlib import Path

from companion.app import Context
from companion.bus import Bus
from companion.clock import SimClock
from companion.config import default_config
from companion.messages import (
    NAV_TOPIC,
    PAYLOAD_CMD_TOPIC,
    PAYLOAD_SENSORS_TOPIC,
    RC_IN_TOPIC,
    VEHICLE_STATUS_TOPIC,
    ControlSource,
    NavState,
    PayloadCommand,
    PayloadSensors,
    RcInput,
    VehicleStatus,
)
from companion.params import ParamStore
from companion.payloads.launcher import PARAMS as LAUNCHER_PARAMS
from companion.payloads.samplelog import SampleLog
from companion.payloads.sampler import PARAMS as SAMPLER_PARAMS
from companion.payloads.topics import PayloadOutputs

LAT0, LON0 = 41.77, 123.43


def make_ctx() -> Context:
    clock = SimClock(start_unix_time_s=1_700_000_000.0)
    params = ParamStore(LAUNCHER_PARAMS + SAMPLER_PARAMS)
    return Context(config=default_config(), clock=clock, bus=Bus(), params=params)


class World:
    """Publishes what the boat's sensors would: nav, RC selector, vehicle arming, payload sensors."""

    def __init__(self, ctx: Context, tmp: Path) -> None:
        self.ctx = ctx
        self.clock: SimClock = ctx.clock  # type: ignore[assignment]
        self.outputs = PayloadOutputs(ctx.bus, ctx.clock)
        self.log = SampleLog(tmp / "samples.sqlite")
        self.pressure_mpa = 30.0
        self.bottles_ml = [0.0] * 4
        self.lat, self.lon, self.heading_rad = LAT0, LON0, 0.5
        self.vel_ne_mps = (0.0, 0.0)
        self.commands: list[PayloadCommand] = []
        ctx.bus.topic(PAYLOAD_CMD_TOPIC).add_listener(self.commands.append)

    def set_armed(self, armed: bool) -> None:
        self.ctx.bus.topic(VEHICLE_STATUS_TOPIC).publish(
            VehicleStatus(t_s=self.clock.now_s(), armed=armed, mode=0)
        )

    def set_source(self, source: ControlSource) -> None:
        self.ctx.bus.topic(RC_IN_TOPIC).publish(
            RcInput(t_s=self.clock.now_s(), channels_us=(), source=source)
        )

    def publish_sensors(self) -> None:
        t = self.clock.now_s()
        self.ctx.bus.topic(PAYLOAD_SENSORS_TOPIC).publish(
            PayloadSensors(
                t_s=t, cylinder_pressure_mpa=self.pressure_mpa, bottle_volume_ml=tuple(self.bottles_ml)
            )
        )
        self.ctx.bus.topic(NAV_TOPIC).publish(
            NavState(
                t_s=t,
                lat_deg=self.lat,
                lon_deg=self.lon,
                alt_m=0.0,
                heading_rad=self.heading_rad,
                roll_rad=0.0,
                pitch_rad=0.0,
                vel_north_mps=self.vel_ne_mps[0],
                vel_east_mps=self.vel_ne_mps[1],
                u_mps=0.0,
                v_mps=0.0,
                r_radps=0.0,
            )
        )

    async def advance(self, seconds: float, step_s: float = 0.05) -> None:
        """Advance simulated time, publishing sensors every step and letting tasks run."""
        end = self.clock.now_s() + seconds
        while self.clock.now_s() < end - 1e-9:
            self.clock.advance_to(min(end, self.clock.now_s() + step_s))
            self.publish_sensors()
            for _ in range(3):
                await asyncio.sleep(0)

    def ready(self) -> None:
        self.set_armed(True)
        self.set_source(ControlSource.COMPANION)
        self.publish_sensors()
