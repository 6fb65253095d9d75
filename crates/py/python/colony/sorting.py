"""Swarm sorting (the cache-consensus paper's task) as a PettingZoo ``ParallelEnv``.

One agent per robot. Each step every robot sees what the paper's robots perceive,
as arrays (``map``: a grid over its camera's footprint, one channel per puck kind
plus robots and obstacles; ``gripper``: empty or the kind it carries; ``pose``:
its place in the arena for CACHECONS-style methods), and is told a wheel command.
The scene and the methods' parameters come from the same TOML files as
``colony sort run``; the same seed gives the same episode, bit for bit.

The built-in methods (BHD, PROBSEEK, CACHECONS) are reference policies
(:meth:`SortingEnv.reference_actions`), so a learned controller can be compared
with them on the same seeds.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from . import _native
from ._actions import agent_index, choice, wheels
from ._render import HumanView, check_mode
from ._seeding import EpisodeSeeds

METHODS = ("bhd", "probseek", "cachecons")


class SortingEnv(ParallelEnv):
    """Robots sorting pucks into clusters of one kind.

    Parameters:
        scene, params: paths of a scene and a sorting-parameters TOML file
            (``configs/scene.toml``, ``configs/sort.toml``); None takes the
            built-in standard configuration, as ``colony sort run`` does.
        robots, pucks, kinds: override the scene's robot count, puck count and
            puck kinds (``colony sort run --robots --pucks --types``).
        scale_robots: the standard scene scaled to this many robots, 10 pucks
            each, the arena grown to keep the paper's densities (``--scale-robots``).
        max_steps: the episode is truncated after this many control steps.
        pc_target: the episode terminates once percentage completion reaches it.
        reward: ``"pc"`` (PC each step), ``"pc_change"`` or ``"twc_change"`` (this
            step's increment of the time-weighted completion of PC sampled every
            step), all as fractions (PC / 100); every robot gets the team's reward.
        grid: cells per side of the local map.
        engine: the contact engine that steps the arena, ``"rapier"`` or
            ``"disc"`` (``--engine``); None keeps the scene's (``physics.engine``).
        actions: ``"continuous"`` (forward and turn in [-1, 1], float64) or
            ``"discrete"`` (an index into :attr:`discrete_actions`).
        render_mode: ``"rgb_array"`` (an image of the arena) or ``"human"`` (each
            step's ``vision`` published to the hub at ``hub``, so colony's monitor
            shows the run live, paced to ``render_speed`` times real time).
    """

    # One frame a control step: 14/3 a second in the paper's scene (each instance
    # sets its own scene's rate).
    metadata = {"name": "colony_sorting_v0", "render_modes": ["rgb_array", "human"], "render_fps": 14 / 3}

    def __init__(
        self,
        scene: Optional[str] = None,
        params: Optional[str] = None,
        *,
        robots: Optional[int] = None,
        pucks: Optional[int] = None,
        kinds: Optional[int] = None,
        scale_robots: Optional[int] = None,
        max_steps: int = 2000,
        pc_target: Optional[float] = None,
        reward: str = "pc_change",
        grid: int = 16,
        engine: Optional[str] = None,
        actions: str = "continuous",
        render_mode: Optional[str] = None,
        render_size: int = 400,
        hub: str = "127.0.0.1:7400",
        render_speed: float = 1.0,
        seed: int = 0,
    ):
        if actions not in ("continuous", "discrete"):
            raise ValueError(f"actions must be 'continuous' or 'discrete', not {actions!r}")
        check_mode(self.metadata, render_mode, render_size)
        config = _native.SortConfig(
            scene=scene,
            params=params,
            robots=robots,
            pucks=pucks,
            kinds=kinds,
            scale_robots=scale_robots,
            max_steps=max_steps,
            pc_target=pc_target,
            reward=reward,
            grid=grid,
            engine=engine,
        )
        self.core = _native.SortCore(config, seed)
        self.discrete = actions == "discrete"
        self.render_mode = render_mode
        self.render_size = render_size
        self.metadata = {**SortingEnv.metadata, "render_fps": 1.0 / self.core.step_seconds}
        self._human = HumanView(hub, self.metadata["render_fps"] * render_speed) if render_mode == "human" else None
        self._seeds = EpisodeSeeds(seed)
        n = self.core.agents
        self.possible_agents = [f"robot_{i}" for i in range(n)]
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self.agents = []
        channels, grid_cells, gripper, pose = self.core.layout
        self._map = np.zeros((n, channels, grid_cells, grid_cells), np.float32)
        self._gripper = np.zeros((n, gripper), np.float32)
        self._pose = np.zeros((n, pose), np.float32)
        self._actions = np.zeros((n, 2), np.float64)
        self._indices = np.zeros(n, np.uint32)
        self.discrete_actions = self.core.discrete_actions()
        # Each channel's most per cell: every puck of the world (carried ones are
        # left out, so fewer), every other robot, and 1 for the obstacle flag. A
        # bound of 0 (a lone robot) is raised to 1, since Gymnasium's checker
        # warns of a Box whose low equals its high.
        kinds = self.core.kinds
        high = np.empty((channels, 1, 1), np.float32)
        high[:kinds] = max(self.core.pucks, 1)
        high[kinds] = max(n - 1, 1)
        high[kinds + 1] = 1.0
        self._obs_space = spaces.Dict(
            {
                "map": spaces.Box(
                    0.0,
                    np.broadcast_to(high, (channels, grid_cells, grid_cells)),
                    (channels, grid_cells, grid_cells),
                    np.float32,
                ),
                "gripper": spaces.Box(0.0, 1.0, (gripper,), np.float32),
                "pose": spaces.Box(-1.0, 1.0, (pose,), np.float32),
            }
        )
        if self.discrete:
            self._act_space = spaces.Discrete(len(self.discrete_actions))
        else:
            self._act_space = spaces.Box(-1.0, 1.0, (2,), np.float64)

    # The same space object for every agent and call (PettingZoo checks it is),
    # kept on the environment rather than in a cache that would outlive it.
    def observation_space(self, agent: str) -> spaces.Space:
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Space:
        return self._act_space

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        self._seeds.start(seed, self.core.reset)
        self.agents = list(self.possible_agents)
        self.core.observe(self._map, self._gripper, self._pose)
        if self._human is not None:
            self._human.publish(self.core.vision_packets())
        return self._observations(), {a: {"pc": self.core.pc} for a in self.agents}

    def step(self, actions: dict[str, Any]):
        if not self.agents:
            raise RuntimeError("the episode is over: call reset()")
        # A robot with no action this step stands still.
        n = len(self.discrete_actions)
        live = set(self.agents)
        if self.discrete:
            self._indices.fill(0)
            for a, act in actions.items():
                self._indices[agent_index(a, self._index, live)] = choice(a, act, n, "the action")
            reward, pc, terminated, truncated = self.core.step_discrete(self._indices)
        else:
            self._actions.fill(0.0)
            for a, act in actions.items():
                self._actions[agent_index(a, self._index, live)] = wheels(a, act)
            reward, pc, terminated, truncated = self.core.step(self._actions)
        self.core.observe(self._map, self._gripper, self._pose)
        obs = self._observations()
        rewards = {a: float(reward) for a in self.agents}
        terms = {a: bool(terminated) for a in self.agents}
        truncs = {a: bool(truncated) for a in self.agents}
        infos = {a: {"pc": pc} for a in self.agents}
        if self._human is not None:
            self._human.publish(self.core.vision_packets())
        if terminated or truncated:
            self.agents = []
        return obs, rewards, terms, truncs, infos

    def reference_actions(self, method: str) -> dict[str, Any]:
        """This step's actions of a built-in method (``"bhd"``, ``"probseek"``,
        ``"cachecons"``), one controller per robot with the random stream
        ``colony sort run`` gives it: stepping with them reproduces that run.
        Call it once per step (the controllers advance); continuous actions only."""
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, not {method!r}")
        if self.discrete:
            raise ValueError("the built-in methods drive with continuous actions")
        commands = self.core.reference(method)
        return {a: commands[i] for i, a in enumerate(self.agents)}

    @property
    def pc(self) -> float:
        """Percentage completion of the sorting now, 0 to 100."""
        return self.core.pc

    def render(self):
        if self.render_mode == "rgb_array":
            return self.core.render(self.render_size, self.render_size)
        return None

    def state(self) -> np.ndarray:
        """The whole swarm's observations stacked (map, gripper and pose
        flattened per robot), for centralised critics."""
        n = len(self.possible_agents)
        return np.concatenate(
            [self._map.reshape(n, -1), self._gripper, self._pose], axis=1
        ).reshape(-1)

    def close(self):
        if self._human is not None:
            self._human.close()
            self._human = None

    def _observations(self) -> dict[str, dict[str, np.ndarray]]:
        # Copies: an agent's observation must not change under a caller who kept it.
        return {
            a: {"map": self._map[i].copy(), "gripper": self._gripper[i].copy(), "pose": self._pose[i].copy()}
            for i, a in enumerate(self.agents)
        }


def parallel_env(**kwargs) -> SortingEnv:
    """PettingZoo's conventional constructor name."""
    return SortingEnv(**kwargs)
