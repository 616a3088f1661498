"""Rope launcher interlocks (chapter 4.1): fires only when every condition holds, with a reason otherwise."""

from __future__ import annotations

import pytest

from companion.messages import ControlSource
from companion.payloads.launcher import Interlock, LauncherState, RopeLauncher

from .helpers import World, make_ctx


@pytest.fixture
def world(tmp_path) -> World:
    return World(make_ctx(), tmp_path)


def _launcher(world: World) -> RopeLauncher:
    return RopeLauncher(world.ctx, world.outputs, world.log)


def _fired(world: World) -> bool:
    return any(c.launcher_trigger for c in world.commands)


async def test_arm_then_fire_pulses_trigger_and_logs_launch(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    assert launcher.arm() is None and launcher.state() == LauncherState.ARMED
    assert launcher.interlocks() == Interlock(31)
    import asyncio

    task = asyncio.ensure_future(launcher.fire(mission_seq=None))
    await world.advance(0.1)
    assert world.outputs.current.launcher_trigger and world.outputs.current.trigger_pulse_us == 1900
    await world.advance(1.0)
    assert await task is None
    assert not world.outputs.current.launcher_trigger and world.outputs.current.trigger_pulse_us == 1100
    on = [c.t_s for c in world.commands if c.launcher_trigger]
    off_after = [c.t_s for c in world.commands if not c.launcher_trigger and c.t_s > on[0]]
    assert off_after[0] - on[0] == pytest.approx(world.ctx.params.get("USV_LNCH_PULSE_S"), abs=0.06)
    launches = world.log.launches()
    assert len(launches) == 1
    assert launches[0].heading_deg == pytest.approx(28.65, abs=0.01)  # 0.5 rad
    assert launches[0].lat_deg == pytest.approx(world.lat) and launches[0].pressure_mpa == pytest.approx(30.0)
    assert launcher.shots_left == 0 and launcher.state() == LauncherState.EMPTY
    assert await launcher.fire() == "launcher: no shot left"


async def test_fire_without_arming_is_refused(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    assert await launcher.fire() == "launcher: not armed (send ARM first)"
    assert not _fired(world) and world.log.launches() == []


async def test_fire_after_window_expired_is_refused(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    assert launcher.arm(window_s=5.0) is None
    await world.advance(4.0)
    assert launcher.arm_time_left_s() == pytest.approx(1.0, abs=0.06)
    await world.advance(1.5)
    assert await launcher.fire() == "launcher: arm window expired"
    assert await launcher.fire() == "launcher: not armed (send ARM first)"
    assert not _fired(world)


async def test_low_pressure_refuses_arm_and_fire(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    assert launcher.arm() is None
    world.pressure_mpa = 12.0
    await world.advance(0.1)
    assert await launcher.fire() == "launcher: pressure low 12.0<20.0 MPa"
    assert launcher.arm() == "launcher: pressure low 12.0<20.0 MPa"
    assert not _fired(world)


async def test_stale_pressure_counts_as_unknown(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    world.clock.advance_to(10.0)  # no sensor publication for 10 s
    assert launcher.arm() == "launcher: cylinder pressure unknown"


async def test_rc_control_refuses_and_makes_safe(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    assert launcher.arm() is None
    world.set_source(ControlSource.RC)
    assert launcher.state() == LauncherState.SAFE  # giving control to RC disarms the launcher
    assert await launcher.fire() == "launcher: RC has control (selector)"
    world.set_source(ControlSource.COMPANION)
    assert await launcher.fire() == "launcher: not armed (send ARM first)"
    assert not _fired(world)


async def test_vehicle_disarmed_refuses_and_makes_safe(world: World) -> None:
    world.ready()
    launcher = _launcher(world)
    assert launcher.arm() is None
    world.set_armed(False)
    assert launcher.state() == LauncherState.SAFE
    assert await launcher.fire() == "launcher: vehicle not armed"
    assert launcher.arm() == "launcher: vehicle not armed"
    assert not _fired(world)


async def test_unknown_selector_refuses(world: World) -> None:
    world.set_armed(True)
    world.publish_sensors()
    assert _launcher(world).arm() == "launcher: selector state unknown"


async def test_reload_by_parameter(world: World) -> None:
    world.ready()
    world.ctx.params.set("USV_LNCH_SHOTS", 0)
    launcher = _launcher(world)
    assert launcher.arm() == "launcher: no shot left"
    world.ctx.params.set("USV_LNCH_SHOTS", 2)
    assert launcher.arm() is None
