"""MAVLink command latency and mission upload time while telemetry streams to three links.

Measures, on loopback UDP with the real link/command/mission services of the companion:

* COMMAND_LONG -> COMMAND_ACK round trip (p50/p99 in ms; goal p99 <= 5 ms);
* upload of a 500-item mission (MISSION_COUNT to MISSION_ACK, seconds; goal <= 2 s);

while the vehicle streams its telemetry to three ground stations, with ATTITUDE and
GLOBAL_POSITION_INT raised to 50 Hz on every link and navigation samples at 100 Hz.
"""

from __future__ import annotations

import asyncio
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.mavlink_gcs import AsyncGcs, free_port
from companion.app import Application
from companion.clock import WallClock
from companion.config import default_config
from companion.link.dialect import mav
from companion.messages import NavState
from companion.runtime import build_companion, build_context


def _nav(t_s: float) -> NavState:
    return NavState(t_s=t_s, lat_deg=41.77, lon_deg=123.43, alt_m=0.0, heading_rad=0.3, roll_rad=0.0,
                    pitch_rad=0.0, vel_north_mps=1.0, vel_east_mps=0.5, u_mps=1.1, v_mps=0.0, r_radps=0.0)


async def _upload(gcs: AsyncGcs, n: int) -> float:
    plan = [(41.77 + 1e-5 * (i % 50), 123.43 + 1e-5 * (i // 50)) for i in range(n + 1)]

    def item(seq: int) -> Any:
        lat, lon = plan[seq]
        return mav.MAVLink_mission_item_int_message(1, 1, seq, 6, 16, 0, 1, 0, 0, 0, 0, round(lat * 1e7),
                                                    round(lon * 1e7), 0.0, 0)

    done: asyncio.Future[Any] = asyncio.get_running_loop().create_future()

    def on_msg(m: Any) -> bool:
        if m.get_type() == "MISSION_REQUEST_INT":
            gcs.send(item(m.seq))
            return False
        return m.get_type() == "MISSION_ACK"

    t0 = time.perf_counter()
    waiter = asyncio.ensure_future(gcs.wait(("MISSION_REQUEST_INT", "MISSION_ACK"), on_msg, 30.0))
    await asyncio.sleep(0)
    gcs.send(mav.MAVLink_mission_count_message(1, 1, n + 1, 0))
    ack = await waiter
    elapsed = time.perf_counter() - t0
    done.cancel()
    if ack.type != 0:
        raise RuntimeError(f"mission upload refused: {ack.type}")
    return elapsed


async def _bench(quick: bool) -> dict[str, Any]:
    ports = [free_port() for _ in range(3)]
    with tempfile.TemporaryDirectory() as tmp:
        config = default_config().with_overrides({
            "vehicle.state_dir": str(Path(tmp)), "links.udp_targets": [f"127.0.0.1:{p}" for p in ports],
            "links.tcp_listen": "", "links.tlog": True})
        ctx = build_context(config, WallClock())
        services = build_companion(ctx)  # no GPS-INS link: the feed below stands in for it
        services.estimator.warm_up()  # load the compiled UKF step before the clock matters
        app = Application(services.in_start_order())
        task = asyncio.create_task(app.run(install_signal_handlers=False))

        async def nav_feed() -> None:
            while True:
                services.pipeline.on_sample(_nav(ctx.clock.now_s()))
                await asyncio.sleep(0.01)

        feeder = asyncio.create_task(nav_feed())
        try:
            async with AsyncGcs(ports[0]) as g0, AsyncGcs(ports[1]) as g1, AsyncGcs(ports[2]) as g2:
                for g in (g0, g1, g2):
                    await g.connect(10.0)
                    for msg_id in (mav.MAVLINK_MSG_ID_ATTITUDE, mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT):
                        await g.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 20_000)
                n = 200 if quick else 2000
                latencies_ms: list[float] = []
                for i in range(n):
                    t0 = time.perf_counter()
                    ack = await g0.command(mav.MAV_CMD_DO_CHANGE_SPEED, 1, 2.0 + (i % 3), -1)
                    latencies_ms.append((time.perf_counter() - t0) * 1000.0)
                    if ack.result != 0:
                        raise RuntimeError(f"command refused: {ack.result}")
                rx_before = sum(len(g.received) for g in (g1, g2))
                t_stream0 = time.perf_counter()
                upload_s = await _upload(g0, 100 if quick else 500)
                stream_rate = (sum(len(g.received) for g in (g1, g2)) - rx_before) / (
                    2 * (time.perf_counter() - t_stream0))
        finally:
            feeder.cancel()
            app.request_stop()
            await task
    latencies_ms.sort()
    return {
        "links": 3,
        "commands": n,
        "command_ack_latency_ms_p50": round(statistics.median(latencies_ms), 3),
        "command_ack_latency_ms_p99": round(latencies_ms[int(0.99 * (n - 1))], 3),
        "command_ack_latency_ms_max": round(latencies_ms[-1], 3),
        "mission_items": 100 if quick else 500,
        "mission_upload_s": round(upload_s, 3),
        "telemetry_msgs_per_s_per_link_during_upload": round(stream_rate, 1),
        "goal_p99_ms": 5.0,
        "goal_upload_500_s": 2.0,
    }


def run(quick: bool) -> dict[str, Any]:
    return asyncio.run(_bench(quick))
