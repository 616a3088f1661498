"""``usv bench --only lossy_link``: the highest packet loss at which mission uploads still complete.

One real ``usv sitl`` (real time) with two UDP links, each behind a
:class:`~benchmarks.lossy_link.LossyProxy`; for each loss rate (the same in both directions, plus
5 % duplicates, 5 % reordering and 10-30 ms delay) a pymavlink script
(:mod:`benchmarks.lossy_gcs`: its own 0.4 s retries, 40 attempts per message) and a MAVSDK-Python
script (:mod:`benchmarks.lossy_mavsdk`: MAVSDK's retries, the upload call repeated up to 5 times)
upload a 20-item mission and download it again, one after the other, each in its own process.
``max_loss_upload_completes`` is the highest rate of the sweep at which both clients' uploads
completed (and at every lower rate too); the same per client, and for downloads.

JSON: per rate and client whether upload and download completed, wall seconds and how many
messages/calls it took; datagrams dropped by the proxies; the figure above.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from benchmarks.fuzz_target import free_port, usv_command
from benchmarks.lossy_link import Impairment, LossyProxy

RATES = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)
RATES_QUICK = (0.3,)
ITEMS, ITEMS_QUICK = 20, 5
CLIENT_TIMEOUT_S = 240.0
CLIENTS = ("pymavlink", "mavsdk")


def _client(module: str, port: int, args: list[str]) -> dict[str, Any]:
    try:
        proc = subprocess.run([sys.executable, "-m", module, "--port", str(port), *args],
                              capture_output=True, text=True, timeout=CLIENT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return {"ok": False, "error": f"no result within {CLIENT_TIMEOUT_S:.0f} s"}
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    return json.loads(lines[-1]) if lines else {"ok": False, "error": proc.stderr[-500:]}


def _summary(result: dict[str, Any]) -> dict[str, Any]:
    up, down = result.get("upload", {}), result.get("download", {})
    return {"upload_ok": bool(up.get("ok")), "download_ok": bool(down.get("ok")),
            "upload_wall_s": up.get("wall_s"), "download_wall_s": down.get("wall_s"),
            "upload_sent": up.get("sent", up.get("calls")),
            "error": str(result.get("error", up.get("error")) or "")[:160] or None}


def run(quick: bool) -> dict[str, Any]:
    rates = RATES_QUICK if quick else RATES
    items = ITEMS_QUICK if quick else ITEMS
    vehicle_ports = [free_port(socket.SOCK_DGRAM) for _ in range(2)]
    client_ports = [free_port(socket.SOCK_DGRAM) for _ in range(2)]
    t0 = time.perf_counter()
    per_rate: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="usv-lossy-") as tmp:
        config = Path(tmp) / "sitl.toml"
        targets = ", ".join(f'"127.0.0.1:{p}"' for p in vehicle_ports)
        config.write_text(f'[vehicle]\nstate_dir = "{tmp}/state"\n[links]\nudp_targets = [{targets}]\n'
                          'tcp_listen = ""\n', encoding="utf-8")
        proxies = [LossyProxy(v, c, Impairment(loss=0.0), seed=i + 1).start()
                   for i, (v, c) in enumerate(zip(vehicle_ports, client_ports, strict=True))]
        log = open(Path(tmp) / "sitl.log", "wb")  # noqa: SIM115 - closed below
        proc = subprocess.Popen([*usv_command(), "sitl", "-c", str(config), "--realtime"], stdout=log,
                                stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        try:
            for rate in rates:
                for proxy in proxies:
                    proxy.impairment = Impairment(loss=rate)
                pym = _client("benchmarks.lossy_gcs", client_ports[0],
                              ["--items", str(items), "--params", "0", "--retry", "0.4"])
                sdk = _client("benchmarks.lossy_mavsdk", client_ports[1],
                              ["--items", str(items), "--no-arm", "--attempts", "5"])
                per_rate[f"{rate:.2f}"] = {"pymavlink": _summary(pym), "mavsdk": _summary(sdk)}
        finally:
            proc.send_signal(2)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
            log.close()
            for proxy in proxies:
                proxy.stop()
    def highest(client: str | None, key: str = "upload_ok") -> float | None:
        """The highest rate up to which (every lower rate too) the client(s) completed ``key``."""
        best = None
        for rate in rates:
            runs = per_rate[f"{rate:.2f}"]
            if not all(r[key] for name, r in runs.items() if client in (None, name)):
                break
            best = rate
        return best

    return {"items": items, "impairment": "loss each way + 5 % duplicated + 5 % reordered + 10-30 ms delay",
            "by_loss_rate": per_rate, "max_loss_upload_completes": highest(None),
            "max_loss_upload_completes_by_client": {c: highest(c) for c in CLIENTS},
            "max_loss_download_completes_by_client": {c: highest(c, "download_ok") for c in CLIENTS},
            "datagrams_dropped": [p.stats.as_dict() for p in proxies],
            "sweep_wall_s": round(time.perf_counter() - t0, 1)}
