"""Repeats over a lossy link change nothing twice: a command repeated within the window (a
duplicated frame, a retry after a lost ACK, with or without a new ``confirmation``) is answered
with its first COMMAND_ACK and not executed again; a mission upload whose MISSION_ACK was lost is
acknowledged again when the ground station resends the last item.

The vehicle runs on a paced simulation clock (:func:`tests.mavlink.helpers.paced`); the window is
measured on it."""

from __future__ import annotations

from pathlib import Path

from companion.clock import SimClock
from companion.link.dialect import mav
from companion.mavlink.command_history import REPEAT_WINDOW_S
from companion.mavlink.commands import MAV_RESULT, CommandRequest, CommandResult
from tests.mavlink.gcs import AsyncGcs, free_port
from tests.mavlink.helpers import feed_nav, paced, running_vehicle
from tests.mavlink.test_params_missions import square_plan, upload

TOGGLE = 31050  # a test command on the vehicle's own registry: flips a switch each time it runs


def command(cmd: int, param1: float, confirmation: int = 0) -> object:
    return mav.MAVLink_command_long_message(1, 1, cmd, confirmation, param1, 0, 0, 0, 0, 0, 0)


async def test_repeated_command_is_acked_again_not_run_again(state_dir: Path) -> None:
    port = free_port()
    runs: list[float] = []

    async def toggle(cmd: CommandRequest) -> CommandResult:
        if cmd.param1 < 0:
            runs.append(cmd.param1)
            return CommandResult.denied("toggle: negative")
        runs.append(cmd.param1)
        return CommandResult.accepted()

    async with (AsyncGcs(port) as gcs, paced(SimClock()) as clock,
                running_vehicle(state_dir, [port], clock=clock) as services):
        services.commands.register(TOGGLE, toggle, name="TEST_TOGGLE")
        await gcs.connect(timeout_s=10.0)
        frame = command(TOGGLE, 1.0).pack(gcs.codec)  # type: ignore[attr-defined]
        gcs.send_raw(frame)
        first = await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)
        gcs.send_raw(frame)  # the link duplicated the frame
        dup = await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)
        gcs.send(command(TOGGLE, 1.0, confirmation=1))  # the station retried: its ACK was lost
        retry = await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)
        gcs.send(command(TOGGLE, 1.0))  # a simple script retries with confirmation 0
        naive = await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)
        assert [a.result for a in (first, dup, retry, naive)] == [MAV_RESULT.ACCEPTED] * 4
        assert runs == [1.0]  # executed once
        texts = [m.text for m in gcs.received if m.get_type() == "STATUSTEXT" and "repeated" in m.text]
        assert len(texts) == 1 and f"{TOGGLE}" in texts[0]  # the operator is told, once
        gcs.send(command(TOGGLE, 2.0))  # other parameters: a new command
        assert (await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)).result == MAV_RESULT.ACCEPTED
        assert runs == [1.0, 2.0]
        for _ in range(2):  # a refused command changed nothing: its retry is judged again
            gcs.send(command(TOGGLE, -1.0))
            assert (await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)).result == MAV_RESULT.DENIED
        assert runs == [1.0, 2.0, -1.0, -1.0]
        gcs.send(command(TOGGLE, 2.0))
        await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)
        assert runs == [1.0, 2.0, -1.0, -1.0, 2.0]  # the last accepted was 2.0 before the refusals
        start_s = clock.now_s()
        while clock.now_s() < start_s + REPEAT_WINDOW_S + 0.2:  # the window, on the vehicle's clock
            await gcs.wait("HEARTBEAT", timeout_s=5.0)
        gcs.send(command(TOGGLE, 2.0))  # after the window: the operator means it again
        await gcs.wait("COMMAND_ACK", lambda m: m.command == TOGGLE)
        assert runs == [1.0, 2.0, -1.0, -1.0, 2.0, 2.0]


async def test_lost_mission_ack_is_sent_again_for_the_repeated_last_item(state_dir: Path) -> None:
    port = free_port()
    plan = square_plan(3)
    async with (AsyncGcs(port) as gcs, paced(SimClock()) as clock,
                running_vehicle(state_dir, [port], clock=clock) as services):
        await gcs.connect(timeout_s=10.0)
        feed_nav(services)
        assert (await upload(gcs, plan)).type == mav.MAV_MISSION_ACCEPTED
        last = plan[-1]
        gcs.send(mav.MAVLink_mission_item_int_message(1, 1, last.seq, last.frame, last.command, 0, 1,
                                                      0, 0, 0, 0, last.x, last.y, last.z, 0))
        again = await gcs.wait("MISSION_ACK")
        assert again.type == mav.MAV_MISSION_ACCEPTED
        assert len(services.vehicle.missions.items(0)) == len(plan)  # stored once, unchanged


async def test_a_repeat_after_the_vehicle_state_changed_is_run_again(state_dir: Path) -> None:
    """Set HOLD, something else (here the vehicle itself) switches to MANUAL, the station sets HOLD
    again within the window: the vehicle's state is no longer what the first command left, so the
    second one is executed, not answered from the cache."""
    port = free_port()
    set_hold = mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
    async with (AsyncGcs(port) as gcs, paced(SimClock()) as clock,
                running_vehicle(state_dir, [port], clock=clock) as services):
        await gcs.connect(timeout_s=10.0)
        assert services.vehicle.set_mode(0) is None  # MANUAL
        gcs.send(set_hold)
        assert (await gcs.wait("COMMAND_ACK")).result == MAV_RESULT.ACCEPTED
        assert services.vehicle.modes.current.number == 4
        assert services.vehicle.set_mode(0) is None  # e.g. the RC selector: back to MANUAL
        gcs.send(set_hold)
        assert (await gcs.wait("COMMAND_ACK")).result == MAV_RESULT.ACCEPTED
        assert services.vehicle.modes.current.number == 4  # executed again
        gcs.send(set_hold)  # a plain repeat (state unchanged): cached, and harmless
        assert (await gcs.wait("COMMAND_ACK")).result == MAV_RESULT.ACCEPTED
        assert services.mavlink.commands.history.repeats_answered == 1
