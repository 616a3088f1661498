"""Behaviour fingerprint of a lockstep SITL run, for speed work that must not change behaviour.

``python -m benchmarks.sitl_same_run OUT_DIR`` writes two runs of 120 simulated seconds (seed 3,
current 0.5 m/s toward 90 deg) into ``OUT_DIR``:

* ``plain_truth.csv``: ``usv sitl --speedup 0 --duration 120 --seed 3 --current 0.5,90
  --truth-log ...`` as a separate process (no ground station: the boat holds, disarmed, and drifts);
* ``guided_truth.csv`` and ``guided_mavlink.csv``: the same companion and simulator built as
  ``usv sitl`` builds them (:func:`companion.commands.sitl._run_sitl`), with a scripted ground
  station on an in-process MAVLink link whose frames are fed and recorded at fixed simulated
  times (so the run is deterministic): HEARTBEAT at 1 Hz, arm at 3 s, DO_REPOSITION (GUIDED) to
  120 m north / 80 m east at 5 s and to 50 m south / 100 m east at 60 s.  ``guided_mavlink.csv``
  holds every frame the vehicle sent on that link (simulated time, message type, the raw frame
  in hex, so equal files mean equal telemetry values, sequence numbers included).

Run it on two commits and compare the directories (``diff -r``): a behaviour-neutral change
leaves every file identical.  The simulation clock starts at a fixed Unix time here, so
SYSTEM_TIME does not depend on when the check runs, and the check runs with ``PYTHONHASHSEED=0``
(it restarts itself so) because the ids of chunked STATUSTEXTs hash their text.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, TextIO

from companion.app import Application, BaseService
from companion.clock import SimClock
from companion.config import default_config
from companion.guidance.geo import LocalFrame
from companion.link.dialect import mav, new_codec
from companion.link.endpoint import Link
from companion.link.manager import LinkManager
from companion.messages import ModeNumber

SEED = 3
CURRENT = "0.5,90"
DURATION_S = 120.0
START_UNIX_S = 1_700_000_000.0
HOME = (41.77, 123.43)
"""``sim.home`` of the default configuration."""


class ScriptedGcs(BaseService):
    """A ground station on an in-process link, speaking MAVLink at fixed simulated times."""

    name = "scripted-gcs"

    def __init__(self, clock: SimClock, links: LinkManager, out: TextIO) -> None:
        self.clock, self.out = clock, out
        self.codec = new_codec(255, 190)
        self.frame = LocalFrame(*HOME)
        self.link: Link = links.make_link("scripted-gcs", self._record)

    def _record(self, frame: bytes) -> None:
        msg = mav.MAVLink(None).decode(bytearray(frame))
        self.out.write(f"{self.clock.now_s():.2f},{msg.get_type()},{frame.hex()}\n")

    def _send(self, msg: Any) -> None:
        self.link.feed(msg.pack(self.codec))
        self.codec.seq = (self.codec.seq + 1) % 256

    def _reposition(self, north_m: float, east_m: float) -> None:
        lat, lon = self.frame.to_lat_lon(north_m, east_m)
        self._send(mav.MAVLink_command_int_message(
            1, 1, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1,
            mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, 0, round(lat * 1e7), round(lon * 1e7), 0))

    async def run(self) -> None:
        script = {3: lambda: self._send(mav.MAVLink_command_long_message(
                      1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)),
                  5: lambda: self._reposition(120.0, 80.0),
                  60: lambda: self._reposition(-50.0, 100.0)}
        second = 0
        while True:
            await self.clock.sleep(second + 0.5 - self.clock.now_s())
            second += 1
            self._send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
            action = script.get(second)
            if action is not None:
                action()


async def guided_run(out_dir: Path) -> ModeNumber:
    from companion.runtime import build_companion, build_context
    from sim_bridge.runtime import SimulatorService, StopAfter
    from sim_bridge.truthlog import TruthLog

    with tempfile.TemporaryDirectory(prefix="usv-same-run-") as state_dir:
        config = default_config().with_overrides({
            "vehicle.state_dir": state_dir, "sim.seed": SEED, "sim.current": CURRENT, "sim.speedup": 0.0,
            "links.udp_targets": [], "links.tcp_listen": "", "links.tlog": False})
        clock = SimClock(start_unix_time_s=START_UNIX_S)
        ctx = build_context(config, clock)
        sim = SimulatorService(ctx, clock)
        services = build_companion(ctx, sim.companion_links)
        app = Application([sim, *services.in_start_order()])
        app.add(TruthLog(sim.boat, clock, out_dir / "guided_truth.csv"))
        with (out_dir / "guided_mavlink.csv").open("w", encoding="utf-8") as out:
            out.write("t_s,type,frame_hex\n")
            app.add(ScriptedGcs(clock, services.links, out))
            app.add(StopAfter(clock, DURATION_S, app.request_stop))
            await app.run()
        return ModeNumber(services.vehicle.modes.current.number)


def plain_run(out_dir: Path) -> None:
    with tempfile.TemporaryDirectory(prefix="usv-same-run-") as state_dir:
        subprocess.run([sys.executable, "-m", "companion.cli", "sitl", "--speedup", "0", "--duration",
                        str(DURATION_S), "--seed", str(SEED), "--current", CURRENT, "--status-every", "0",
                        "--state-dir", state_dir, "--truth-log", str(out_dir / "plain_truth.csv")],
                       check=True, stdout=subprocess.DEVNULL, timeout=1200)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0] if __doc__ else None)
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--skip-plain", action="store_true", help="only the scripted GUIDED run")
    args = parser.parse_args(argv)
    if os.environ.get("PYTHONHASHSEED") != "0":  # STATUSTEXT chunk ids hash their text: fix the seed
        env = {**os.environ, "PYTHONHASHSEED": "0"}
        again = sys.argv[1:] if argv is None else argv
        return subprocess.run([sys.executable, "-m", "benchmarks.sitl_same_run", *again], env=env).returncode
    args.out_dir.mkdir(parents=True, exist_ok=True)
    mode = asyncio.run(guided_run(args.out_dir))
    print(f"guided run done (final mode {mode.name})", flush=True)
    if not args.skip_plain:
        plain_run(args.out_dir)
        print("plain run done", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
