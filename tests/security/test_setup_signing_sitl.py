"""SETUP_SIGNING end to end: over a serial port (a real pseudo-terminal, trusted by default) it sets
the key; over TCP it is refused.  After a restart with ``require_signing`` the saved key is the
vehicle's: a station with it arms the boat, one without it does not."""

from __future__ import annotations

import os
import stat
import time
import tty
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import all as mavlink2

from companion.link.dialect import mav
from companion.link.signing import timestamp_now
from tests.mavlink.gcs import free_port
from tests.mavlink.sitl_process import sitl, write_config
from tests.security.station import Station

pytestmark = pytest.mark.integration

KEY = bytes(range(200, 232))
TCP_KEY = bytes(range(50, 82))


def setup_signing_frame(key: bytes) -> bytes:
    codec = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
    return bytes(codec.setup_signing_encode(1, 1, list(key), timestamp_now()).pack(codec))


def test_setup_signing_on_serial_then_required_after_restart(tmp_path: Path) -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    device = os.ttyname(slave)
    port = free_port()
    state = tmp_path / "state"
    cfg = write_config(tmp_path / "sitl.toml", state, [free_port()], port)
    cfg.write_text(cfg.read_text() + f'serial = ["{device}:57600"]\n')
    env = dict(os.environ, XDG_STATE_HOME=str(tmp_path / "xdg"), PYTHONUNBUFFERED="1")
    saved = state / "signing.key"
    try:
        with sitl(cfg, env, log=tmp_path / "first.log"), Station(port) as tcp:
            assert tcp.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1) is not None
            since = tcp.mark()
            tcp.send(tcp.mav.setup_signing_encode(1, 1, list(TCP_KEY), timestamp_now()))  # not trusted
            refused = tcp.wait("STATUSTEXT", lambda m: "untrusted link" in m.text, since=since)
            assert refused is not None and not saved.exists()
            since = tcp.mark()
            os.write(master, setup_signing_frame(KEY))  # the USB/serial port: trusted
            done = tcp.wait("STATUSTEXT", lambda m: "Signing key set" in m.text, since=since)
            assert done is not None and "serial:" in done.text
            hb = tcp.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1)
            assert hb is not None  # still received without a key, and now signed on every link:
            assert hb.get_header().incompat_flags & mavlink2.MAVLINK_IFLAG_SIGNED
        assert saved.read_text().strip() == KEY.hex() and stat.S_IMODE(saved.stat().st_mode) == 0o600

        cfg.write_text(cfg.read_text() + "[security]\nrequire_signing = true\n")
        with sitl(cfg, env, log=tmp_path / "second.log"):
            with Station(port) as unsigned:
                since = unsigned.mark()
                unsigned.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
                time.sleep(3.0)
                assert unsigned.messages("COMMAND_ACK", since) == []
                assert not unsigned.armed()
            with Station(port, key=KEY) as signed:
                for _ in range(20):
                    since = signed.mark()
                    signed.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
                    ack = signed.wait("COMMAND_ACK", since=since, timeout_s=3.0)
                    if ack is not None and ack.result == mav.MAV_RESULT_ACCEPTED:
                        break
                    time.sleep(0.5)
                assert signed.armed()
    finally:
        os.close(master)
        os.close(slave)
