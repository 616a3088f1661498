"""Standard normal draws for the simulator's noise processes, fetched from numpy in blocks.

One ``Generator.standard_normal()`` call costs about a microsecond and the simulator needs
a dozen normals per 100 Hz step (sensor noise, gusts, a wandering current).  numpy's
Generator draws the same sequence whether the values are requested one at a time or as
an array, so drawing 4096 at a time changes nothing but the cost, provided nothing else
draws from the same generator in between (a block is drawn only when the previous one is
used up, exactly where the next single draw would have happened).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

BLOCK = 4096


def normal_stream(rng: np.random.Generator, block: int = BLOCK) -> Callable[[], float]:
    """A function returning the next standard normal of ``rng`` (as a Python float).

    It is the ``__next__`` of an endless chain of blocks, each drawn when the previous one
    is used up (no Python frame per draw: the hot path is C)."""
    blocks = iter(lambda: rng.standard_normal(block).tolist(), None)  # never returns None: endless
    return itertools.chain.from_iterable(blocks).__next__
