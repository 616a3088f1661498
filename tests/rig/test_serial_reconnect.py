"""A USB radio that disappears and comes back at the same path is used again without a restart.

Real pseudo-terminals: the vehicle is configured with a stable symlink (as udev's
``/dev/serial/by-id/...``) to the slave end of a pty.  The test closes the pty (the radio is
unplugged: the vehicle's reads fail), then creates a new pty and points the symlink at it (the
radio re-enumerates under a new ``/dev/pts/N``).  Meanwhile the vehicle says the radio is NOT OPEN
(STATUSTEXT on its other links), then that it is back; MAVLink flows on the new pty.  The vehicle
runs on a paced simulation clock; the retry period is on that clock."""

from __future__ import annotations

import asyncio
import os
import tty
from pathlib import Path

from companion.clock import SimClock
from companion.link.dialect import mav, new_codec
from companion.link.manager import SERIAL_RETRY_S
from tests.mavlink.gcs import AsyncGcs, free_port
from tests.mavlink.helpers import paced, running_vehicle


def new_pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


def point(link: Path, target: str) -> None:
    """Re-point the symlink atomically (rename over it), as udev does."""
    tmp = link.with_suffix(".new")
    tmp.unlink(missing_ok=True)
    tmp.symlink_to(target)
    os.replace(tmp, link)


async def messages_on(master: int, timeout_s: float, want: str, text: str = "") -> object:
    codec = new_codec(255, 190)
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while loop.time() < deadline:
        try:
            data = os.read(master, 4096)
        except BlockingIOError:
            await asyncio.sleep(0.02)
            continue
        for msg in codec.parse_buffer(data) or []:
            if msg.get_type() == want and text in str(getattr(msg, "text", "")):
                return msg
    raise AssertionError(f"no {want} {text!r} on the serial link within {timeout_s} s")


async def test_vanished_radio_is_reopened_at_the_same_path(tmp_path: Path, state_dir: Path) -> None:
    radio = tmp_path / "usb-radio"
    master, slave, device = new_pty()
    point(radio, device)
    port = free_port()
    async with (AsyncGcs(port) as gcs, paced(SimClock()) as clock,
                running_vehicle(state_dir, [port], serial=[f"{radio}:57600"], clock=clock) as services):
        await gcs.connect(timeout_s=10.0)
        hb = await messages_on(master, 10.0, "HEARTBEAT")
        assert hb.type == mav.MAV_TYPE_SURFACE_BOAT  # type: ignore[attr-defined]
        serial = services.links.serial[0]
        assert serial.is_open and serial.open_count == 1

        lost = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "NOT OPEN" in m.text, 10.0))
        os.close(master)  # unplugged
        os.close(slave)
        assert "usb-radio lost" in (await lost).text  # the operator's other station is told
        assert not serial.is_open
        unplugged_s = clock.now_s()
        await asyncio.sleep(0.5)
        assert not serial.is_open and len(services.links.links) == 1  # only the UDP link is left

        back = asyncio.ensure_future(gcs.wait("STATUSTEXT", lambda m: "reconnected" in m.text, 15.0))
        master, slave, device2 = new_pty()  # re-enumerated under another /dev/pts number
        point(radio, device2)
        assert "usb-radio reconnected" in (await back).text
        assert serial.is_open and serial.open_count == 2
        assert clock.now_s() - unplugged_s <= 2 * SERIAL_RETRY_S + 1.0  # found on the next retries
        await messages_on(master, 10.0, "HEARTBEAT")  # MAVLink flows on the new pty, both ways:
        request = mav.MAVLink_param_request_read_message(1, 1, b"SYSID_THISMAV", -1)
        os.write(master, request.pack(new_codec(255, 190)))
        await messages_on(master, 5.0, "PARAM_VALUE")
        os.close(master)
        os.close(slave)
