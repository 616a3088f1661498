"""How the idling boat drifts over ground, heading by heading, in one current and weather: the
simulated boat alone (no companion), the jet at idle throttle, the nozzle holding a fixed heading.

A water jet has no reverse: what a hold can do in a current depends on where the idling boat goes
on each heading (bow upstream it creeps up a current weaker than its idle speed; with the wind
against the current the idle drift can nearly vanish on some headings).  ``docs/tuning.md``
("The idling boat's drift by heading in wind against the current") has the table this prints.

For each heading ``off`` degrees clockwise from upstream: the boat starts on it, settles for
:data:`SETTLE_S`, then its mean velocity over ground over :data:`MEASURE_S` is split into the part
down the current (negative: up it) and across it (positive: to the right looking down the
current); ``heading_error_deg`` is the nozzle's mean miss.  The last row is the boat with its
engine off.

Run: ``python -m benchmarks.idle_drift --current 0.8,90 --wind 6,90 --waves 0.3 --seed 5``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

from companion.config import ConfigError
from companion.messages import ActuatorCommand, NavState
from sim_bridge.disturbances import parse_current, parse_waves, parse_wind
from sim_bridge.hull import BoatParams
from sim_bridge.sitl import SitlHarness

SETTLE_S = 20.0
MEASURE_S = 30.0
SAMPLE_S = 0.5
HEADING_GAIN = 2.0
"""Nozzle angle per radian of heading error (rad/rad)."""
NOZZLE_MAX_RAD = BoatParams().nozzle_max_rad
"""The simulated nozzle's stop."""
OFFSETS_DEG = (0.0, 20.0, 40.0, 60.0, 90.0, 120.0, 150.0, 180.0)


@dataclass(frozen=True)
class DriftRow:
    off_upstream_deg: float
    engine_on: bool
    down_current_mps: float
    across_mps: float
    heading_error_deg: float | None
    """``None`` with the engine off (nothing holds the heading)."""


def add_condition_args(ap: argparse.ArgumentParser, current: str, wind: str, waves: str) -> None:
    """``--current``, ``--wind``, ``--waves`` (checked as ``usv sitl`` checks them) and ``--seed``,
    with these defaults."""
    ap.add_argument("--current", type=condition_flag(parse_current), default=current,
                    help="SPEED,TOWARD_DEG (as usv sitl)")
    ap.add_argument("--wind", type=condition_flag(parse_wind), default=wind,
                    help="SPEED,FROM_DEG (as usv sitl)")
    ap.add_argument("--waves", type=condition_flag(parse_waves), default=waves,
                    help="significant wave height (m)")
    ap.add_argument("--seed", type=int, default=5)


def condition_flag(parse: Callable[[str], object]) -> Callable[[str], str]:
    """An argparse type that accepts what ``usv sitl``'s flag of the same name accepts
    (``parse``: :mod:`sim_bridge.disturbances`'s parser, which names the accepted form)."""
    def check(text: str) -> str:
        try:
            parse(text)
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(f"wants what usv sitl takes: {exc}") from None
        return text
    return check


async def drift_row(current: str, wind: str, waves: str, seed: int, off_deg: float,
                    engine_on: bool = True) -> DriftRow:
    """One heading's idle drift (module docstring); ``current`` and ``wind`` as ``usv sitl`` takes
    them (speed, toward / from degrees)."""
    toward_rad = parse_current(current)[1]
    heading = toward_rad + math.radians(180.0 + off_deg)
    async with SitlHarness(seed=seed, current=current, wind=wind, waves=waves,
                           psi0_deg=math.degrees(heading)) as h:
        def hold_heading(nav: NavState) -> ActuatorCommand:
            error = math.remainder(heading - nav.heading_rad, 2.0 * math.pi)
            nozzle = max(-NOZZLE_MAX_RAD, min(NOZZLE_MAX_RAD, HEADING_GAIN * error))
            return ActuatorCommand(nav.t_s, nozzle_rad=nozzle, throttle=0.0, ignition_on=engine_on)

        h.drive(hold_heading)
        await h.run_for(SETTLE_S)
        s = h.plant.state
        n0, e0, t0 = s.north_m, s.east_m, s.t_s
        errors = []
        for _ in range(round(MEASURE_S / SAMPLE_S)):
            await h.run_for(SAMPLE_S)
            errors.append(abs(math.degrees(math.remainder(heading - h.plant.state.psi_rad, 2.0 * math.pi))))
        s = h.plant.state
        vn, ve = (s.north_m - n0) / (s.t_s - t0), (s.east_m - e0) / (s.t_s - t0)
    down = vn * math.cos(toward_rad) + ve * math.sin(toward_rad)
    across = -vn * math.sin(toward_rad) + ve * math.cos(toward_rad)
    return DriftRow(off_deg, engine_on, round(down, 2), round(across, 2),
                    round(sum(errors) / len(errors), 1) if engine_on else None)


async def drift_map(current: str, wind: str, waves: str, seed: int,
                    offsets_deg: Sequence[float] = OFFSETS_DEG) -> list[DriftRow]:
    """Every heading of ``offsets_deg``, then the engine off."""
    rows = [await drift_row(current, wind, waves, seed, off) for off in offsets_deg]
    rows.append(await drift_row(current, wind, waves, seed, 0.0, engine_on=False))
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.idle_drift", description=__doc__.split("\n\n")[0])
    add_condition_args(ap, current="0.8,90", wind="6,90", waves="0.3")
    args = ap.parse_args(argv)
    logging.disable(logging.CRITICAL)
    rows = asyncio.run(drift_map(args.current, args.wind, args.waves, args.seed))
    json.dump({"current": args.current, "wind": args.wind, "waves": args.waves, "seed": args.seed,
               "rows": [asdict(r) for r in rows]}, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
