"""How tightly the simulated boat turns with its nozzle at the stop, throttle by throttle: the
simulated boat alone (no companion), in one current and weather (calm by default).

A water jet steers only while it pushes, and has no reverse: the smallest circle a hold can fly,
and how far a boat that is still moving when a hold starts runs out before it is round, follow
from this table.  ``docs/tuning.md`` ("What the hull can turn") uses it.

For each throttle: the boat starts from rest with the nozzle at its stop (a turn to starboard),
settles for :data:`SETTLE_S`, then over :data:`MEASURE_S` its mean speed through the water, its
mean turn rate, their ratio (the radius of the turn through the water) and the engine's mean rpm
are printed (``turns``).  Then, for each of those throttles, the boat runs straight at it until its
speed has settled and at a point the nozzle goes to its stop at full throttle, as a hold started
at that speed turns at once: how far from that point the boat gets before its bow has come round
a full turn (``entries``).

Run: ``python -m benchmarks.turn_capability`` (``--current``, ``--wind``, ``--waves`` and
``--seed`` as :mod:`benchmarks.idle_drift` takes them).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import math
import sys
from collections.abc import Sequence
from dataclasses import asdict, dataclass

from benchmarks.idle_drift import NOZZLE_MAX_RAD, add_condition_args
from companion.messages import ActuatorCommand, NavState
from sim_bridge.sitl import SitlHarness

SETTLE_S = 30.0
MEASURE_S = 10.0
SAMPLE_S = 0.2
THROTTLES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
ENTRY_LIMIT_S = 60.0
"""A full turn takes 6-36 s; an entry is measured for at most this long."""


@dataclass(frozen=True)
class TurnRow:
    throttle: float
    water_speed_mps: float
    """Mean speed through the water (surge and sway)."""
    turn_rate_dps: float
    radius_m: float
    """Of the turn through the water: speed over turn rate."""
    engine_rpm: float


async def turn_row(throttle: float, current: str = "0,0", wind: str = "0,0", waves: str = "0",
                   seed: int = 5) -> TurnRow:
    """The steady turn at ``throttle`` with the nozzle at its stop (module docstring)."""
    async with SitlHarness(seed=seed, current=current, wind=wind, waves=waves) as h:
        def hard_over(nav: NavState) -> ActuatorCommand:
            return ActuatorCommand(nav.t_s, nozzle_rad=-NOZZLE_MAX_RAD, throttle=throttle, ignition_on=True)

        h.drive(hard_over)
        await h.run_for(SETTLE_S)
        speeds, rates, rpms = [], [], []
        for _ in range(round(MEASURE_S / SAMPLE_S)):
            await h.run_for(SAMPLE_S)
            s = h.plant.state
            speeds.append(math.hypot(s.u_r_mps, s.v_r_mps))
            rates.append(abs(s.r_radps))
            rpms.append(s.engine_rpm)
    speed, rate = sum(speeds) / len(speeds), sum(rates) / len(rates)
    return TurnRow(throttle, round(speed, 2), round(math.degrees(rate), 1),
                   round(speed / rate, 2) if rate > 0.0 else math.inf, round(sum(rpms) / len(rpms)))


@dataclass(frozen=True)
class EntryRow:
    throttle_before: float
    entry_speed_mps: float
    """Speed through the water when the nozzle went over."""
    max_from_entry_m: float
    """Farthest the boat got from that point in its first full turn."""


async def entry_row(throttle_before: float, current: str = "0,0", wind: str = "0,0", waves: str = "0",
                    seed: int = 5, turn_throttle: float = 1.0) -> EntryRow:
    """A turn at the nozzle's stop and ``turn_throttle`` (full power by default, the tightest)
    started from a straight run at ``throttle_before`` (module docstring)."""
    turning = False

    async with SitlHarness(seed=seed, current=current, wind=wind, waves=waves) as h:
        def command(nav: NavState) -> ActuatorCommand:
            if turning:
                return ActuatorCommand(nav.t_s, nozzle_rad=-NOZZLE_MAX_RAD, throttle=turn_throttle,
                                       ignition_on=True)
            return ActuatorCommand(nav.t_s, nozzle_rad=0.0, throttle=throttle_before, ignition_on=True)

        h.drive(command)
        await h.run_for(SETTLE_S)
        s = h.plant.state
        start_n, start_e, speed = s.north_m, s.east_m, math.hypot(s.u_r_mps, s.v_r_mps)
        turning, turned_rad, heading_rad, farthest_m = True, 0.0, s.psi_rad, 0.0
        while turned_rad < 2.0 * math.pi and h.plant.state.t_s - s.t_s < ENTRY_LIMIT_S:
            await h.run_for(SAMPLE_S)
            now = h.plant.state
            turned_rad += abs(math.remainder(now.psi_rad - heading_rad, 2.0 * math.pi))
            heading_rad = now.psi_rad
            farthest_m = max(farthest_m, math.hypot(now.north_m - start_n, now.east_m - start_e))
    return EntryRow(throttle_before, round(speed, 2), round(farthest_m, 2))


async def turn_table(current: str = "0,0", wind: str = "0,0", waves: str = "0", seed: int = 5,
                     throttles: Sequence[float] = THROTTLES) -> list[TurnRow]:
    return [await turn_row(t, current, wind, waves, seed) for t in throttles]


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.turn_capability",
                                 description=__doc__.split("\n\n")[0])
    add_condition_args(ap, current="0,0", wind="0,0", waves="0")
    args = ap.parse_args(argv)
    logging.disable(logging.CRITICAL)
    conditions = (args.current, args.wind, args.waves, args.seed)
    turns = asyncio.run(turn_table(*conditions))
    entries = [asyncio.run(entry_row(t, *conditions)) for t in THROTTLES]
    out = {"current": args.current, "wind": args.wind, "waves": args.waves, "seed": args.seed,
           "turns": [asdict(r) for r in turns], "entries": [asdict(r) for r in entries]}
    json.dump(out, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
