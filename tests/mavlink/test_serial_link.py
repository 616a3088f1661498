"""Serial radio link on a real pseudo-terminal: MAVLink flows, and a vanished port is retried."""

from __future__ import annotations

import asyncio
import os
import tty
from pathlib import Path

from companion.link.dialect import mav, new_codec
from tests.mavlink.helpers import running_vehicle


async def _read_heartbeat(fd: int, timeout_s: float = 5.0) -> object:
    codec = new_codec(255, 190)
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while loop.time() < deadline:
        try:
            data = os.read(fd, 4096)
        except BlockingIOError:
            await asyncio.sleep(0.05)
            continue
        for msg in codec.parse_buffer(data) or []:
            if msg.get_type() == "HEARTBEAT":
                return msg
    raise AssertionError("no heartbeat on the serial link")


async def test_serial_link_on_pty_and_reconnect(state_dir: Path) -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    device = os.ttyname(slave)
    async with running_vehicle(state_dir, [], serial=[f"{device}:57600"]) as services:
        hb = await _read_heartbeat(master)
        assert hb.type == mav.MAV_TYPE_SURFACE_BOAT  # type: ignore[attr-defined]
        codec = new_codec(255, 190)
        os.write(master, mav.MAVLink_command_long_message(1, 1, 520, 0, 1, 0, 0, 0, 0, 0, 0).pack(codec))
        links = services.links
        # the port vanishes (radio unplugged): the link goes away, the vehicle keeps running
        os.close(master)
        os.close(slave)
        for _ in range(100):
            if not links.links:
                break
            await asyncio.sleep(0.05)
        assert not links.links
        port = links.serial[0]
        assert port.open_count == 1
        await asyncio.sleep(0.1)
        assert services.mavlink.links is links
