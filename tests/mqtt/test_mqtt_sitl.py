"""Issue 17 end to end: a real amqtt broker process, ``usv sitl --speedup 10 --mqtt URL`` and a
separate aiomqtt subscriber process (a dashboard), all on loopback.

One boat, one broker and one subscriber serve the module (start-up costs once):

* the telemetry test checks that every message on ``usv/usv1/#`` validates against its JSON
  Schema (``companion/mqtt/schemas.json``, the README's), that every state topic and ``online``
  arrive, that the position rate is ``USV_MQTT_POS_HZ`` in *simulated* time (the messages'
  ``t_s``), and that a dashboard connecting later gets the retained status at once;
* the commands test publishes three commands with amqtt's own client (another process): a wrong
  token is answered ``unauthorized``, a command outside this boat's allowlist ``denied``, an
  allowlisted one with the token ``accepted`` (the boat connects with a user name and password,
  commands on, a token file, allowlist HOLD and STOP_PUMP);
* the outage test flies a four-sample mission from a pymavlink ground station, stops the broker
  after the first sample record arrived, lets the other three samples be taken while it is away
  (the companion's memory is sampled meanwhile), restarts it on the same port and checks that
  every sample record of the sample log reached the subscriber exactly once.
"""

from __future__ import annotations

import itertools
import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from companion.guidance.geo import LocalFrame
from companion.mission.items import MissionItem
from companion.mqtt.topics import schema_name, schemas
from mavlink_dialect import UsvCmd
from tests.conftest import REPO_ROOT
from tests.mavlink.sitl_process import sitl
from tests.missions.pymavlink_gcs import CMD_ARM_DISARM, PymavlinkGcs

pytestmark = pytest.mark.integration
jsonschema = pytest.importorskip("jsonschema")

HOME = (41.77, 123.43)
"""``sim.home``'s default."""
SAMPLE_POINTS_NE = [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]
SAMPLE_ML = 50.0
MODE_AUTO = 10
TOKEN = "a-test-token-of-32-characters-ok"


def _free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Broker:
    """``amqtt`` as a separate process on 127.0.0.1:``port`` (anonymous, as a test broker)."""

    def __init__(self, tmp: Path, port: int) -> None:
        self.port = port
        self.config = tmp / "broker.yaml"
        self.config.write_text(
            f"listeners:\n  default:\n    type: tcp\n    bind: 127.0.0.1:{port}\nplugins:\n"
            "  amqtt.plugins.authentication.AnonymousAuthPlugin:\n    allow_anonymous: true\n")
        self.log = tmp / "broker.log"
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        amqtt = Path(sys.executable).with_name("amqtt")
        with open(self.log, "ab") as out:
            self.proc = subprocess.Popen([str(amqtt), "-c", str(self.config)], stdout=out,
                                         stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 20
        while True:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", self.port)) == 0:
                    return
            assert self.proc.poll() is None and time.monotonic() < deadline, self.log.read_text()
            time.sleep(0.05)

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self.proc = None


class Dashboard:
    """The subscriber process and what it wrote."""

    def __init__(self, port: int, out: Path) -> None:
        self.out = out
        self.proc = subprocess.Popen([sys.executable, "-m", "tests.mqtt.subscriber", str(port), str(out)],
                                     cwd=REPO_ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def messages(self) -> list[dict[str, Any]]:
        if not self.out.exists():
            return []
        lines = self.out.read_text(encoding="utf-8").splitlines()
        return [m for m in (json.loads(line) for line in lines if line.endswith("}")) if "topic" in m]

    def wait_for(self, what: str, cond: Any, timeout_s: float) -> list[dict[str, Any]]:
        deadline = time.monotonic() + timeout_s
        while True:
            msgs = self.messages()
            if cond(msgs):
                return msgs
            assert time.monotonic() < deadline, f"{what}: not within {timeout_s} s ({len(msgs)} messages)"
            time.sleep(0.1)

    def close(self) -> None:
        self.proc.terminate()
        self.proc.wait(10)


@dataclass
class Boat:
    broker: Broker
    dashboard: Dashboard
    sitl: subprocess.Popen[bytes]
    gcs_port: int
    state_dir: Path


@pytest.fixture(scope="module")
def boat(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Boat]:
    tmp = tmp_path_factory.mktemp("mqtt")
    port, gcs_port = _free_port(), _free_port(socket.SOCK_DGRAM)
    broker = Broker(tmp, port)
    broker.start()
    state_dir = tmp / "state"
    config = tmp / "boat.toml"
    secrets = {"password": tmp / "mqtt.pw", "token": tmp / "mqtt.token"}
    secrets["password"].write_text("boat-password\n")
    secrets["token"].write_text(TOKEN + "\n")
    for path in secrets.values():
        path.chmod(0o600)
    config.write_text(f'[vehicle]\nstate_dir = "{state_dir}"\n[links]\n'
                      f'udp_targets = ["127.0.0.1:{gcs_port}"]\ntcp_listen = ""\n'
                      '[mqtt]\nreconnect_max_s = 1.0\nusername = "boat"\n'
                      f'password_file = "{secrets["password"]}"\ncommands = true\n'
                      f'command_token_file = "{secrets["token"]}"\n'
                      'command_allowlist = ["HOLD", "STOP_PUMP"]\n'
                      '[params]\nFS_GCS_ENABLE = 0\n',  # heartbeats a loaded machine delays: no failsafe
                      encoding="utf-8")
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "XDG_STATE_HOME": str(tmp / "xdg")}
    dashboard = Dashboard(port, tmp / "dashboard.jsonl")
    try:
        with sitl(config, env, speedup=10.0, extra_args=["--mqtt", f"mqtt://127.0.0.1:{port}"]) as proc:
            yield Boat(broker, dashboard, proc, gcs_port, state_dir)
    finally:
        dashboard.close()
        broker.stop()


def _by_topic(msgs: list[dict[str, Any]], name: str) -> list[dict[str, Any]]:
    return [json.loads(m["payload"]) for m in msgs if m["topic"] == name]


def test_telemetry_topics_validate_against_their_schemas_at_their_rates(boat: Boat) -> None:
    msgs = boat.dashboard.wait_for("10 simulated seconds of positions",
                                   lambda ms: len(_by_topic(ms, "usv/usv1/position")) >= 21, 60)
    for name in ("position", "status", "link", "engine", "current", "launcher", "sampler", "online"):
        assert _by_topic(msgs, f"usv/usv1/{name}"), f"no {name} message"
    for m in msgs:
        key = schema_name(m["topic"])
        assert key is not None, m["topic"]
        jsonschema.validate(json.loads(m["payload"]), schemas()[key])
    positions = _by_topic(msgs, "usv/usv1/position")[-20:]  # live ones (the first may be retained)
    gaps = [b["t_s"] - a["t_s"] for a, b in itertools.pairwise(positions)]
    assert all(abs(g - 0.5) < 0.06 for g in gaps), gaps  # USV_MQTT_POS_HZ = 2 on the simulated clock
    statuses = _by_topic(msgs, "usv/usv1/status")
    assert statuses[-1]["mode"] == "HOLD" and statuses[-1]["armed"] is False
    late = Dashboard(boat.broker.port, boat.dashboard.out.with_name("late.jsonl"))
    try:
        got = late.wait_for("retained status",
                            lambda ms: any(m["topic"] == "usv/usv1/status" for m in ms), 20)
        first = next(m for m in got if m["topic"] == "usv/usv1/status")
        assert first["retain"] is True  # the last state, at once, for a dashboard that connects late
    finally:
        late.close()


def _command(port: int, command: dict[str, str]) -> None:
    """Publish one command with amqtt's own client (another process, another MQTT library)."""
    pub = Path(sys.executable).with_name("amqtt_pub")
    subprocess.run([str(pub), "--url", f"mqtt://127.0.0.1:{port}", "-t", "usv/usv1/cmd", "-q", "1",
                    "-m", json.dumps(command)], check=True, timeout=30, capture_output=True)


def test_commands_need_the_token_and_the_allowlist(boat: Boat) -> None:
    port = boat.broker.port
    _command(port, {"id": "c1", "command": "HOLD", "token": "wrong-token-wrong-token"})
    _command(port, {"id": "c2", "command": "RTL", "token": TOKEN})  # not in this boat's allowlist
    _command(port, {"id": "c3", "command": "HOLD", "token": TOKEN})
    msgs = boat.dashboard.wait_for("three replies",
                                   lambda ms: len(_by_topic(ms, "usv/usv1/cmd/reply")) >= 3, 30)
    replies = {r["id"]: r for r in _by_topic(msgs, "usv/usv1/cmd/reply")}
    for reply in replies.values():
        jsonschema.validate(reply, schemas()["cmd/reply"])
    assert replies["c1"]["result"] == "unauthorized"
    assert replies["c2"]["result"] == "denied"
    assert replies["c3"]["result"] == "accepted", replies["c3"]
    assert _by_topic(msgs, "usv/usv1/status")[-1]["mode"] == "HOLD"


def _final_samples(state_dir: Path) -> list[tuple[int, int, str]]:
    path = state_dir / "samples.sqlite"
    if not path.exists():
        return []
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        return [(int(i), int(b), str(s)) for i, b, s in
                db.execute("SELECT id, bottle, status FROM samples WHERE status != 'filling' ORDER BY id")]
    finally:
        db.close()


def _rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def _published_once(messages: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The records as the boat published them, one per record id, failing on a second publication.

    A dashboard that subscribes while a record is being published can get it more than once from
    the broker: live (retain 0) and as retained copies (retain 1; amqtt 0.12 stores the retained
    copy before its broadcast queue forwards the live one, and in 200 trials of subscribing while a
    record was published it delivered 1-5 retained copies).  Dashboards dedupe by record id (the
    README).  What only the boat can cause fails here: a record published twice (a second live
    copy), a record arriving on two connections (the broker was restarted empty, so a copy on the
    second connection of one delivered on the first was published again), or two contents.
    """
    by_topic: dict[str, list[dict[str, Any]]] = {}
    for m in messages:
        by_topic.setdefault(m["topic"], []).append(m)
    once = []
    for name, copies in by_topic.items():
        assert sum(not m["retain"] for m in copies) <= 1, f"{name} published more than once: {copies}"
        assert len({(m["conn"], m["payload"]) for m in copies}) == 1, f"{name} published again: {copies}"
        once.append(copies[0])
    return once


def test_broker_restart_during_a_four_sample_mission_every_sample_arrives_once(boat: Boat) -> None:
    frame = LocalFrame(*HOME)
    plan = [MissionItem.home(*HOME)]
    plan += [MissionItem.at(i + 1, UsvCmd.NAV_SAMPLE_HERE, *frame.to_lat_lon(n, e), param4=SAMPLE_ML)
             for i, (n, e) in enumerate(SAMPLE_POINTS_NE)]
    gcs = PymavlinkGcs(boat.gcs_port)
    try:
        gcs.wait(lambda: gcs.seen.position is not None, 30, "vehicle telemetry")
        assert gcs.upload(plan) == 0
        assert gcs.command(CMD_ARM_DISARM, 1) == 0
        assert gcs.set_mode(MODE_AUTO) == 0
        boat.dashboard.wait_for("the first sample record",
                                lambda ms: _by_topic(ms, "usv/usv1/sample/1"), 120)
        boat.broker.stop()
        rss_kb = [_rss_kb(boat.sitl.pid)]
        deadline = time.monotonic() + 120
        while len(_final_samples(boat.state_dir)) < 4:  # the other three while the broker is away
            assert time.monotonic() < deadline, (_final_samples(boat.state_dir), gcs.seen.mode, gcs.seen.t_s,
                                                 gcs.seen.texts[-8:])
            time.sleep(0.5)
            rss_kb.append(_rss_kb(boat.sitl.pid))
        away_s = gcs.seen.t_s
        boat.broker.start()
        expected = {f"usv/usv1/sample/{i}" for i, _, _ in _final_samples(boat.state_dir)}
        msgs = boat.dashboard.wait_for("every sample record",
                                       lambda ms: expected <= {m["topic"] for m in ms}, 60)
        time.sleep(1.0)  # anything sent twice would arrive now
        msgs = boat.dashboard.messages()
    finally:
        gcs.settle()
        gcs.close()
    records = _published_once(m for m in msgs if m["topic"].startswith("usv/usv1/sample/"))
    assert sorted(m["topic"] for m in records) == sorted(expected) and len(expected) == 4  # exactly once each
    rows = {i: (b, s) for i, b, s in _final_samples(boat.state_dir)}
    for m in records:
        doc = json.loads(m["payload"])
        jsonschema.validate(doc, schemas()["sample"])
        assert (doc["bottle"], doc["status"]) == rows[doc["id"]] and doc["record_id"] == f"sample-{doc['id']}"
        assert m["qos"] == 1
    assert sorted(json.loads(m["payload"])["bottle"] for m in records) == [1, 2, 3, 4]
    # memory stayed bounded while the broker was away (latest state wins, records wait on disk)
    assert max(rss_kb) - rss_kb[0] < 8_000, (rss_kb[0], max(rss_kb), away_s)
