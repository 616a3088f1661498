"""Standard normal draws for the simulator's noise processes, fetched from numpy in blocks.

One ``Generator.standard_normal()`` call costs about a microsecond and the simulator needs
a dozen normals per 100 Hz step (sensor noise, gusts, a wandering current).  numpy's
Generator draws the same sequence whether the values are requested one at a time or as
an array, so drawing 4096 at a time changes nothing but the cost, provided nothing else
draws from the same generator in between (a block is drawn only when the previous one is
used up, exactly where the next single draw would have happened).
"""

from __future__ import annotations

import copy
import itertools
import operator
from collections.abc import Iterator
from typing import Any

import numpy as np

BLOCK = 4096


class NormalStream:
    """``draw()`` returns the next standard normal of ``rng`` (a Python float).

    ``draw`` is the ``__next__`` of an endless chain of blocks (no Python frame per value).
    A deep copy (e.g. ``copy.deepcopy`` of a plant, to try something from the same state)
    continues the same sequence independently: it gets the rest of the current block and a
    copy of the generator.
    """

    __slots__ = ("_current", "_rng", "_size", "_values", "draw")

    def __init__(self, rng: np.random.Generator, block: int = BLOCK, pending: list[float] | None = None
                 ) -> None:
        self._rng, self._size = rng, block
        self._values: list[float] = pending or []
        self._current: Iterator[float] = iter(self._values)
        self.draw = itertools.chain.from_iterable(self._blocks()).__next__

    def _blocks(self) -> Iterator[Iterator[float]]:
        yield self._current
        while True:
            self._values = self._rng.standard_normal(self._size).tolist()
            self._current = iter(self._values)
            yield self._current

    def __deepcopy__(self, memo: dict[int, Any]) -> NormalStream:
        left = operator.length_hint(self._current)
        pending = self._values[len(self._values) - left:] if left else []
        return NormalStream(copy.deepcopy(self._rng, memo), self._size, pending)
