"""Episode seeds, the same for every environment: an explicit seed is the
episode's own (the same as ``colony sort run --seed``), and later resets without
one draw theirs from it, so episodes differ but a run repeats from its first seed."""

from __future__ import annotations

import operator
from typing import Callable, Optional

import numpy as np


class EpisodeSeeds:
    def __init__(self, seed: int):
        self.seed = operator.index(seed)
        self._draws = np.random.default_rng(self.seed)

    def start(self, seed: Optional[int], reset: Callable[[int], None]) -> None:
        """Calls `reset` with the next episode's seed. Nothing changes unless it
        succeeds: a seed the world refuses leaves the episode as it was."""
        if seed is not None:
            # An integer: a float would be truncated into another episode's seed.
            seed = operator.index(seed)
            reset(seed)
            self.seed, self._draws = seed, np.random.default_rng(seed)
        else:
            state = self._draws.bit_generator.state
            drawn = int(self._draws.integers(0, 2**63))
            try:
                reset(drawn)
            except BaseException:
                self._draws.bit_generator.state = state
                raise
            self.seed = drawn
