"""MAVLink 2 encode/parse throughput of the messages the vehicle streams (pymavlink)."""

from __future__ import annotations

import time
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2


def _sample_messages(mav: mavlink2.MAVLink) -> list[Any]:
    m = mavlink2
    return [
        m.MAVLink_heartbeat_message(m.MAV_TYPE_SURFACE_BOAT, m.MAV_AUTOPILOT_ARDUPILOTMEGA, 129, 10,
                                    m.MAV_STATE_ACTIVE, 3),
        m.MAVLink_sys_status_message(0x1000_0027, 0x1000_0027, 0x1000_0027, 120, 12600, -1, 80, 0, 0, 0, 0,
                                     0, 0),
        m.MAVLink_gps_raw_int_message(123456789, 3, 417700000, 1234300000, 1000, 80, 120, 500, 9000, 14),
        m.MAVLink_global_position_int_message(12345, 417700000, 1234300000, 1000, 0, 300, 20, 0, 9000),
        m.MAVLink_attitude_message(12345, 0.01, -0.02, 1.57, 0.001, 0.002, 0.1),
        m.MAVLink_vfr_hud_message(5.0, 5.1, 90, 30, 0.0, 0.0),
        m.MAVLink_servo_output_raw_message(12345, 0, 1500, 1300, 1900, 1100, 1000, 1000, 1500, 1500),
        m.MAVLink_nav_controller_output_message(0.0, 0.0, 90, 92, 45, 0.0, 0.0, 0.12),
    ]


def run(quick: bool) -> dict[str, Any]:
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    msgs = _sample_messages(mav)
    rounds = 300 if quick else 5000
    t0 = time.perf_counter()
    frames: list[bytes] = []
    for _ in range(rounds):
        for msg in msgs:
            frames.append(msg.pack(mav))
    encode_s = time.perf_counter() - t0
    stream = b"".join(frames)
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True
    t0 = time.perf_counter()
    parsed = parser.parse_buffer(stream) or []
    parse_s = time.perf_counter() - t0
    n = len(frames)
    if len(parsed) != n:
        raise RuntimeError(f"parsed {len(parsed)} of {n} frames")
    return {
        "messages": [m.get_type() for m in msgs],
        "frames": n,
        "encode_msgs_per_s": round(n / encode_s),
        "parse_msgs_per_s": round(n / parse_s),
        "bytes_per_frame_mean": round(len(stream) / n, 1),
    }
