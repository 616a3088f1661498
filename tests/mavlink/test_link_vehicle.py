"""The MAVLink vehicle in process, seen from a pymavlink ground station on loopback UDP.

The vehicle runs on a simulation clock paced by the test (:func:`tests.mavlink.helpers.paced`),
so rates and periods are checked in the vehicle's own time stamps, whatever the machine's load.
"""

from __future__ import annotations

import asyncio
import contextlib
import subprocess
import sys
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from companion.clock import SimClock
from companion.link.dialect import mav
from companion.mavlink.commands import CommandRequest, CommandResult
from companion.runtime import Services
from tests.mavlink.gcs import AsyncGcs, free_port
from tests.mavlink.helpers import feed_nav, feeding_nav, paced
from tests.mavlink.helpers import running_vehicle as wall_clock_vehicle

PREARM = mav.MAV_SYS_STATUS_PREARM_CHECK
GPS = mav.MAV_SYS_STATUS_SENSOR_GPS


@contextlib.asynccontextmanager
async def running_vehicle(state_dir: Path, udp_ports: list[int]) -> AsyncIterator[Services]:
    """The companion on a paced simulation clock."""
    async with paced(SimClock()) as clock, wall_clock_vehicle(state_dir, udp_ports, clock=clock) as services:
        yield services


async def one_vehicle_second(gcs: AsyncGcs, msg_type: str) -> list[Any]:
    """The ``msg_type`` messages stamped (``time_boot_ms``, vehicle clock) within one second of
    vehicle time, starting with the next one received."""
    first = await gcs.wait(msg_type)
    end_ms = first.time_boot_ms + 1000
    start = next(i for i in range(len(gcs.received) - 1, -1, -1) if gcs.received[i] is first)
    await gcs.wait(msg_type, lambda m: m.time_boot_ms >= end_ms, timeout_s=10.0)
    return [m for m in gcs.received[start:] if m.get_type() == msg_type and m.time_boot_ms < end_ms]


async def test_heartbeat_identity_and_health(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]) as services:
        hb = await gcs.connect()
        assert (hb.type, hb.autopilot) == (mav.MAV_TYPE_SURFACE_BOAT, mav.MAV_AUTOPILOT_ARDUPILOTMEGA)
        assert hb.custom_mode == 4 and hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1
        st = await gcs.wait("SYS_STATUS")
        assert not st.onboard_control_sensors_health & PREARM  # no position yet: not armable
        banner = [m.text for m in gcs.received if m.get_type() == "STATUSTEXT"]
        assert any(t.startswith("usv-companion") for t in banner), banner

        async with feeding_nav(services):
            st = await gcs.wait("SYS_STATUS", lambda m: m.onboard_control_sensors_health & PREARM, 3.0)
            assert st.onboard_control_sensors_health & GPS
            gp = await gcs.wait("GLOBAL_POSITION_INT")
            assert abs(gp.lat / 1e7 - 41.77) < 1e-6
            home = await gcs.wait("HOME_POSITION", timeout_s=6.0)
            assert abs(home.latitude / 1e7 - 41.77) < 1e-6


async def test_boot_statustext_names_product(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]):
        await gcs.connect()
        ack = await gcs.command(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        ver = next(m for m in gcs.received if m.get_type() == "AUTOPILOT_VERSION")
        assert ver.capabilities & mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT
        assert bytes(ver.flight_custom_version).startswith(b"usvcomp")


async def test_arm_denied_with_reason_then_accepted(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]) as services:
        await gcs.connect()
        texts = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "PreArm" in m.text))
        ack = await gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        assert ack.result == mav.MAV_RESULT_DENIED
        assert "navigation" in (await texts).text
        feed_nav(services)
        ack = await gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        hb = await gcs.wait("HEARTBEAT", lambda m: m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
        assert hb.system_status == mav.MAV_STATE_ACTIVE
        ack = await gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
        assert ack.result == mav.MAV_RESULT_ACCEPTED and not services.vehicle.armed


async def test_modes_set_refuse_and_report(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]):
        await gcs.connect()
        ack = await gcs.command(mav.MAV_CMD_DO_SET_MODE, 1, 0)
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await gcs.wait("HEARTBEAT", lambda m: m.custom_mode == 0)
        reason = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "unknown mode" in m.text))
        ack = await gcs.command(mav.MAV_CMD_DO_SET_MODE, 1, 77)
        assert ack.result == mav.MAV_RESULT_DENIED
        await reason
        last_mode = asyncio.ensure_future(
            gcs.wait("AVAILABLE_MODES", lambda m: m.mode_index == m.number_modes))
        ack = await gcs.command(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_AVAILABLE_MODES)
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        await last_mode
        names = {m.mode_name for m in gcs.received if m.get_type() == "AVAILABLE_MODES"}
        assert {"MANUAL", "HOLD"} <= names
        cur = await gcs.wait("CURRENT_MODE", timeout_s=2.0)
        assert cur.custom_mode == 0


async def test_unknown_nan_and_garbage_never_kill(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]):
        await gcs.connect()
        assert (await gcs.command(42424)).result == mav.MAV_RESULT_UNSUPPORTED
        nan = float("nan")
        assert (await gcs.command(mav.MAV_CMD_DO_SET_MODE, 1, nan)).result == mav.MAV_RESULT_DENIED
        ack = await gcs.command(mav.MAV_CMD_DO_REPOSITION, -1, 1, 0, 0, nan, nan, 0)
        assert ack.result == mav.MAV_RESULT_DENIED
        ack = await gcs.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 99.0, -1)
        assert ack.result == mav.MAV_RESULT_DENIED
        gcs.send_raw(b"\xfd\xff\x00garbage" * 50)
        gcs.send_raw(bytes(range(256)))
        ack = await gcs.command(mav.MAV_CMD_REQUEST_MESSAGE, 1)
        assert ack.result == mav.MAV_RESULT_ACCEPTED  # still alive and answering


async def test_long_command_in_progress_then_result(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]) as services:
        clock = services.ctx.clock

        async def slow(cmd: CommandRequest) -> CommandResult:
            await clock.sleep(0.5)
            cmd.progress(50)
            await clock.sleep(0.1)
            return CommandResult.accepted()

        services.commands.register(31013, slow)
        await gcs.connect()
        start = len(gcs.received)
        ack = await gcs.command(31013)
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        progress = [m.progress for m in gcs.received[start:]
                    if m.get_type() == "COMMAND_ACK" and m.result == mav.MAV_RESULT_IN_PROGRESS]
        assert progress[:1] == [0] and 50 in progress


async def test_stream_rates_per_link(state_dir: Path) -> None:
    a, b = free_port(), free_port()
    async with AsyncGcs(a) as gcs_a, AsyncGcs(b) as gcs_b, running_vehicle(state_dir, [a, b]):
        await gcs_a.connect()
        await gcs_b.connect()
        system_time = mav.MAVLINK_MSG_ID_SYSTEM_TIME
        ack = await gcs_a.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, system_time, 50_000)  # 20 Hz
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        ack = await gcs_b.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, system_time, -1)  # off on link b
        assert ack.result == mav.MAV_RESULT_ACCEPTED
        nb = len(gcs_b.received)
        assert 19 <= len(await one_vehicle_second(gcs_a, "SYSTEM_TIME")) <= 21
        assert gcs_b.count("SYSTEM_TIME", nb) == 0
        gcs_b.send(mav.MAVLink_request_data_stream_message(1, 1, 11, 10, 1))  # VFR_HUD group at 10 Hz
        ack = await gcs_b.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 999, 1000)
        assert ack.result == mav.MAV_RESULT_DENIED


async def test_tlog_readable_by_mavlogdump(state_dir: Path) -> None:
    port = free_port()
    async with AsyncGcs(port) as gcs, running_vehicle(state_dir, [port]):
        await gcs.connect()
        await gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    logs = sorted((state_dir / "logs").glob("*.tlog"))
    assert logs, "no tlog written"
    out = subprocess.run([sys.executable, "-m", "pymavlink.tools.mavlogdump", "--types",
                          "HEARTBEAT,COMMAND_LONG,COMMAND_ACK", str(logs[0])],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "HEARTBEAT" in out.stdout and "COMMAND_LONG" in out.stdout and "COMMAND_ACK" in out.stdout
