"""What the mission scripts share: the MAVSDK connection, the vehicle's clock and track, waiting.

The scripts (``rescue.py``, ``water_sampling.py``, ``search.py``) are written like the
MAVSDK-Python examples: ``async def run()`` + ``asyncio.run(run())``, the MAVSDK 4 native
plugins (telemetry, action, mission, mission_raw, param) and ``mavlink_direct`` with the
boat's dialect (``mavlink_dialect/usv.xml``) for the payload commands and status messages.
:class:`Boat` holds what each of them would otherwise repeat:

* connecting with a time limit, and a clear message when nothing answers at the URL;
* the vehicle's own clock: every time a script reports (time to casualty, time on station,
  the track of Fig. 13) is in *vehicle* seconds from ``time_boot_ms``, so figures are the same
  whether ``usv sitl`` runs in real time or ``--speedup 10``;
* the track (GLOBAL_POSITION_INT), STATUSTEXT, mission progress, and the launcher and sampler
  status messages of the dialect, recorded in the background;
* :meth:`Boat.until`: wait for a condition with a limit in vehicle seconds, and fail at once
  when telemetry stops for :data:`TELEMETRY_SILENCE_S` of wall time (link lost).

Exit status of every script: 0 the mission met its success criteria, 1 it did not (or the
vehicle refused a step), 2 bad arguments, 3 no vehicle at the URL or the link was lost.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import sys
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from companion.guidance.geo import LocalFrame

DEFAULT_URL = "udpin://0.0.0.0:14540"
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_NO_VEHICLE = 0, 1, 2, 3
READY_TIMEOUT_S = 120.0
"""Vehicle seconds to wait for a position, home and passing pre-arm checks."""
TELEMETRY_SILENCE_S = 10.0
"""Wall seconds without a position report after which the link counts as lost."""
MISSION_STATE_ACTIVE, MISSION_STATE_COMPLETE = 3, 5
LEFT_AUTO_GRACE_S = 3.0
"""Vehicle seconds a mission may be out of AUTO before MISSION_CURRENT says COMPLETE."""
MODE_HOLD, MODE_AUTO, MODE_RTL = 4, 10, 11
UINT16_UNKNOWN = 65535
MAV_MODE_FLAG_ARMED = 128
MAV_CMD_REQUEST_MESSAGE, MSG_ID_HOME_POSITION = 512, 242


class MissionError(Exception):
    """A step failed; ``code`` is the script's exit status."""

    def __init__(self, message: str, code: int = EXIT_FAILED) -> None:
        super().__init__(message)
        self.code = code
        self.details: dict[str, Any] = {}
        """Figures known when the step failed (printed with the failure)."""


def add_common_arguments(parser: argparse.ArgumentParser, *, timeout_s: float) -> None:
    """``--url``, ``--connect-timeout``, ``--timeout`` (vehicle s), ``--json``, ``--verbose``."""
    parser.add_argument("--url", default=DEFAULT_URL,
                        help=f"MAVSDK connection URL of the vehicle (default {DEFAULT_URL})")
    parser.add_argument("--connect-timeout", type=float, default=30.0, metavar="S",
                        help="give up when no vehicle answers within this many wall seconds (default 30)")
    parser.add_argument("--timeout", type=float, default=timeout_s, metavar="S",
                        help=f"give up when the mission is not done after this many vehicle seconds "
                             f"(default {timeout_s:.0f})")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument("--verbose", action="store_true", help="show MAVSDK's own log messages")


def parse_pair(text: str, what: str) -> tuple[float, float]:
    """``"A,B"`` -> two finite floats (argparse type helper with a clear message)."""
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what}: expected two numbers 'A,B', got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise argparse.ArgumentTypeError(f"{what}: {text!r} is not finite")
    return a, b


@dataclass(frozen=True, slots=True)
class TrackPoint:
    """One GLOBAL_POSITION_INT: vehicle time, position, heading, speed over ground."""

    t_s: float
    lat_deg: float
    lon_deg: float
    heading_deg: float
    speed_mps: float


@dataclass(frozen=True, slots=True)
class WaterCurrent:
    """The vehicle's estimate of the water current (USV_CURRENT_ESTIMATE): where the water flows
    toward, m/s north and east, and how clearly it stands out of its uncertainty (0..1)."""

    north_mps: float
    east_mps: float
    confidence: float

    @property
    def speed_mps(self) -> float:
        return math.hypot(self.north_mps, self.east_mps)

    @property
    def toward_deg(self) -> float:
        return math.degrees(math.atan2(self.east_mps, self.north_mps)) % 360.0


@dataclass
class Records:
    """What the vehicle reported, stamped with vehicle seconds."""

    track: list[TrackPoint] = field(default_factory=list)
    texts: list[tuple[float, str]] = field(default_factory=list)
    reached: dict[int, float] = field(default_factory=dict)
    current_since: dict[int, float] = field(default_factory=dict)
    """Mission item -> vehicle time it first became current (mission active)."""
    current: tuple[int, int, int] = (-1, 0, 0)
    """MISSION_CURRENT: (seq, total, mission_state)."""
    launcher: dict[str, Any] | None = None
    sampler: dict[str, Any] | None = None
    samples: list[dict[str, Any]] = field(default_factory=list)
    """USV_SAMPLER_STATUS at each new sample (last_sample_time changed)."""
    unix_offset_s: float | None = None
    """Vehicle unix time minus vehicle boot time (SYSTEM_TIME)."""
    heard_wall_s: float = 0.0
    homes: int = 0
    """HOME_POSITION messages received (the latest is :attr:`Boat.home`)."""
    mode: int = -1
    """custom_mode of the vehicle's HEARTBEAT (ArduRover numbers)."""
    armed: bool = False
    water_current: WaterCurrent | None = None
    """The vehicle's latest water-current estimate (USV_CURRENT_ESTIMATE; ``None`` while it has none)."""


class Boat:
    """One connected vehicle and what it reports (build with :meth:`connect`)."""

    def __init__(self, mav: Any, system: Any, url: str) -> None:
        from mavsdk.asyncio.plugins.action import ActionAsync
        from mavsdk.asyncio.plugins.mavlink_direct import MavlinkDirectAsync
        from mavsdk.asyncio.plugins.mission import MissionAsync
        from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
        from mavsdk.asyncio.plugins.param import ParamAsync
        from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

        self.mav, self.system, self.url = mav, system, url
        self.telemetry, self.action = TelemetryAsync(system), ActionAsync(system)
        self.mission, self.mission_raw = MissionAsync(system), MissionRawAsync(system)
        self.param, self.direct = ParamAsync(system), MavlinkDirectAsync(system)
        self.rec = Records()
        self.home: tuple[float, float] | None = None
        self.quiet = False
        self._tasks: list[asyncio.Task[None]] = []

    # -- connecting ---------------------------------------------------------------------
    @classmethod
    async def connect(cls, url: str, timeout_s: float, *, verbose: bool = False) -> Boat:
        """Connect and start recording; :class:`MissionError` (exit 3) when nothing answers."""
        from mavsdk import logging as mavsdk_logging
        from mavsdk.asyncio import ComponentType, Configuration, Mavsdk, MavsdkConnectionError

        if not verbose:  # MAVSDK logs every message it assembles; keep the script's output readable
            mavsdk_logging.log_subscribe(lambda level, *_: level < mavsdk_logging.LogLevel.ERROR)
        mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
        try:
            await mav.add_any_connection(url)
        except MavsdkConnectionError as exc:
            mav.destroy()
            raise MissionError(f"cannot open {url}: {exc}", EXIT_NO_VEHICLE) from None
        system = await mav.first_autopilot(timeout_s)
        if system is None:
            mav.destroy()
            raise MissionError(f"no vehicle answered at {url} within {timeout_s:.0f} s (is `usv sitl` "
                               "running and sending to this port?)", EXIT_NO_VEHICLE)
        boat = cls(mav, system, url)
        await boat._start_recording()
        return boat

    def close(self) -> None:
        for task in self._tasks:
            task.cancel()
        self.mav.destroy()

    async def _start_recording(self) -> None:
        import mavlink_dialect

        await self.direct.load_custom_xml(mavlink_dialect.mavsdk_xml())
        handlers: dict[str, Callable[[dict[str, Any]], None]] = {
            "GLOBAL_POSITION_INT": self._on_position, "SYSTEM_TIME": self._on_system_time,
            "MISSION_CURRENT": self._on_current, "MISSION_ITEM_REACHED": self._on_reached,
            "USV_LAUNCHER_STATUS": self._on_launcher, "USV_SAMPLER_STATUS": self._on_sampler,
            "HOME_POSITION": self._on_home, "HEARTBEAT": self._on_heartbeat,
            "USV_CURRENT_ESTIMATE": self._on_water_current,
        }
        for name, handler in handlers.items():
            self._tasks.append(asyncio.ensure_future(self._follow(name, handler)))
        self._tasks.append(asyncio.ensure_future(self._follow_texts()))
        self.rec.heard_wall_s = time.monotonic()

    async def _follow(self, name: str, handler: Callable[[dict[str, Any]], None]) -> None:
        async for msg in self.direct.subscribe_message(name):
            handler(json.loads(msg.fields_json))

    async def _follow_texts(self) -> None:
        async for status in self.telemetry.subscribe_status_text():
            self.rec.texts.append((self.now_s(), status.text))
            if not self.quiet:
                print(f"  [{self.now_s():7.1f} s] vehicle: {status.text}", flush=True)

    def _on_position(self, f: dict[str, Any]) -> None:
        hdg = f["hdg"]
        self.rec.track.append(TrackPoint(f["time_boot_ms"] / 1000.0, f["lat"] / 1e7, f["lon"] / 1e7,
                                         math.nan if hdg == UINT16_UNKNOWN else hdg / 100.0,
                                         math.hypot(f["vx"], f["vy"]) / 100.0))
        self.rec.heard_wall_s = time.monotonic()

    def _on_heartbeat(self, f: dict[str, Any]) -> None:
        self.rec.mode, self.rec.armed = int(f["custom_mode"]), bool(int(f["base_mode"]) & MAV_MODE_FLAG_ARMED)

    def _on_home(self, f: dict[str, Any]) -> None:
        self.home = (f["latitude"] / 1e7, f["longitude"] / 1e7)
        self.rec.homes += 1

    def _on_system_time(self, f: dict[str, Any]) -> None:
        self.rec.unix_offset_s = f["time_unix_usec"] / 1e6 - f["time_boot_ms"] / 1000.0

    def _on_current(self, f: dict[str, Any]) -> None:
        self.rec.current = (int(f["seq"]), int(f["total"]), int(f.get("mission_state", 0)))
        if self.rec.current[2] == MISSION_STATE_ACTIVE:
            self.rec.current_since.setdefault(self.rec.current[0], self.now_s())

    def _on_water_current(self, f: dict[str, Any]) -> None:
        north, east, confidence = (_number(f.get(k)) for k in ("current_north", "current_east", "confidence"))
        finite = all(math.isfinite(x) for x in (north, east, confidence))
        self.rec.water_current = WaterCurrent(north, east, confidence) if finite else None

    def _on_reached(self, f: dict[str, Any]) -> None:
        self.rec.reached.setdefault(int(f["seq"]), self.now_s())

    def _on_launcher(self, f: dict[str, Any]) -> None:
        self.rec.launcher = f

    def _on_sampler(self, f: dict[str, Any]) -> None:
        last = self.rec.samples[-1]["last_sample_time_unix_usec"] if self.rec.samples else 0
        if f["last_sample_time_unix_usec"] not in (0, last):
            self.rec.samples.append(f)
        self.rec.sampler = f

    # -- the vehicle's clock and position ---------------------------------------------------
    def now_s(self) -> float:
        """Vehicle seconds since boot (latest position report)."""
        return self.rec.track[-1].t_s if self.rec.track else 0.0

    def vehicle_time_s(self, unix_usec: int) -> float:
        """A vehicle unix time stamp (dialect messages) as vehicle seconds since boot."""
        offset = self.rec.unix_offset_s
        return math.nan if offset is None or unix_usec == 0 else unix_usec / 1e6 - offset

    def frame(self) -> LocalFrame:
        """North-east metres around the vehicle's home."""
        if self.home is None:
            raise MissionError("the vehicle has no home position")
        return LocalFrame(*self.home)

    def position_ne(self) -> tuple[float, float]:
        last = self.rec.track[-1]
        return self.frame().to_ne(last.lat_deg, last.lon_deg)

    def distance_home_m(self) -> float:
        return math.hypot(*self.position_ne())

    # -- waiting ---------------------------------------------------------------------------
    async def until(self, cond: Callable[[], bool], timeout_s: float, what: str) -> None:
        """Wait until ``cond()``; at most ``timeout_s`` vehicle seconds; fail fast on a lost link."""
        start_s = self.now_s() if self.rec.track else None
        while not cond():
            if time.monotonic() - self.rec.heard_wall_s > TELEMETRY_SILENCE_S:
                raise MissionError(f"link to {self.url} lost while waiting for {what} (no telemetry for "
                                   f"{TELEMETRY_SILENCE_S:.0f} s)", EXIT_NO_VEHICLE)
            if start_s is None and self.rec.track:
                start_s = self.now_s()  # the vehicle's clock is known from its first position report
            if start_s is not None and self.now_s() - start_s > timeout_s:
                raise MissionError(f"{what}: not done after {timeout_s:.0f} s (vehicle time)")
            await asyncio.sleep(0.05)

    async def wait_ready(self, timeout_s: float) -> None:
        """Healthy, armable and with a home position, or :class:`MissionError` naming what is missing."""
        health: list[Any] = []

        async def watch() -> None:  # polled: MAVSDK reports health on changes only
            while True:
                health[:] = [await self.telemetry.health()]
                await asyncio.sleep(0.2)

        task = asyncio.ensure_future(watch())
        try:
            await self.until(lambda: bool(health) and health[0].is_armable and health[0].is_home_position_ok
                             and health[0].is_global_position_ok and bool(self.rec.track), timeout_s,
                             "vehicle ready to arm")
        except MissionError as exc:
            if exc.code == EXIT_NO_VEHICLE or not health:
                raise
            h = health[0]
            checks = (("position", h.is_global_position_ok), ("home", h.is_home_position_ok),
                      ("pre-arm checks", h.is_armable))
            missing = ", no ".join(name for name, ok in checks if not ok)
            raise MissionError(f"vehicle not ready after {timeout_s:.0f} s: no {missing}") from None
        finally:
            task.cancel()
        await self.until(lambda: self.rec.homes > 0, 30.0, "home position")

    # -- acting ----------------------------------------------------------------------------
    async def arm(self) -> None:
        """Arm (the vehicle moves its home to where it is) and read the new home back."""
        from mavsdk.asyncio.plugins.action import ActionError

        try:
            await self.action.arm()
        except ActionError as exc:
            raise MissionError(f"arming refused: {exc} (see the vehicle's messages above)") from None
        seen = self.rec.homes
        await self.command(MAV_CMD_REQUEST_MESSAGE, MSG_ID_HOME_POSITION)
        await self.until(lambda: self.rec.homes > seen, 30.0, "home position after arming")

    async def param_float(self, name: str) -> float:
        return float(await self.param.get_param_float(name))

    async def command(self, command: int, *params: float) -> int:
        """COMMAND_LONG through ``mavlink_direct`` (boat dialect commands); the MAV_RESULT."""
        from mavsdk.plugins.mavlink_direct import MavlinkMessage

        values = [*params, *([0.0] * (7 - len(params)))]
        fields = {"target_system": 1, "target_component": 1, "command": int(command), "confirmation": 0,
                  **{f"param{i + 1}": float(v) for i, v in enumerate(values)}}
        ack = await asyncio.wait_for(self.direct.send_command(
            MavlinkMessage("COMMAND_LONG", 0, 0, 1, 1, json.dumps(fields))), 15.0)
        return int(json.loads(ack.fields_json)["result"])

    async def run_raw_mission(self, items: list[Any], timeout_s: float, describe: Callable[[int], str],
                              item_limits_s: dict[int, float] | None = None) -> float:
        """Upload ``items`` (mission_raw), start, print progress until MISSION_CURRENT says COMPLETE.

        Returns the vehicle time the mission started.  ``describe(seq)`` names an item for the log;
        ``item_limits_s`` gives items that must be done within so many vehicle seconds of starting.
        """
        from mavsdk.asyncio.plugins.mission_raw import MissionRawError

        limits = item_limits_s or {}
        self.rec.current = (-1, 0, 0)  # forget the last mission's progress
        self.rec.reached.clear()
        self.rec.current_since.clear()
        try:
            await self.mission_raw.upload_mission(items)
            await self.mission_raw.start_mission()
        except MissionRawError as exc:
            raise MissionError(f"mission refused: {exc} (see the vehicle's messages above)") from None
        start_s = self.now_s()
        shown, active, left_auto_s, since_s = -1, False, math.inf, start_s

        def progress() -> bool:
            nonlocal shown, active, left_auto_s, since_s
            seq, total, state = self.rec.current
            active = active or (state == MISSION_STATE_ACTIVE and self.rec.mode == MODE_AUTO)
            if active and seq != shown and 0 <= seq < len(items) and state != MISSION_STATE_COMPLETE:
                shown = seq
                since_s = self.now_s()
                print(f"  [{since_s:7.1f} s] item {seq + 1}/{total}: {describe(seq)}", flush=True)
            if seq == shown and seq in limits and self.now_s() - since_s > limits[seq]:
                raise MissionError(f"item {seq + 1} ({describe(seq)}) not done after {limits[seq]:.0f} s")
            if active and state == MISSION_STATE_COMPLETE:
                return True
            if active and self.rec.mode != MODE_AUTO:  # done (MISSION_CURRENT may come later) or stopped
                left_auto_s = min(left_auto_s, self.now_s())
                if self.now_s() - left_auto_s > LEFT_AUTO_GRACE_S:
                    raise MissionError(f"the vehicle left AUTO (mode {self.rec.mode}) at item {seq + 1}: "
                                       "see its messages above")
            return False

        await self.until(progress, timeout_s, "mission")
        return start_s

    async def go_home_and_disarm(self, radius_m: float, timeout_s: float) -> float:
        """RTL until within ``radius_m`` of home, then disarm; the distance from home at disarming."""
        from mavsdk.asyncio.plugins.action import ActionError

        try:
            await self.action.return_to_launch()
        except ActionError as exc:
            raise MissionError(f"RTL refused: {exc}") from None
        await self.until(lambda: self.distance_home_m() <= radius_m, timeout_s, "return home")
        distance_m = self.distance_home_m()
        await self.action.disarm()
        await self.until(lambda: not self.rec.armed, 30.0, "disarm")
        return distance_m

    async def abort(self) -> None:
        """After a failure mid-mission: send the boat home (best effort; only when armed)."""
        if not self.rec.armed:
            return
        with contextlib.suppress(Exception):
            await asyncio.wait_for(self.action.return_to_launch(), 5.0)
            print("  boat sent home (RTL)", file=sys.stderr, flush=True)


async def fly(name: str, args: argparse.Namespace,
              mission: Callable[[Boat, argparse.Namespace], Awaitable[int]]) -> int:
    """Connect to ``args.url``, wait until the vehicle is ready, run ``mission``; its exit status.

    A :class:`MissionError` is printed (``--json``: as JSON) and, once armed, the boat sent home.
    """
    try:
        boat = await Boat.connect(args.url, args.connect_timeout, verbose=args.verbose)
    except MissionError as exc:
        return fail(name, exc, args.json)
    try:
        print(f"{name}: connected to {args.url}", flush=True)
        await boat.wait_ready(READY_TIMEOUT_S)
        return await mission(boat, args)
    except MissionError as exc:
        await boat.abort()
        return fail(name, exc, args.json)
    finally:
        boat.close()


def finish(name: str, summary: dict[str, Any], failures: list[str], as_json: bool,
           show: Callable[[dict[str, Any]], None]) -> int:
    """Add the common criterion (disarmed within WP_RADIUS of home), print the summary (``show``, or
    JSON) and what failed; the exit status."""
    home_m, radius_m = summary["home_distance_at_disarm_m"], summary["wp_radius_m"]
    if home_m > radius_m:
        failures.append(f"disarmed {home_m:.1f} m from home (WP_RADIUS {radius_m} m)")
    summary = {**summary, "ok": not failures, "failures": failures}
    if as_json:
        print(json.dumps(_finite(summary), allow_nan=False, default=str))
    else:
        show(summary)
    for failure in failures:
        print(f"{name}: FAILED: {failure}", file=sys.stderr, flush=True)
    if not failures and not as_json:
        print(f"{name}: success", flush=True)
    return EXIT_FAILED if failures else EXIT_OK


def fail(name: str, exc: MissionError, as_json: bool = False) -> int:
    """Report a step that failed (with :attr:`MissionError.details`); the exit status."""
    if as_json:
        report = {**exc.details, "ok": False, "failures": [str(exc)], "exit_status": exc.code}
        print(json.dumps(_finite(report), allow_nan=False, default=str), flush=True)
    elif exc.details:
        print(f"{name}: {json.dumps(_finite(exc.details), default=str)}", flush=True)
    print(f"{name}: FAILED: {exc}", file=sys.stderr, flush=True)
    return exc.code


def _number(value: Any) -> float:
    """A JSON field as a float; NaN for null, text or anything else that is not a number."""
    return float(value) if isinstance(value, (int, float)) else math.nan


def _finite(value: Any) -> Any:
    """NaN and infinities as ``null`` (JSON has no NaN)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value
