"""Where keeping station bow into the current has failed, per vehicle (issue 14): LOITER, GUIDED
and RTL orbit at once in that current for a while (:mod:`companion.modes.holding`), and circle items
circle instead of holding on their circle (:meth:`~companion.modes.stem_hold.StemHold.when_needed`)."""

from __future__ import annotations

import math

STATION_MEMORY_S = 600.0
"""How long a failed station keeping is remembered (:class:`StationTrials`)."""
SAME_CURRENT_MPS = 0.15
"""Estimates within this (vector difference) count as the same current."""
MAX_REMEMBERED = 8
"""At most this many failures are kept (the newest)."""


class StationTrials:
    """Where keeping station bow into the current has been given up for the orbit (the boat made
    headway with the jet idling, or a trial in a weak current was not set back onto its point:
    :mod:`companion.modes.creep`), so that the next hold in the same current orbits at once instead
    of learning it again.  One per vehicle, shared by LOITER, GUIDED and RTL."""

    def __init__(self, memory_s: float = STATION_MEMORY_S,
                 same_current_mps: float = SAME_CURRENT_MPS) -> None:
        self.memory_s, self.same_current_mps = memory_s, same_current_mps
        self._failures: list[tuple[float, tuple[float, float]]] = []

    def failed(self, current_ne_mps: tuple[float, float], t_s: float) -> None:
        """Station keeping in ``current_ne_mps`` was given up at ``t_s``."""
        self._failures = [f for f in self._failures if t_s - f[0] <= self.memory_s][-(MAX_REMEMBERED - 1):]
        self._failures.append((t_s, current_ne_mps))

    def ruled_out(self, current_ne_mps: tuple[float, float], t_s: float) -> bool:
        """Station keeping failed in this current (within ``same_current_mps``) in the last ``memory_s``."""
        return any(t_s - t <= self.memory_s and math.dist(c, current_ne_mps) <= self.same_current_mps
                   for t, c in self._failures)
