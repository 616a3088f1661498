"""Evidence counted in seconds with a leak (the station keepers' give-up rules)."""

from __future__ import annotations


class LeakyEvidence:
    """Seconds of net evidence: up by ``dt`` while a condition holds, down by half that while it
    does not (never below 0), so brief spells either way neither trigger nor clear it."""

    def __init__(self) -> None:
        self.seconds = 0.0

    def add(self, holds: bool, dt_s: float) -> float:
        """Count one step; the evidence so far (s)."""
        self.seconds = max(0.0, self.seconds + (dt_s if holds else -0.5 * dt_s))
        return self.seconds
