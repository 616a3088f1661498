"""The rope launcher's shot counter survives a restart (it used to reset to USV_LNCH_SHOTS)."""

from __future__ import annotations

import asyncio
from pathlib import Path

from companion.payloads.launcher import LauncherState, RopeLauncher
from companion.payloads.samplelog import SampleLog

from .helpers import World, make_ctx


async def fire_once(world: World, launcher: RopeLauncher) -> None:
    assert launcher.arm() is None
    task = asyncio.ensure_future(launcher.fire())
    await world.advance(1.0)
    assert await task is None


async def test_shot_counter_survives_restart_and_reload_resets_it(tmp_path: Path) -> None:
    world = World(make_ctx(), tmp_path)
    world.ctx.params.set("USV_LNCH_SHOTS", 2)
    world.ready()
    launcher = RopeLauncher(world.ctx, world.outputs, world.log)
    assert launcher.shots_left == 2
    await fire_once(world, launcher)
    assert launcher.shots_left == 1
    world.log.close()

    # "restart": a new launcher on the same log and the same (saved) parameter value
    log = SampleLog(tmp_path / "samples.sqlite")
    again = World(make_ctx(), tmp_path)
    again.ctx.params.set("USV_LNCH_SHOTS", 2)
    relaunched = RopeLauncher(again.ctx, again.outputs, log)
    assert relaunched.shots_left == 1 and log.shots_left() == 1
    again.ready()
    await fire_once(again, relaunched)
    assert relaunched.shots_left == 0 and relaunched.state() == LauncherState.EMPTY
    assert len(log.launches()) == 2
    # a reload is a USV_LNCH_SHOTS set, even with the value the parameter already has
    again.ctx.params.set("USV_LNCH_SHOTS", 2)
    assert relaunched.shots_left == 2 and log.shots_left() == 2
