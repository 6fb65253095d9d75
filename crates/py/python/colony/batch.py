"""Many independent worlds stepped in one call, on every core, for training.

A batch holds ``worlds`` copies of an environment (world ``b`` seeded ``seed + b``)
and steps them all at once in Rust with Python's lock released. Observations,
rewards and flags are stacked arrays (world, robot, ...) that the Rust side
writes in place: :meth:`step` returns the *same* arrays every call, overwritten,
with no copy per step (pass ``copy=True`` to get fresh ones). A world whose
episode ends is reset within the same call (its next seed is drawn from its
previous one), so the arrays always hold live worlds; ``terminated`` and
``truncated`` say which worlds ended on this step, and ``final`` holds each
world's measure after the step, before any reset (PC for sorting; for the
game, the learner's score less the opponent's): for a world that ended, what
it ended with. The observation a world ended on is not kept (its reset's first
is in its place), so a learner that bootstraps from it must step worlds
singly. A world whose next seed cannot be laid out (a crowded scene) tries the
seeds after it.
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from . import _native


class _Batch:
    def _arrays(self, parts: dict[str, tuple]) -> None:
        b = self.worlds
        self.obs = {name: np.zeros((b, *shape), np.float32) for name, shape in parts.items()}
        self.reward = np.zeros((b, self.agents), np.float64)
        self.final = np.zeros(b, np.float64)
        self.terminated = np.zeros(b, np.bool_)
        self.truncated = np.zeros(b, np.bool_)

    def reset(
        self, seed: Optional[int] = None, seeds: Optional[Sequence[int]] = None, copy: bool = False
    ) -> dict[str, np.ndarray]:
        """Starts every world again: world ``b`` with ``seeds[b]``, or ``seed + b``,
        or (neither given) a seed drawn from its last one."""
        self.core.reset(seed, seeds)
        self._observe()
        return {k: v.copy() for k, v in self.obs.items()} if copy else self.obs

    def _result(self, copy: bool):
        out = (self.obs, self.reward, self.terminated, self.truncated, self.final)
        if copy:
            return (
                {k: v.copy() for k, v in self.obs.items()},
                self.reward.copy(),
                self.terminated.copy(),
                self.truncated.copy(),
                self.final.copy(),
            )
        return out


class SortingBatch(_Batch):
    """``worlds`` sorting worlds; takes :class:`~colony.sorting.SortingEnv`'s
    configuration (``robots``, ``scale_robots``, ``max_steps``, ``reward``...;
    continuous actions: an array ``(worlds, robots, 2)`` of forward and turn)."""

    def __init__(
        self,
        worlds: int,
        scene: Optional[str] = None,
        params: Optional[str] = None,
        *,
        seed: int = 0,
        **config,
    ):
        self.core = _native.SortBatch(_native.SortConfig(scene=scene, params=params, **config), worlds, seed)
        self.worlds = self.core.worlds
        self.agents = self.core.agents
        channels, cells, gripper, pose = self.core.layout
        self._arrays(
            {"map": (self.agents, channels, cells, cells), "gripper": (self.agents, gripper), "pose": (self.agents, pose)}
        )

    def _observe(self) -> None:
        self.core.observe(self.obs["map"], self.obs["gripper"], self.obs["pose"])

    def step(self, actions: np.ndarray, copy: bool = False):
        """Steps every world: returns ``(obs, reward, terminated, truncated, final)``."""
        actions = np.ascontiguousarray(actions, dtype=np.float64)
        self.core.step(
            actions,
            self.obs["map"],
            self.obs["gripper"],
            self.obs["pose"],
            self.reward,
            self.terminated,
            self.truncated,
            self.final,
        )
        return self._result(copy)

    def reference(self, method: str) -> np.ndarray:
        """Every world's built-in controllers' commands for this step, ``(worlds, robots, 2)``."""
        return self.core.reference(method)

    def pc(self) -> np.ndarray:
        """Each world's percentage completion now."""
        return self.core.pc()


class GameBatch(_Batch):
    """``worlds`` Capture the Flag or Death Match games with robot-level control;
    takes :class:`~colony.game.GameEnv`'s configuration. Actions are
    ``wheels`` ``(worlds, robots, 2)`` float64, ``fire`` and ``pickup``
    ``(worlds, robots)`` (fire: 0 holds, 1 fires at the nearest enemy, ``2 + k``
    at the k-th robot of ``nearby``; any other code holds)."""

    def __init__(self, worlds: int, mode: str = "ctf", map: Optional[str] = None, *, seed: int = 0, **config):
        self.core = _native.GameBatch(_native.GameConfig(mode=mode, map=map, **config), worlds, seed)
        self.worlds = self.core.worlds
        self.agents = self.core.agents
        self._arrays({name: (self.agents, *shape) for name, shape in self.core.layout.items()})
        self._names = list(self.core.layout.keys())

    def _observe(self) -> None:
        self.core.observe(*(self.obs[n] for n in self._names))

    def step(self, wheels: np.ndarray, fire: np.ndarray, pickup: np.ndarray, copy: bool = False):
        """Steps every world: returns ``(obs, reward, terminated, truncated, final)``."""
        self.core.step(
            np.ascontiguousarray(wheels, dtype=np.float64),
            np.ascontiguousarray(fire, dtype=np.int64),
            np.ascontiguousarray(pickup, dtype=np.bool_),
            *(self.obs[n] for n in self._names),
            self.reward,
            self.terminated,
            self.truncated,
            self.final,
        )
        return self._result(copy)
