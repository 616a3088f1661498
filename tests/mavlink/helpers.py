"""Test helpers for the MAVLink area: a plain context with a simulation clock, a vehicle on it,
nav samples, and the whole companion on a wall clock without hardware (fed by the test)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from pathlib import Path

from companion.app import Context
from companion.bus import Bus
from companion.clock import Clock, SimClock
from companion.config import default_config
from companion.control.system import ControlSystem
from companion.messages import NAV_TOPIC, FixType, NavState
from companion.mission.cursor import MissionCursor
from companion.mission.store import MissionStore
from companion.modes.base import Mode
from companion.modes.manager import MODE_CLASSES, ModeManager
from companion.param_table import all_param_defs
from companion.params import ParamStore
from companion.runtime import Services
from companion.vehicle import Vehicle, home_placeholder_profile

HOME_LAT_DEG = 41.77
HOME_LON_DEG = 123.43


def make_ctx(state_dir: Path | None = None, profile: str = "ardurover") -> Context:
    overrides: dict[str, object] = {"vehicle.profile": profile}
    if state_dir is not None:
        overrides["vehicle.state_dir"] = str(state_dir)
    config = default_config().with_overrides(overrides)
    params = ParamStore(all_param_defs(), None if state_dir is None else state_dir / "params.toml")
    return Context(config=config, clock=SimClock(start_unix_time_s=1.7e9), bus=Bus(), params=params)


def make_vehicle(ctx: Context, modes: list[type[Mode]] | None = None) -> Vehicle:
    """A vehicle on ``ctx`` with the given modes (default: all), no model (PID), no payloads."""
    mission = MissionCursor(MissionStore(), home_placeholder_profile(str(ctx.config["vehicle.profile"])))
    control = ControlSystem(ctx.params, ctx.clock, ctx.bus, None)
    return Vehicle(ctx, mission, ModeManager(modes or MODE_CLASSES), control)


def nav_sample(t_s: float, *, lat_deg: float = HOME_LAT_DEG, lon_deg: float = HOME_LON_DEG,
               fix: FixType = FixType.FIX_3D, valid: bool = True, heading_rad: float = 0.5,
               u_mps: float = 0.0) -> NavState:
    return NavState(t_s=t_s, lat_deg=lat_deg, lon_deg=lon_deg, alt_m=0.0, heading_rad=heading_rad,
                    roll_rad=0.01, pitch_rad=-0.02, vel_north_mps=u_mps, vel_east_mps=0.0, u_mps=u_mps,
                    v_mps=0.0, r_radps=0.0, fix_type=fix, position_valid=valid)


def publish_nav(ctx: Context, **kwargs: object) -> NavState:
    """A nav sample on the bus of a plain context (what the vehicle observes)."""
    nav = nav_sample(ctx.clock.now_s(), **kwargs)  # type: ignore[arg-type]
    ctx.bus.topic(NAV_TOPIC).publish(nav)
    return nav


def feed_nav(services: Services, **kwargs: object) -> NavState:
    """A nav sample through the running companion's pipeline, as the GPS-INS would deliver it."""
    nav = nav_sample(services.ctx.clock.now_s(), **kwargs)  # type: ignore[arg-type]
    services.pipeline.on_sample(nav)
    return nav


@contextlib.asynccontextmanager
async def running_vehicle(state_dir: Path, udp_ports: list[int], *, tcp_port: int | None = None,
                          profile: str = "ardurover", serial: list[str] | None = None,
                          clock: Clock | None = None) -> AsyncIterator[Services]:
    """The companion without GPS-INS or servo link, sending to ``udp_ports`` on loopback, on
    ``clock`` (default: the wall clock; a :class:`SimClock` moves only while :func:`paced` drives
    it); the test feeds navigation samples (:func:`feed_nav`, :func:`feeding_nav`)."""
    from companion.app import Application
    from companion.clock import WallClock
    from companion.runtime import build_companion, build_context

    config = default_config().with_overrides({
        "vehicle.profile": profile, "vehicle.state_dir": str(state_dir),
        "links.udp_targets": [f"127.0.0.1:{p}" for p in udp_ports],
        "links.tcp_listen": f"127.0.0.1:{tcp_port}" if tcp_port else "",
        "links.serial": serial or [],
    })
    services = build_companion(build_context(config, clock or WallClock()))
    services.estimator.warm_up()  # the first sample would stall the wall-clock test for seconds
    app = Application(services.in_start_order())
    task = asyncio.create_task(app.run(install_signal_handlers=False))
    try:
        while "hardware-io" not in app.started:
            if task.done():
                task.result()
            await asyncio.sleep(0.01)
        yield services
    finally:
        app.request_stop()
        await asyncio.wait_for(task, 5.0)


@contextlib.asynccontextmanager
async def paced(clock: SimClock, step_s: float = 0.01) -> AsyncIterator[SimClock]:
    """Advance ``clock`` by exactly ``step_s`` per ``step_s`` of wall time (never more: on a busy
    machine simulated time falls behind, it does not jump), so the vehicle's periods and rates are
    exact in its own time stamps while ground stations talk to it over real sockets."""

    async def pace() -> None:
        while True:
            await asyncio.sleep(step_s)
            clock.advance_to(clock.now_s() + step_s)

    pacer = asyncio.create_task(pace())
    try:
        yield clock
    finally:
        pacer.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await pacer


@contextlib.asynccontextmanager
async def feeding_nav(services: Services, period_s: float = 0.05) -> AsyncIterator[None]:
    """Feed a nav sample every ``period_s`` of wall time while the block runs (a live GPS-INS)."""

    async def feed() -> None:
        while True:
            feed_nav(services)
            await asyncio.sleep(period_s)

    feeder = asyncio.create_task(feed())
    try:
        yield
    finally:
        feeder.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await feeder
