"""Episode seeds, the same for every environment: an explicit seed is the
episode's own (the same as ``colony sort run --seed``), and later resets without
one draw theirs from it, so episodes differ but a run repeats from its first seed."""

from __future__ import annotations

from typing import Callable, Optional

import numpy as np


class EpisodeSeeds:
    def __init__(self, seed: int):
        self.seed = int(seed)
        self._draws = np.random.default_rng(self.seed)

    def start(self, seed: Optional[int], reset: Callable[[int], None]) -> None:
        """Calls `reset` with the next episode's seed. Nothing changes unless it
        succeeds: a seed the world refuses leaves the episode as it was."""
        if seed is not None:
            reset(int(seed))
            self.seed, self._draws = int(seed), np.random.default_rng(int(seed))
        else:
            self.seed = int(self._draws.integers(0, 2**63))
            reset(self.seed)
