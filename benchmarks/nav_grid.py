"""The conditions of ``usv bench nav``: the grid of cells, the seeds, the issue's targets and
ArduRover's reference figures.

Grid (issue 14): current 0, 0.3, 0.5, 0.8 and 1.2 m/s toward N, E, S and W, wind 0-6 m/s, waves
Hs 0-0.3 m, several seeds.  A full product of every factor would be 17 x 3 x 3 x 3 cells; instead
every current gets one cell per seed and the seed's slot picks the weather, so that over the seeds
each current meets wind and waves with it, across it and against it:

* slot 0: wind 6 m/s blowing the way the current flows, Hs 0.3 m (the two push together);
* slot 1: wind 3 m/s blowing across the current (90 degrees to its right), Hs 0.15 m;
* slot 2: wind 6 m/s blowing against the current, Hs 0.3 m (wind against tide).

plus two calm cells (slack water; 0.8 m/s current alone).  Waves travel with the wind.
Seeds: :data:`REPORTING_SEEDS` make every figure of the bench; :data:`TUNING_SEEDS` are the same
grid on other days' noise and waves, for whoever tunes (``python -m benchmarks.nav --seeds tuning``),
and are never reported.  :data:`ISSUE_CASES` are the issue's own two runs, reported beside the grid
(not in its worst case) so the "today" column of the issue can be compared.
"""

from __future__ import annotations

from dataclasses import dataclass

from benchmarks.nav_flight import Cell

CURRENT_SPEEDS_MPS = (0.3, 0.5, 0.8, 1.2)
CURRENT_TOWARD_DEG = (0.0, 90.0, 180.0, 270.0)
REPORTING_SEEDS = (101, 102, 103)
TUNING_SEEDS = (1, 2, 3)
ISSUE_CASES = (Cell(0.5, 90.0, 3.0, 180.0, 0.3, 5), Cell(0.5, 90.0, 3.0, 180.0, 0.3, 6))
"""``usv sitl --current 0.5,90 --wind 3,180 --waves 0.3``, seeds 5 and 6 (the issue's measurement)."""


@dataclass(frozen=True)
class Weather:
    wind_mps: float
    wind_toward_offset_deg: float
    """Where the wind blows TOWARD, relative to where the current flows."""
    waves_hs_m: float


WEATHER_SLOTS = (Weather(6.0, 0.0, 0.3), Weather(3.0, 90.0, 0.15), Weather(6.0, 180.0, 0.3))


def cell(current_mps: float, toward_deg: float, seed_slot: int, seed: int) -> Cell:
    w = WEATHER_SLOTS[seed_slot % len(WEATHER_SLOTS)]
    wind_from = (toward_deg + w.wind_toward_offset_deg + 180.0) % 360.0
    return Cell(current_mps, toward_deg, w.wind_mps, wind_from, w.waves_hs_m, seed)


def full_grid(seeds: tuple[int, ...] = REPORTING_SEEDS) -> list[Cell]:
    """Slack water with the seed's weather, and every current on every seed, the weather picked by the
    seed's slot; then the two calm cells on the first seed."""
    cells = [cell(0.0, 90.0 * slot, slot, seed) for slot, seed in enumerate(seeds)]
    for slot, seed in enumerate(seeds):
        cells += [cell(speed, toward, slot, seed)
                  for speed in CURRENT_SPEEDS_MPS for toward in CURRENT_TOWARD_DEG]
    cells += [Cell(0.0, 0.0, 0.0, 0.0, 0.0, seeds[0]), Cell(0.8, 90.0, 0.0, 0.0, 0.0, seeds[0])]
    return cells


def reduced_grid(seeds: tuple[int, ...] = REPORTING_SEEDS) -> list[Cell]:
    """Two of the hardest cells of the full grid (the regression test, ``usv bench --quick`` and the
    repeatability pair), one flight each per worker: a 1.2 m/s current with 6 m/s of wind and Hs 0.3 m
    pushing the same way (worst LOITER above the jet's idle creep; the circle, the square and the
    samples all miss there today), and 0.5 m/s with 3 m/s of wind across it (worst LOITER below idle
    creep).  Chosen from the full grid on main at 08b0103."""
    return [cell(1.2, 90.0, 0, seeds[0]), cell(0.5, 180.0, 1, seeds[1])]


SAMPLE_CIRCLE_M = 2.5
"""The chapter's sampling circle (section 4.2): the boat must be inside it whenever a bottle fills."""


@dataclass(frozen=True)
class Target:
    """A figure of the issue's table: worst over the grid must be at most ``limit`` (m)."""

    figure: str
    limit_m: float
    text: str


def targets(turn_radius_m: float, circle_radius_m: float) -> list[Target]:
    """The issue's targets, with the limits that depend on the vehicle's parameters filled in."""
    return [
        Target("loiter_max_m_current_above_creep", 1.0,
               "LOITER max distance from the point, current stronger than idle creep: <= 1.0 m"),
        Target("loiter_max_m_current_below_creep", turn_radius_m + 0.5,
               "LOITER max distance from the point, weaker current or slack water: <= minimum turning "
               f"radius (USV_TURN_RAD {turn_radius_m:g} m) + 0.5 m"),
        Target("square_side_max_m", 1.5, "square: distance to the nearest side, max <= 1.5 m"),
        Target("square_mid_leg_rms_m", 0.15, "square: mid-leg cross-track RMS <= 0.15 m"),
        Target("square_mid_leg_max_m", 0.4, "square: mid-leg cross-track max <= 0.4 m"),
        Target("circle_error_max_m", 1.2, "sampling circle: distance from the commanded circle while "
               "circling (chapter Fig. 13 tracking error) <= 1.2 m"),
        Target("sample_distance_max_m", circle_radius_m + 0.6,
               f"every sample <= circle radius ({circle_radius_m:g} m) + 0.6 m from its point (where the "
               "bottle stopped filling)"),
        Target("fill_distance_max_m", SAMPLE_CIRCLE_M,
               f"the boat inside the chapter's {SAMPLE_CIRCLE_M:g} m circle whenever a bottle fills"),
    ]


ARDUROVER_REFERENCE = {
    "source": "issue 14: ArduRover 4.6.2 SITL motorboat flown by the same pymavlink script, currents 0.2-1.0 "
              "m/s (its simulated boat can reverse, and wind and waves do not push it: the easier plant). "
              "Reference values, not measured here.",
    "loiter_max_m": {"current_0.5_toward_90_wind_3_waves_0.3": "3.6-3.7", "weaker_current": 2.2,
                     "stronger_current": "1.8-3.0"},
    "loiter_max_m_current_above_creep": "1.8-3.0",
    "loiter_max_m_current_below_creep": "2.2-3.7",
    "square_side_max_m": "2.3-2.8",
    "square_mid_leg_rms_m": "0.42-0.58",
    "square_mid_leg_max_m": "0.96-1.87",
}
