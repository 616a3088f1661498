"""The payload MAVLink command handlers through the vehicle's command registry (no link),
registered from the payload registry of the built-in payloads."""

from __future__ import annotations

import asyncio
import dataclasses
import math

import pytest

from companion.mavlink.commands import MAV_RESULT, CommandRegistry, CommandRequest
from companion.messages import ControlSource
from companion.payloads.registry import PayloadRegistry, built_in_payloads
from mavlink_dialect import UsvCmd, usv

from .helpers import World, make_ctx


@pytest.fixture
def world(tmp_path) -> World:
    ctx = make_ctx()
    state = {"vehicle.state_dir": str(tmp_path / "state")}
    ctx = dataclasses.replace(ctx, config=ctx.config.with_overrides(state))
    w = World(ctx, tmp_path)
    w.registry = CommandRegistry()  # type: ignore[attr-defined]
    w.service = PayloadRegistry(ctx, built_in_payloads())  # type: ignore[attr-defined]
    w.service.register_commands(w.registry)  # type: ignore[attr-defined]
    w.outputs = w.service.outputs  # type: ignore[attr-defined]
    return w


def _status(world: World, msg_id: int, time_boot_ms: int):
    status = next(s for s in world.service.status_messages if s.msg_id == msg_id)  # type: ignore[attr-defined]
    return status.build(time_boot_ms)


def _cmd(command: int, *params: float, progress: list[int] | None = None) -> CommandRequest:
    p = (list(params) + [0.0] * 7)[:7]
    return CommandRequest(
        command=int(command),
        params=tuple(p),  # type: ignore[arg-type]
        progress_cb=(progress.append if progress is not None else None),
    )


async def _run(world: World, cmd: CommandRequest, seconds: float = 1.0):
    spec = world.registry.get(cmd.command)
    assert spec is not None
    assert not cmd.nan_params(spec.required_params)
    task = asyncio.ensure_future(spec.handler(cmd))
    await world.advance(seconds)
    assert task.done()
    return task.result()


async def test_arm_fire_sequence_and_status_messages(world: World) -> None:
    world.ready()
    assert (await _run(world, _cmd(UsvCmd.LAUNCHER_FIRE))).result == MAV_RESULT.DENIED
    res = await _run(world, _cmd(UsvCmd.LAUNCHER_ARM, 1))
    assert res.result == MAV_RESULT.ACCEPTED and "ARMED" in res.reason
    msg = _status(world, usv.MAVLINK_MSG_ID_USV_LAUNCHER_STATUS, 1000)
    assert msg.state == usv.USV_LAUNCHER_STATE_ARMED and msg.interlocks == 0x1F and msg.shots_left == 1
    res = await _run(world, _cmd(UsvCmd.LAUNCHER_FIRE))
    assert res.result == MAV_RESULT.ACCEPTED and res.reason.startswith("launcher: FIRED")
    msg = _status(world, usv.MAVLINK_MSG_ID_USV_LAUNCHER_STATUS, 2000)
    assert msg.state == usv.USV_LAUNCHER_STATE_EMPTY and msg.last_launch_time_unix_usec > 0
    assert msg.last_launch_heading == round(math.degrees(0.5) * 100)
    msg.pack(usv.MAVLink(None))


async def test_denials_carry_the_interlock(world: World) -> None:
    world.ready()
    world.set_source(ControlSource.RC)
    res = await _run(world, _cmd(UsvCmd.LAUNCHER_ARM, 1))
    assert res.result == MAV_RESULT.DENIED and res.reason == "launcher: RC has control (selector)"
    res = await _run(world, _cmd(UsvCmd.LAUNCHER_ARM, 3))
    assert res.result == MAV_RESULT.DENIED
    assert world.registry.get(UsvCmd.LAUNCHER_ARM).required_params == (1,)  # type: ignore[union-attr]


async def test_sample_command_reports_progress_then_result(world: World) -> None:
    world.publish_sensors()
    progress: list[int] = []
    res = await _run(world, _cmd(UsvCmd.SAMPLE, 0, 5.0, progress=progress), seconds=7.0)
    assert res.result == MAV_RESULT.ACCEPTED and "bottle 1 full" in res.reason
    assert len(progress) >= 3 and progress == sorted(progress) and progress[-1] < 100
    msg = _status(world, usv.MAVLINK_MSG_ID_USV_SAMPLER_STATUS, 0)
    assert list(msg.bottle_state) == [usv.USV_BOTTLE_STATE_FULL, 0, 0, 0] and msg.last_sample_bottle == 1


async def test_pump_stop_cancels_running_sample(world: World) -> None:
    world.publish_sensors()
    spec = world.registry.get(UsvCmd.SAMPLE)
    assert spec is not None
    task = asyncio.ensure_future(spec.handler(_cmd(UsvCmd.SAMPLE, 2, 30.0)))
    await world.advance(2.0)
    assert world.outputs.current.pump_on
    res = await _run(world, _cmd(UsvCmd.PUMP_STOP))
    assert res.result == MAV_RESULT.ACCEPTED and "aborted" in res.reason
    await world.advance(1.5)
    assert task.result().result == MAV_RESULT.CANCELLED
    assert not world.outputs.current.pump_on
    res = await _run(world, _cmd(UsvCmd.SAMPLE, 2))
    assert res.result == MAV_RESULT.DENIED and "bottle 2 failed" in res.reason
    assert (await _run(world, _cmd(UsvCmd.SAMPLER_RESET, 2))).result == MAV_RESULT.ACCEPTED
    await world.service.stop()  # type: ignore[attr-defined]
