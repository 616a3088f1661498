"""One cell of ``usv bench nav``: a ``usv sitl`` process flown by the ground station of
:mod:`benchmarks.nav_gcs`, the way an operator flies it.

The vehicle runs with DEFAULT parameters; only its links (one UDP target on a free port, no TCP
server, no tlog) and the simulated weather differ.  The simulator writes its truth log
(``usv sitl --truth-log``); the ground station keeps a timeline in the vehicle's time base.
The script, in vehicle time:

1. arm; GUIDED go-to :data:`GOTO_NE` (DO_REPOSITION); when the telemetry says the boat is within
   WP_RADIUS, stay in GUIDED for :data:`ARRIVAL_HOLD_S` (the arrival is measured there);
2. LOITER for :data:`LOITER_S`;
3. RTL; within WP_RADIUS of home, upload the mission and stay in RTL until :data:`ARRIVAL_HOLD_S`;
4. AUTO until the mission is COMPLETE (the boat then goes to HOLD, MIS_DONE_BEHAVE 0).  The mission
   is the 50 m square home -> N -> NE -> E -> home (items 1-4, corners :data:`SQUARE_NE`), then the
   sampling mission: four USV_CMD_NAV_SAMPLE_HERE items (5-8) at :data:`SAMPLE_POINTS_NE`, every
   parameter 0 (default radius, next empty bottle, default fill time).  One upload, one AUTO run: no
   ground-station command (whose arrival in vehicle time depends on wall-clock latency) falls
   between the square and the samples, which keeps the sampling figures repeatable.
"""

from __future__ import annotations

import contextlib
import math
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from benchmarks.mavlink_gcs import free_port
from benchmarks.nav_gcs import (
    MAV_CMD_USV_NAV_SAMPLE_HERE,
    MODE_AUTO,
    MODE_LOITER,
    MODE_RTL,
    GcsError,
    GroundStation,
)
from companion.guidance.geo import LocalFrame

SITL_SPEEDUP = 20.0
"""``usv sitl --speedup``: lockstep, capped at 20x real time.  The ground station reacts within a few
milliseconds of wall time, i.e. about 0.1 s of vehicle time at 20x; the repeatability section of the
bench shows what that does to the figures (same cell twice)."""

GOTO_NE = (30.0, 30.0)
"""GUIDED go-to target, metres north/east of home (the issue's script)."""
ARRIVAL_HOLD_S = 30.0
"""Vehicle seconds the ground station leaves the boat on its GUIDED/RTL point before the next step."""
LOITER_S = 120.0
SQUARE_NE = ((50.0, 0.0), (50.0, 50.0), (0.0, 50.0), (0.0, 0.0))
"""The AUTO square's waypoints after home (north, east metres): legs N, E, S, W, 50 m each."""
SAMPLE_POINTS_NE = ((25.0, 0.0), (25.0, 25.0), (0.0, 25.0), (-15.0, 10.0))
"""The four sampling points (north, east metres from home)."""
PHASE_LIMIT_S = {"goto": 120.0, "rtl": 120.0, "mission": 900.0}
"""Vehicle seconds after which a phase counts as failed (the cell reports the error)."""


@dataclass(frozen=True)
class Cell:
    """One set of conditions: current (toward), wind (from), waves, seed."""

    current_mps: float
    current_toward_deg: float
    wind_mps: float
    wind_from_deg: float
    waves_hs_m: float
    seed: int

    @property
    def name(self) -> str:
        return (f"current {self.current_mps:g} toward {self.current_toward_deg:g}, wind {self.wind_mps:g} "
                f"from {self.wind_from_deg:g}, Hs {self.waves_hs_m:g}, seed {self.seed}")

    def sitl_args(self) -> list[str]:
        return ["--current", f"{self.current_mps:g},{self.current_toward_deg:g}",
                "--wind", f"{self.wind_mps:g},{self.wind_from_deg:g}", "--waves", f"{self.waves_hs_m:g}",
                "--seed", str(self.seed)]


@dataclass
class Flight:
    """What one flight produced: the ground station's timeline and where the truth log is."""

    cell: Cell
    truth_csv: Path
    home: tuple[float, float]
    events: list[list[Any]]
    positions: list[list[float]]
    """GLOBAL_POSITION_INT as received: [vehicle t_s, lat_deg, lon_deg]."""
    params: dict[str, float]
    plan: dict[str, Any]
    error: str | None
    failsafe: bool
    wall_s: float
    sim_s: float
    sitl_cpu_s: float
    """CPU seconds of the ``usv sitl`` process (user + system)."""
    gcs_cpu_s: float

    def to_json(self) -> dict[str, Any]:
        out = asdict(self)
        out["truth_csv"] = str(self.truth_csv)
        return out


def usv_command() -> list[str]:
    """The ``usv`` console script beside this interpreter (as a user runs it), else ``-m companion.cli``."""
    script = Path(sys.executable).with_name("usv")
    return [str(script)] if script.exists() else [sys.executable, "-m", "companion.cli"]


def write_config(path: Path, state_dir: Path, port: int) -> Path:
    path.write_text(f'[vehicle]\nstate_dir = "{state_dir}"\n[links]\nudp_targets = ["127.0.0.1:{port}"]\n'
                    'tcp_listen = ""\ntlog = false\n', encoding="utf-8")
    return path


@contextlib.contextmanager
def sitl_process(cell: Cell, workdir: Path, port: int, speedup: float) -> Iterator[subprocess.Popen[bytes]]:
    """``usv sitl`` for ``cell`` sending MAVLink to ``port``; stopped with SIGINT (Ctrl-C) afterwards."""
    state = workdir / "state"
    state.mkdir(parents=True, exist_ok=True)
    config = write_config(workdir / "sitl.toml", state, port)
    env = dict(os.environ, XDG_STATE_HOME=str(workdir / "xdg"), PYTHONUNBUFFERED="1")
    args = [*usv_command(), "sitl", "-c", str(config), "--speedup", f"{speedup:g}", *cell.sitl_args(),
            "--truth-log", str(workdir / "truth.csv")]
    with open(workdir / "sitl.log", "wb") as log:
        proc = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, env=env)
        try:
            yield proc
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                try:
                    proc.wait(20)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(5)


def _within(gcs: GroundStation, frame: LocalFrame, point_ne: tuple[float, float], radius_m: float) -> bool:
    if gcs.position is None:
        return False
    n, e = frame.to_ne(*gcs.position)
    return math.hypot(n - point_ne[0], e - point_ne[1]) <= radius_m


def fly(gcs: GroundStation, plan: dict[str, Any]) -> None:
    """The operator's script (module docstring), recording phase marks on the timeline."""
    tl = gcs.timeline
    assert gcs.home is not None
    frame = LocalFrame(*gcs.home)
    radius = plan["params"]["WP_RADIUS"]
    gcs.arm()
    goto = frame.to_lat_lon(*GOTO_NE)
    gcs.goto(*goto)
    tl.add(gcs.t_s, "phase", "goto")
    gcs.wait(lambda: _within(gcs, frame, GOTO_NE, radius), vehicle_s=PHASE_LIMIT_S["goto"],
             what="go-to arrival")
    tl.add(gcs.t_s, "phase", "goto_arrived")
    gcs.sleep_vehicle(ARRIVAL_HOLD_S)

    gcs.set_mode(MODE_LOITER)
    tl.add(gcs.t_s, "phase", "loiter")
    gcs.sleep_vehicle(LOITER_S)

    gcs.set_mode(MODE_RTL)
    tl.add(gcs.t_s, "phase", "rtl")
    gcs.wait(lambda: _within(gcs, frame, (0.0, 0.0), radius), vehicle_s=PHASE_LIMIT_S["rtl"],
             what="RTL arrival")
    arrived_s = gcs.t_s
    tl.add(arrived_s, "phase", "rtl_arrived")
    gcs.upload_mission(plan["square_items"] + plan["sample_items"])
    gcs.sleep_vehicle(max(0.0, arrived_s + ARRIVAL_HOLD_S - gcs.t_s))

    gcs.set_mode(MODE_AUTO)
    tl.add(gcs.t_s, "phase", "mission")
    gcs.wait(lambda: gcs.mission_state == 5 or gcs.mode != MODE_AUTO, vehicle_s=PHASE_LIMIT_S["mission"],
             what="mission complete")
    tl.add(gcs.t_s, "phase", "mission_done")
    gcs.sleep_vehicle(2.0)  # the last sample's USV_SAMPLER_STATUS (1 Hz)
    tl.add(gcs.t_s, "phase", "end")


def mission_plan(gcs: GroundStation) -> dict[str, Any]:
    """The mission items (from the vehicle's home) and the parameters the figures need."""
    mavlink = gcs.mavutil.mavlink
    assert gcs.home is not None
    frame = LocalFrame(*gcs.home)
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    square = [(rel, mavlink.MAV_CMD_NAV_WAYPOINT, (0.0, 0.0, 0.0, 0.0), *frame.to_lat_lon(*c))
              for c in SQUARE_NE]
    samples = [(rel, MAV_CMD_USV_NAV_SAMPLE_HERE, (0.0, 0.0, 0.0, 0.0), *frame.to_lat_lon(*p))
               for p in SAMPLE_POINTS_NE]
    params = {name: gcs.read_param(name) for name in ("WP_RADIUS", "USV_TURN_RAD", "USV_SMPL_CIRC_M")}
    return {"square_items": square, "sample_items": samples, "params": params,
            "goto_ne": GOTO_NE, "square_ne": SQUARE_NE, "sample_points_ne": SAMPLE_POINTS_NE}


def run_cell(cell: Cell, workdir: Path, speedup: float = SITL_SPEEDUP) -> Flight:
    """Fly ``cell`` in a fresh ``usv sitl`` process; the truth log stays in ``workdir``."""
    shutil.rmtree(workdir, ignore_errors=True)
    workdir.mkdir(parents=True)
    t0, cpu0 = time.monotonic(), time.process_time()
    children0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    port = free_port()
    gcs = GroundStation(port)
    error: str | None = None
    plan: dict[str, Any] = {"params": {}}
    try:
        with sitl_process(cell, workdir, port, speedup) as proc:
            try:
                gcs.connect()
                plan = mission_plan(gcs)
                fly(gcs, plan)
            except GcsError as exc:
                error = f"{exc}; sitl exit={proc.poll()}"
    finally:
        gcs.close()
    if gcs.failsafe and error is None:
        texts = [t for _, t in gcs.statustexts if "failsafe" in t.lower()]
        error = "GCS failsafe during the flight: " + "; ".join(texts)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    sitl_cpu_s = (children.ru_utime - children0.ru_utime) + (children.ru_stime - children0.ru_stime)
    return Flight(cell=cell, truth_csv=workdir / "truth.csv", home=gcs.home or (math.nan, math.nan),
                  events=gcs.timeline.to_json()["events"],
                  positions=[[round(t, 3), la, lo] for t, la, lo in gcs.timeline.positions],
                  params=plan["params"],
                  plan={k: v for k, v in plan.items() if not k.endswith("_items")}, error=error,
                  failsafe=gcs.failsafe, wall_s=round(time.monotonic() - t0, 1), sim_s=round(gcs.t_s, 1),
                  sitl_cpu_s=round(sitl_cpu_s, 1), gcs_cpu_s=round(time.process_time() - cpu0, 1))
