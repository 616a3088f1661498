"""A MAVSDK-Python 4 ground station script for lossy links, run as its own process.

``python -m benchmarks.lossy_mavsdk --port Q [--items N] [--plan mission|rally] [--no-arm]``
connects with ``udpin://127.0.0.1:Q`` and, relying on MAVSDK's own timeouts and retries (each
call is repeated up to ``--attempts`` times when MAVSDK gives up, as a script would), sets two
parameters and reads them back, uploads an ``N``-item mission (item 0 the first waypoint, as
MAVSDK sends it) or ``N`` rally points with MissionRaw, downloads and compares them, then (unless
``--no-arm``) arms and disarms.  Prints one JSON object (per phase: completed, wall seconds, calls
needed, and why each failed call failed); exit status 0 when every phase completed.
"""

from __future__ import annotations

import argparse
import asyncio
import functools
import json
import math
import time
from collections.abc import Awaitable, Callable
from typing import Any

HOME_LAT_E7, HOME_LON_E7 = 417_700_000, 1_234_300_000


async def retried(call: Callable[[], Awaitable[Any]], attempts: int, timeout_s: float) -> tuple[Any, int]:
    """``call()`` until it succeeds, at most ``attempts`` times; the result and the calls needed.
    Raises RuntimeError naming why each failed call failed (MAVSDK's result, e.g. TIMEOUT)."""
    failures: list[str] = []
    for attempt in range(1, attempts + 1):
        try:
            return await asyncio.wait_for(call(), timeout_s), attempt
        except Exception as exc:  # MAVSDK's timeout or a refusal: a script tries again
            failures.append(f"{type(exc).__name__}: {str(exc).split(';')[0][:80]}")
    raise RuntimeError(f"failed after {attempts} calls: {failures}")


async def run(port: int, items: int, attempts: int, plan_type: str = "mission",
              arm: bool = True) -> dict[str, Any]:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.mission_raw import MissionItem

    out: dict[str, Any] = {}
    mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    await mav.add_any_connection(f"udpin://127.0.0.1:{port}")
    system = await mav.first_autopilot(60)
    out["connected"] = system is not None
    if system is None:
        return out
    param, mission, action = ParamAsync(system), MissionRawAsync(system), ActionAsync(system)
    telemetry = TelemetryAsync(system)

    rally = plan_type == "rally"
    command, mission_type = (5100, 2) if rally else (16, 0)  # NAV_RALLY_POINT in the RALLY plan
    plan = [MissionItem(i, 6, command, 1 if i == 0 and not rally else 0, 1, 0.0, 0.0 if rally else 2.0, 0.0,
                        0.0 if rally else math.nan, HOME_LAT_E7 + 1000 * (i % 5),
                        HOME_LON_E7 + 1000 * (i // 5), 0.0, mission_type)
            for i in range(items)]
    upload_call = ((lambda: mission.upload_rally_points(plan)) if rally
                   else (lambda: mission.upload_mission(plan)))
    download_call = mission.download_rallypoints if rally else mission.download_mission

    async def params() -> dict[str, Any]:
        calls = 0
        for name, value in (("WP_RADIUS", 2.75), ("LOIT_RADIUS", 3.25)):
            _, n = await retried(functools.partial(param.set_param_float, name, value), attempts, 20)
            got, m = await retried(functools.partial(param.get_param_float, name), attempts, 20)
            calls += n + m
            if not math.isclose(got, value, abs_tol=1e-4):
                return {"ok": False, "calls": calls}
        return {"ok": True, "calls": calls}

    async def upload() -> dict[str, Any]:
        _, calls = await retried(upload_call, attempts, 60)
        return {"ok": True, "calls": calls}

    async def download() -> dict[str, Any]:
        got, calls = await retried(download_call, attempts, 60)
        same = [(i.x, i.y) for i in got] == [(i.x, i.y) for i in plan]
        return {"ok": same, "calls": calls, "items": len(got)}

    async def arm_disarm() -> dict[str, Any]:
        _, a = await retried(action.arm, attempts, 20)
        async for armed in telemetry.subscribe_armed():
            if armed:
                break
        _, d = await retried(action.disarm, attempts, 20)
        return {"ok": True, "calls": a + d}

    phases = [("params", params), ("upload", upload), ("download", download)]
    if arm:
        phases.append(("arm", arm_disarm))
    for name, phase in phases:
        start = time.monotonic()
        try:
            result = await phase()
        except Exception as exc:
            result = {"ok": False, "error": repr(exc)}
        result["wall_s"] = round(time.monotonic() - start, 2)
        out[name] = result
    out["ok"] = all(out[name]["ok"] for name, _ in phases)
    mav.destroy()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--items", type=int, default=10)
    parser.add_argument("--attempts", type=int, default=5)
    parser.add_argument("--plan", choices=("mission", "rally"), default="mission")
    parser.add_argument("--no-arm", action="store_true")
    args = parser.parse_args(argv)
    t0 = time.monotonic()
    out = asyncio.run(run(args.port, args.items, args.attempts, args.plan, not args.no_arm))
    out["wall_s"] = round(time.monotonic() - t0, 2)
    print(json.dumps(out), flush=True)
    return 0 if out.get("ok") else 1


if __name__ == "__main__":
    raise SystemExit(main())
