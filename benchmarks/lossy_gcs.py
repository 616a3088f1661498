"""A pymavlink ground station script for lossy links, run as its own process.

``python -m benchmarks.lossy_gcs --port Q [--items N] [--params K] [--fire]`` listens on UDP
``Q`` (``udpin``), waits for the vehicle and then, retrying every request whose answer does not
come within ``--retry`` seconds as a ground station does on a bad radio:

1. sets ``K`` parameters (PARAM_SET until the PARAM_VALUE echo has the new value);
2. uploads an ``N``-item mission (MISSION_COUNT, answering every MISSION_REQUEST_INT, resending
   its last message on silence) and waits for MISSION_ACK;
3. downloads it again and compares every item;
4. with ``--fire``: arms the boat, arms the rope launcher and sends FIRE until it is acknowledged,
   reading the launcher's shot counter (USV_LAUNCHER_STATUS) before and after, then disarms.

It prints one JSON object: per phase whether it completed, the wall seconds it took, how many
messages it sent, the results received and (``--fire``) the shots before and after.  Exit
status 0 when every phase completed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import threading
import time
from typing import Any

LAUNCHER_ARM, LAUNCHER_FIRE = 31010, 31011
ARM_DISARM = 400
HOME_LAT_E7, HOME_LON_E7 = 417_700_000, 1_234_300_000
PARAMS = ("WP_SPEED", "CRUISE_SPEED", "FS_GCS_TIMEOUT", "WP_RADIUS", "LOIT_RADIUS")
"""Set in this order (the MAVSDK script sets WP_RADIUS and LOIT_RADIUS: run both at once with
at most 3 here)."""


class Station:
    def __init__(self, port: int, retry_s: float) -> None:
        os.environ["MAVLINK20"] = "1"
        from pymavlink import mavutil

        import companion.link.dialect  # noqa: F401 - adds the boat's messages (USV_LAUNCHER_STATUS) to "all"

        self.conn: Any = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255,
                                                    source_component=190, dialect="all")
        self.retry_s = retry_s
        self.sent = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.shots_left: int | None = None

    def send(self, msg: Any) -> None:
        with self._lock:
            self.conn.mav.send(msg)
        self.sent += 1

    def beat(self) -> None:
        while not self._stop.wait(1.0):
            self.send(self.conn.mav.heartbeat_encode(6, 8, 0, 0, 4))

    def recv(self, types: tuple[str, ...], cond: Any, timeout_s: float) -> Any | None:
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            msg = self.conn.recv_match(blocking=True, timeout=left)
            if msg is None:
                continue
            if msg.get_type() == "USV_LAUNCHER_STATUS":
                self.shots_left = int(msg.shots_left)
            if msg.get_type() in types and cond(msg):
                return msg
        return None

    def request(self, msg: Any, types: tuple[str, ...], cond: Any, attempts: int) -> Any | None:
        """Send ``msg`` until an answer matching ``cond`` arrives (at most ``attempts`` times)."""
        for _ in range(attempts):
            self.send(msg)
            answer = self.recv(types, cond, self.retry_s)
            if answer is not None:
                return answer
        return None


def plan(items: int) -> list[tuple[int, int, int, int]]:
    """(seq, command, lat e7, lon e7): item 0 the home placeholder (as QGC/MAVProxy write it)."""
    return [(i, 16, HOME_LAT_E7 + 1000 * (i % 7), HOME_LON_E7 + 1000 * (i // 7)) for i in range(items + 1)]


def item_msg(st: Station, seq: int, lat: int, lon: int) -> Any:
    frame = 0 if seq == 0 else 6  # home in GLOBAL, the rest relative-alt INT, as QGC writes them
    return st.conn.mav.mission_item_int_encode(1, 1, seq, frame, 16, 0, 1, 0, 0, 0, 0, lat, lon, 0, 0)


def set_params(st: Station, count: int, attempts: int) -> dict[str, Any]:
    done = 0
    for i, name in enumerate(PARAMS[:count]):
        value = 2.0 + 0.5 * i + 0.25
        echo = st.request(st.conn.mav.param_set_encode(1, 1, name.encode(), value, 9), ("PARAM_VALUE",),
                          lambda m, name=name, value=value: m.param_id == name and
                          math.isclose(m.param_value, value, abs_tol=1e-4), attempts)
        done += echo is not None
    return {"ok": done == count, "set": done}


def upload(st: Station, items: list[tuple[int, int, int, int]], attempts: int) -> dict[str, Any]:
    last: Any = st.conn.mav.mission_count_encode(1, 1, len(items), 0)
    silent = 0
    st.send(last)
    while silent < attempts:
        msg = st.recv(("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"),
                      lambda m: getattr(m, "mission_type", 0) == 0, st.retry_s)
        if msg is None:
            silent += 1
            st.send(last)
            continue
        silent = 0
        if msg.get_type() == "MISSION_ACK":
            return {"ok": msg.type == 0, "ack": int(msg.type)}
        seq = int(msg.seq)
        if 0 <= seq < len(items):
            last = item_msg(st, seq, items[seq][2], items[seq][3])
            st.send(last)
    return {"ok": False, "ack": None}


def download(st: Station, items: list[tuple[int, int, int, int]], attempts: int) -> dict[str, Any]:
    count = st.request(st.conn.mav.mission_request_list_encode(1, 1, 0), ("MISSION_COUNT",),
                       lambda m: True, attempts)
    if count is None:
        return {"ok": False}
    got: list[tuple[int, int]] = []
    for seq in range(int(count.count)):
        item = st.request(st.conn.mav.mission_request_int_encode(1, 1, seq, 0), ("MISSION_ITEM_INT",),
                          lambda m, seq=seq: m.seq == seq, attempts)
        if item is None:
            return {"ok": False, "items": len(got)}
        got.append((int(item.x), int(item.y)))
    st.send(st.conn.mav.mission_ack_encode(1, 1, 0, 0))
    same = [(x, y) for _, _, x, y in items[1:]] == got[1:]
    return {"ok": same and len(got) == len(items), "items": len(got)}


def command(st: Station, cmd: int, *params: float, attempts: int) -> tuple[int | None, int]:
    """COMMAND_LONG until its final COMMAND_ACK (confirmation counts the retransmissions)."""
    p = [*params, *[0.0] * (7 - len(params))]
    for confirmation in range(attempts):
        st.send(st.conn.mav.command_long_encode(1, 1, cmd, min(confirmation, 255), *p))
        ack = st.recv(("COMMAND_ACK",), lambda m: m.command == cmd and m.result != 5, st.retry_s)
        if ack is not None:
            return int(ack.result), confirmation + 1
    return None, attempts


def fire(st: Station, attempts: int) -> dict[str, Any]:
    st.recv(("USV_LAUNCHER_STATUS",), lambda m: True, 5.0)
    before = st.shots_left
    armed, _ = command(st, ARM_DISARM, 1.0, attempts=attempts)
    launcher, _ = command(st, LAUNCHER_ARM, 1.0, 120.0, attempts=attempts)
    fired, sends = command(st, LAUNCHER_FIRE, attempts=attempts)
    time.sleep(1.0)  # the trigger pulse, then the status stream
    st.recv(("USV_LAUNCHER_STATUS",), lambda m: True, 5.0)
    after = st.shots_left
    disarmed, _ = command(st, ARM_DISARM, 0.0, attempts=attempts)
    return {"ok": fired == 0 and before is not None and after == before - 1, "arm_result": armed,
            "launcher_arm_result": launcher, "fire_result": fired, "fire_sends": sends,
            "shots_before": before, "shots_after": after, "disarm_result": disarmed}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--items", type=int, default=30)
    parser.add_argument("--params", type=int, default=4)
    parser.add_argument("--retry", type=float, default=0.4, help="seconds before a request is resent")
    parser.add_argument("--attempts", type=int, default=40)
    parser.add_argument("--fire", action="store_true")
    args = parser.parse_args(argv)
    st = Station(args.port, args.retry)
    out: dict[str, Any] = {}
    t0 = time.monotonic()
    hb = st.recv(("HEARTBEAT",), lambda m: m.get_srcSystem() == 1, 60.0)
    out["connected"] = hb is not None
    threading.Thread(target=st.beat, daemon=True).start()
    items = plan(args.items)
    phases = [("params", lambda: set_params(st, args.params, args.attempts)),
              ("upload", lambda: upload(st, items, args.attempts)),
              ("download", lambda: download(st, items, args.attempts))]
    if args.fire:
        phases.append(("fire", lambda: fire(st, args.attempts)))
    for name, phase in phases:
        if not out["connected"]:
            break
        start, sent = time.monotonic(), st.sent
        result = phase()
        result.update(wall_s=round(time.monotonic() - start, 2), sent=st.sent - sent)
        out[name] = result
    st._stop.set()
    out["wall_s"] = round(time.monotonic() - t0, 2)
    out["ok"] = out["connected"] and all(out.get(name, {}).get("ok") for name, _ in phases)
    print(json.dumps(out), flush=True)
    return 0 if out["ok"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
