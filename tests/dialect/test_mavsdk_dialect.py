"""MAVSDK-Python 4 (real native library) loads usv.xml with mavlink_direct, decodes the boat's
status messages and sends the boat's commands, against a pymavlink peer on loopback."""

from __future__ import annotations

import asyncio
import json
import socket
import threading

import pytest

import mavlink_dialect
from mavlink_dialect import UsvCmd

pytestmark = pytest.mark.integration


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Peer(threading.Thread):
    """A pymavlink vehicle using the generated module: heartbeats, one status message, ACKs."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        from pymavlink import mavutil

        mavlink_dialect.use_with_mavutil()
        self.conn = mavutil.mavlink_connection(
            f"udpout:127.0.0.1:{port}", source_system=1, source_component=1
        )
        self.stop = threading.Event()
        self.commands: list[tuple[int, float]] = []

    def run(self) -> None:
        usv = mavlink_dialect.usv
        while not self.stop.is_set():
            self.conn.mav.heartbeat_send(11, 3, 0, 0, 0)
            self.conn.mav.send(
                usv.MAVLink_usv_launcher_status_message(
                    5, 29.5, 20.0, 3.0, 0, 1, 2, 9000, usv.USV_LAUNCHER_STATE_ARMED, 0x1F, 2
                )
            )
            msg = self.conn.recv_match(type="COMMAND_LONG", blocking=True, timeout=0.1)
            if msg is not None and msg.command >= 31000:
                self.commands.append((msg.command, msg.param1))
                self.conn.mav.command_ack_send(
                    msg.command, 2, 0, 7, msg.get_srcSystem(), msg.get_srcComponent()
                )
        self.conn.close()


async def test_mavsdk_loads_dialect_decodes_status_and_sends_command() -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.mavlink_direct import MavlinkDirectAsync
    from mavsdk.plugins.mavlink_direct import MavlinkMessage

    port = _free_udp_port()
    mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    await mav.add_any_connection(f"udpin://127.0.0.1:{port}")
    peer = _Peer(port)
    peer.start()
    try:
        system = await mav.first_autopilot(10)
        direct = MavlinkDirectAsync(system)
        await direct.load_custom_xml(mavlink_dialect.mavsdk_xml())

        async def first_status() -> dict[str, object]:
            async for m in direct.subscribe_message("USV_LAUNCHER_STATUS"):
                return dict(json.loads(m.fields_json))
            raise AssertionError("no message")

        fields = await asyncio.wait_for(first_status(), 10)
        assert fields["cylinder_pressure_mpa"] == pytest.approx(29.5)
        assert fields["shots_left"] == 2 and fields["last_launch_heading"] == 9000

        cmd = {
            "target_system": 1,
            "target_component": 1,
            "command": int(UsvCmd.LAUNCHER_ARM),
            "confirmation": 0,
            **{f"param{i}": 0.0 for i in range(1, 8)},
        }
        cmd["param1"] = 1.0
        ack = await asyncio.wait_for(
            direct.send_command(
                MavlinkMessage(
                    message_name="COMMAND_LONG",
                    system_id=0,
                    component_id=0,
                    target_system_id=1,
                    target_component_id=1,
                    fields_json=json.dumps(cmd),
                )
            ),
            15,
        )
        ack_fields = json.loads(ack.fields_json)
        assert ack_fields["command"] == UsvCmd.LAUNCHER_ARM and ack_fields["result"] == 2
        assert (int(UsvCmd.LAUNCHER_ARM), 1.0) in peer.commands
    finally:
        peer.stop.set()
        peer.join(5)
