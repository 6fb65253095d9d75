"""JointEnv's episode ends, on a ParallelEnv scripted to end as a test asks."""

import unittest

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from colony import JointEnv


class Scripted(ParallelEnv):
    """Two agents; `ends` says, per step, each agent's (terminated, truncated)."""

    metadata = {"name": "scripted"}

    def __init__(self, ends):
        self.possible_agents = ["a", "b"]
        self.ends = ends
        self._obs = spaces.Box(0.0, 1.0, (1,), np.float32)
        self._act = spaces.Discrete(2)

    def observation_space(self, agent):
        return self._obs

    def action_space(self, agent):
        return self._act

    def reset(self, seed=None, options=None):
        self.agents, self.t = list(self.possible_agents), 0
        return {a: np.zeros(1, np.float32) for a in self.agents}, {a: {} for a in self.agents}

    def step(self, actions):
        ends = self.ends[self.t]
        self.t += 1
        terms = {a: ends[a][0] for a in self.agents}
        truncs = {a: ends[a][1] for a in self.agents}
        obs = {a: np.zeros(1, np.float32) for a in self.agents}
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        return obs, {a: 1.0 for a in terms}, terms, truncs, {a: {} for a in terms}


class Ends(unittest.TestCase):
    def run_to_end(self, ends):
        env = JointEnv(Scripted(ends))
        env.reset(seed=0)
        for _ in ends:
            _, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        return terminated, truncated, reward

    def test_the_clock_cutting_off_any_agent_makes_the_episode_truncated(self):
        # b is destroyed on the step the clock ends a's episode.
        self.assertEqual(self.run_to_end([{"a": (False, True), "b": (True, False)}])[:2], (False, True))

    def test_an_episode_ended_by_the_game_is_terminated(self):
        ends = [{"a": (True, False), "b": (False, False)}, {"b": (True, False)}]
        terminated, truncated, reward = self.run_to_end(ends)
        self.assertEqual((terminated, truncated), (True, False))
        self.assertEqual(reward, 1.0, "only the agent still in the episode is rewarded")

    def test_a_step_before_the_end_ends_nothing(self):
        env = JointEnv(Scripted([{"a": (False, False), "b": (False, False)}]))
        env.reset(seed=0)
        self.assertEqual(env.step(env.action_space.sample())[2:4], (False, False))


if __name__ == "__main__":
    unittest.main()
