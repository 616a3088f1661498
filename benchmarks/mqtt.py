"""What MQTT telemetry costs the 100 Hz control loop (issue 17): ``usv bench --only mqtt``.

The full companion (:class:`sim_bridge.sitl.SitlHarness`, every service) runs paced at real time
(``--speedup 1``: one 10 ms control tick per 10 ms of wall time, as on the boat) for
``sim_s`` seconds, without MQTT and publishing to a real amqtt broker (a separate process on
loopback) at the default rates, alternating, ``rounds`` times each, with the machine idle and
with two CPU-burning processes beside it (``loaded``).  Figures per condition:

* ``publish_cpu_us_per_tick``: the MQTT publication cost per control tick, = CPU microseconds per
  state publication (``publish_cpu_us_per_message``: build the document, encode, hand it to
  aiomqtt, written to the real broker; every state topic 300 times, after the run) x the
  publications per tick at the default rates (6.5 Hz in all: 0.065 per 10 ms tick);
  ``service_work_us_per_tick``: the wall time the running service spent building and encoding
  its documents, per tick (measured inside it);
* ``cpu_us_per_tick_median``: the process's CPU time per control tick (everything: simulator,
  control loop, MAVLink, MQTT), median of the rounds; ``process_cpu_difference_us_per_tick``
  (with minus without MQTT) is the MQTT cost seen from outside, too noisy on a shared machine to
  resolve a few microseconds (the runs vary by tens);
* ``missed_ticks``: GPS-INS samples handled more than one tick (10 ms) after their due time on
  the wall clock (the pacing origin is each run's least late sample), out of ``ticks`` (sums of
  the rounds); ``max_late_ms`` the worst lateness;
* ``mqtt_messages``: what the service published (state documents, records).
"""

from __future__ import annotations

import asyncio
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from companion.config import default_config
from companion.messages import NAV_TOPIC, NavState
from companion.mqtt.params import PARAMS
from companion.mqtt.service import MqttService, aiomqtt_client
from companion.mqtt.topics import StateTopic, encode, topic
from sim_bridge.sitl import SitlHarness

TICK_S = 0.01
LATE_S = 0.01
"""A sample handled later than this after its due time missed its tick."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class _Broker:
    """amqtt in its own process on loopback."""

    def __init__(self, tmp: Path) -> None:
        self.port = _free_port()
        config = tmp / "broker.yaml"
        config.write_text("listeners:\n  default:\n    type: tcp\n"
                          f"    bind: 127.0.0.1:{self.port}\nplugins:\n"
                          "  amqtt.plugins.authentication.AnonymousAuthPlugin:\n    allow_anonymous: true\n")
        amqtt = Path(sys.executable).with_name("amqtt")
        self.proc = subprocess.Popen([str(amqtt), "-c", str(config)], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 20
        while True:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", self.port)) == 0:
                    return
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("amqtt broker did not start")
            time.sleep(0.05)

    def close(self) -> None:
        self.proc.terminate()
        self.proc.wait(10)


async def _once(mqtt_url: str | None, sim_s: float, warmup_s: float) -> dict[str, Any]:
    overrides: dict[str, Any] = {"links.udp_targets": [], "links.tcp_listen": ""}
    if mqtt_url is not None:
        overrides["mqtt.url"] = mqtt_url
    config = default_config().with_overrides(overrides)
    async with SitlHarness(full_stack=True, config=config, speedup=1.0) as h:
        await h.run_for(warmup_s)
        stamps: list[tuple[float, float]] = []

        def on_nav(nav: NavState) -> None:
            stamps.append((time.perf_counter(), nav.t_s))

        remove = h.ctx.bus.topic(NAV_TOPIC).add_listener(on_nav)
        mqtt = h.services.mqtt if h.services is not None else None
        work0 = mqtt.stats.state_cost_us if mqtt is not None else 0.0
        sent0 = (mqtt.stats.state_published + mqtt.stats.records_published) if mqtt is not None else 0
        cpu0 = time.process_time()
        await h.run_for(sim_s)
        cpu_s = time.process_time() - cpu0
        remove()
        ticks = len(stamps)
        origin = min(wall - t for wall, t in stamps)
        late_s = [wall - t - origin for wall, t in stamps]
        result = {
            "ticks": ticks,
            "cpu_us_per_tick": round(1e6 * cpu_s / max(1, ticks), 1),
            "missed_ticks": sum(1 for x in late_s if x > LATE_S),
            "max_late_ms": round(1e3 * max(late_s), 2),
        }
        if mqtt is not None:
            result.update(await _publish_cost(mqtt))
            result["service_work_us_per_tick"] = round((mqtt.stats.state_cost_us - work0) / max(1, ticks), 2)
            result["mqtt_messages"] = mqtt.stats.state_published + mqtt.stats.records_published - sent0
            result["mqtt_connected"] = mqtt.connected
        return result


async def _publish_cost(mqtt: MqttService, rounds: int = 300) -> dict[str, Any]:
    """CPU microseconds per state publication (build, encode, hand to the client, QoS 0 to the
    real broker), every state topic ``rounds`` times through a second connection, and what that
    costs per control tick at the default rates."""
    client = aiomqtt_client(mqtt.settings)
    async with client:
        count = 0
        cpu0 = time.process_time()
        for _ in range(rounds):
            for which in StateTopic:
                document = mqtt.snapshot.document(which)
                if document is not None:
                    await client.publish(topic("bench", which.value), encode(document), qos=0, retain=False)
                    count += 1
        per_message_us = 1e6 * (time.process_time() - cpu0) / max(1, count)
    rate_hz = sum(param.default for param in PARAMS)
    return {"publish_cpu_us_per_message": round(per_message_us, 1),
            "messages_per_tick_at_default_rates": round(rate_hz * TICK_S, 3),
            "publish_cpu_us_per_tick": round(per_message_us * rate_hz * TICK_S, 2)}


def _burners(n: int) -> list[subprocess.Popen[bytes]]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def _condition(url: str, rounds: int, sim_s: float, warmup_s: float) -> dict[str, Any]:
    """``rounds`` runs without and with MQTT, alternating (slow drifts of a shared machine hit
    both alike); medians of the CPU figures, sums of the ticks."""
    runs: dict[str, list[dict[str, Any]]] = {"without_mqtt": [], "with_mqtt": []}
    for _ in range(rounds):
        runs["without_mqtt"].append(asyncio.run(_once(None, sim_s, warmup_s)))
        runs["with_mqtt"].append(asyncio.run(_once(url, sim_s, warmup_s)))
    summary: dict[str, Any] = {}
    for name, results in runs.items():
        summary[name] = {
            "ticks": sum(r["ticks"] for r in results),
            "missed_ticks": sum(r["missed_ticks"] for r in results),
            "max_late_ms": max(r["max_late_ms"] for r in results),
            "cpu_us_per_tick_median": round(statistics.median(r["cpu_us_per_tick"] for r in results), 1),
            "cpu_us_per_tick_runs": [r["cpu_us_per_tick"] for r in results],
        }
    with_mqtt = runs["with_mqtt"]
    summary["with_mqtt"].update({
        "publish_cpu_us_per_message": round(statistics.median(r["publish_cpu_us_per_message"]
                                                              for r in with_mqtt), 1),
        "service_work_us_per_tick": round(statistics.median(r["service_work_us_per_tick"]
                                                            for r in with_mqtt), 2),
        "mqtt_messages": sum(r["mqtt_messages"] for r in with_mqtt),
        "mqtt_connected": all(r["mqtt_connected"] for r in with_mqtt),
    })
    summary["publish_cpu_us_per_tick"] = round(statistics.median(r["publish_cpu_us_per_tick"]
                                                                 for r in with_mqtt), 2)
    summary["process_cpu_difference_us_per_tick"] = round(
        summary["with_mqtt"]["cpu_us_per_tick_median"] - summary["without_mqtt"]["cpu_us_per_tick_median"], 1)
    summary["missed_ticks_without_vs_with"] = [summary["without_mqtt"]["missed_ticks"],
                                               summary["with_mqtt"]["missed_ticks"]]
    return summary


def run(quick: bool) -> dict[str, Any]:
    rounds, sim_s, warmup_s = (1, 3.0, 2.0) if quick else (3, 10.0, 2.0)
    per_tick = round(sum(p.default for p in PARAMS) * TICK_S, 3)
    results: dict[str, Any] = {"rounds": rounds, "sim_seconds_per_run": sim_s, "tick_s": TICK_S,
                               "messages_per_tick_at_default_rates": per_tick}
    with tempfile.TemporaryDirectory(prefix="usv-bench-mqtt-") as tmp:
        broker = _Broker(Path(tmp))
        try:
            url = f"mqtt://127.0.0.1:{broker.port}"
            for condition, burners in (("idle", 0), ("loaded", 2)):
                procs = _burners(burners)
                try:
                    results[condition] = _condition(url, rounds, sim_s, warmup_s)
                finally:
                    for p in procs:
                        p.kill()
                        p.wait()
        finally:
            broker.close()
    return results
