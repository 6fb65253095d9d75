"""A PettingZoo ``ParallelEnv`` as one Gymnasium ``Env``: the whole team is one agent.

Centralised controllers and single-agent learners (and Gymnasium's own
environment checker) see every robot's observation stacked along a first axis,
and give every robot's action at once. A robot that is out of the episode (a
destroyed one in the game) reads zeros and its action is ignored.
"""

from __future__ import annotations

from typing import Any, Optional

import gymnasium
import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv


def stacked(space: spaces.Space, n: int) -> spaces.Space:
    """`space` for `n` agents at once, stacked along a new first axis."""
    if isinstance(space, spaces.Box):
        return spaces.Box(
            np.broadcast_to(space.low, (n, *space.shape)),
            np.broadcast_to(space.high, (n, *space.shape)),
            (n, *space.shape),
            space.dtype,
        )
    if isinstance(space, spaces.Discrete):
        return spaces.MultiDiscrete(np.full(n, space.n), start=np.full(n, space.start))
    if isinstance(space, spaces.MultiBinary):
        return spaces.MultiBinary([n, *np.atleast_1d(space.n)])
    if isinstance(space, spaces.Dict):
        return spaces.Dict({k: stacked(s, n) for k, s in space.spaces.items()})
    raise TypeError(f"cannot stack a {type(space).__name__} space")


def _zeros(space: spaces.Space) -> Any:
    if isinstance(space, spaces.Dict):
        return {k: _zeros(s) for k, s in space.spaces.items()}
    return np.zeros(space.shape, space.dtype)


def _stack(values: list, space: spaces.Space) -> Any:
    if isinstance(space, spaces.Dict):
        return {k: _stack([v[k] for v in values], s) for k, s in space.spaces.items()}
    return np.stack([np.asarray(v, dtype=space.dtype) for v in values])


def _pick(joint: Any, i: int, space: spaces.Space) -> Any:
    if isinstance(space, spaces.Dict):
        return {k: _pick(joint[k], i, s) for k, s in space.spaces.items()}
    value = np.asarray(joint)[i]
    if isinstance(space, spaces.Discrete):
        return int(value)
    return value


class JointEnv(gymnasium.Env):
    """Every agent of `env` controlled as one. The reward is the sum of the
    agents' rewards; the episode ends when no agent is left."""

    def __init__(self, env: ParallelEnv):
        self.env = env
        self.agents = list(env.possible_agents)
        first = self.agents[0]
        self._agent_obs = env.observation_space(first)
        self._agent_act = env.action_space(first)
        self.observation_space = stacked(self._agent_obs, len(self.agents))
        self.action_space = stacked(self._agent_act, len(self.agents))
        self.metadata = env.metadata
        self.render_mode = getattr(env, "render_mode", None)

    def _joint(self, obs: dict) -> Any:
        return _stack([obs.get(a, _zeros(self._agent_obs)) for a in self.agents], self._agent_obs)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        obs, infos = self.env.reset(seed=seed, options=options)
        return self._joint(obs), {"agents": infos}

    def step(self, action: Any):
        live = set(self.env.agents)
        actions = {a: _pick(action, i, self._agent_act) for i, a in enumerate(self.agents) if a in live}
        obs, rewards, terms, truncs, infos = self.env.step(actions)
        reward = float(sum(rewards.values()))
        # Ended by the clock if any agent was cut off by it, else by the game.
        over = not self.env.agents
        truncated = over and any(truncs.values())
        terminated = over and not truncated
        return self._joint(obs), reward, terminated, truncated, {"agents": infos}

    def render(self):
        return self.env.render()

    def close(self):
        self.env.close()
