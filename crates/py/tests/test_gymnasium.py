"""What a Gymnasium user meets first: the registered ids, spaces the checkers
accept without a warning, and images whose colours match the monitor's."""

import os
import re
import unittest
import warnings

import gymnasium
import numpy as np
from gymnasium.utils.env_checker import check_env

import colony  # noqa: F401 (registers the ids)
from colony import CaptureTheFlagEnv, DeathMatchEnv, JointEnv, SortingEnv

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")

IDS = {
    "colony/Sorting-v0": {"robots": 4, "max_steps": 60},
    "colony/CaptureTheFlag-v0": {"max_steps": 60},
    "colony/DeathMatch-v0": {"max_steps": 60, "control": "squad"},
    # With the checker's render checks, which remake it through its spec in each mode.
    "colony/Sorting-v0 rendered": {"robots": 4, "max_steps": 60, "render_mode": "rgb_array"},
}


def boxes(space):
    """Every Box in a (possibly nested) space."""
    if isinstance(space, gymnasium.spaces.Dict):
        return [b for s in space.spaces.values() for b in boxes(s)]
    return [space] if isinstance(space, gymnasium.spaces.Box) else []


def monitor_colours():
    """The monitor's puck colours by kind, from its page script."""
    with open(os.path.join(ROOT, "crates", "monitor", "web", "app.js")) as f:
        line = next(l for l in f if l.startswith("const KIND_COLOURS"))
    return [tuple(int(h[i : i + 2], 16) for i in (0, 2, 4)) for h in re.findall(r"#([0-9a-fA-F]{6})", line)]


class Registry(unittest.TestCase):
    def test_make_finds_every_id_and_it_resets_steps_and_passes_the_checker_without_a_warning(self):
        for name, kwargs in IDS.items():
            with self.subTest(name), warnings.catch_warnings():
                warnings.simplefilter("error")
                env = gymnasium.make(name.split()[0], **kwargs)
                self.assertIsInstance(env.unwrapped, JointEnv)
                obs, _ = env.reset(seed=3)
                self.assertIn(obs, env.observation_space)
                for _ in range(5):
                    obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
                    self.assertIn(obs, env.observation_space)
                check_env(env.unwrapped, skip_render_check="render_mode" not in kwargs)
                env.close()

    def test_keyword_arguments_reach_the_environment(self):
        env = gymnasium.make("colony/Sorting-v0", robots=3, pucks=12, render_mode="rgb_array", render_size=64)
        self.assertEqual(len(env.unwrapped.agents), 3)
        self.assertEqual(env.unwrapped.env.core.pucks, 12)
        env.reset(seed=1)
        self.assertEqual(env.render().shape, (64, 64, 3))

    def test_importing_colony_again_registers_nothing_twice(self):
        import importlib

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            importlib.reload(colony)


class Bounds(unittest.TestCase):
    def test_every_observation_bound_is_finite(self):
        for env in (
            SortingEnv(robots=4),
            SortingEnv(robots=1, pucks=6),
            CaptureTheFlagEnv(),
            DeathMatchEnv(control="squad"),
        ):
            with self.subTest(env=type(env).__name__):
                for box in boxes(env.observation_space(env.possible_agents[0])):
                    self.assertTrue(np.isfinite(box.low).all() and np.isfinite(box.high).all(), box)
                    self.assertTrue((box.low < box.high).all(), box)

    def test_the_sorting_maps_channels_are_bounded_by_pucks_robots_and_one(self):
        env = SortingEnv(robots=5, pucks=30, kinds=3, grid=4)
        high = env.observation_space("robot_0")["map"].high
        self.assertEqual(high.shape, (5, 4, 4))
        np.testing.assert_array_equal(high[:, 0, 0], [30, 30, 30, 4, 1])
        self.assertTrue((high == high[:, :1, :1]).all(), "the same bound in every cell of a channel")

    def test_a_crowd_of_pucks_and_robots_stays_in_the_sorting_space(self):
        # Everything within a few cells of each robot's camera: cells count many.
        env = SortingEnv(robots=12, pucks=120, max_steps=40)
        space = env.observation_space("robot_0")
        obs, _ = env.reset(seed=9)
        rng = np.random.default_rng(1)
        for _ in range(40):
            for o in obs.values():
                self.assertIn(o, space)
            if not env.agents:
                break
            obs, *_ = env.step({a: rng.uniform(-1, 1, 2) for a in env.agents})

    def test_the_games_velocities_are_bounded_and_a_match_stays_within_them(self):
        env = CaptureTheFlagEnv(max_steps=300)
        space = env.observation_space("robot_0")
        own = space["own"]
        self.assertTrue((own.high[4:7] > 1).all(), "a shoved robot may pass its top speed")
        # The map's diagonal in one control step at the slowest type's top speed.
        speed, turn = env.core.motion_bounds
        np.testing.assert_allclose(own.high[4:7], [speed, speed, turn], rtol=1e-6)
        obs, _ = env.reset(seed=2)
        rng = np.random.default_rng(4)
        while env.agents:
            for o in obs.values():
                self.assertIn(o, space)
            actions = {
                a: {"wheels": rng.uniform(-1, 1, 2), "fire": int(rng.integers(0, 3)), "pickup": 1}
                for a in env.agents
            }
            obs, *_ = env.step(actions)


class Colours(unittest.TestCase):
    def test_pucks_are_drawn_in_the_monitors_colours_by_kind(self):
        colours = monitor_colours()
        self.assertEqual(len(colours), 8)
        env = SortingEnv(robots=2, pucks=30, kinds=3, render_mode="rgb_array", render_size=300)
        env.reset(seed=5)
        pixels = env.render().reshape(-1, 3)
        seen = {tuple(int(v) for v in p) for p in np.unique(pixels, axis=0)}
        for kind in range(3):
            self.assertIn(colours[kind], seen, f"kind {kind}'s colour in the frame")
        # The figures' red and green, which the frames once used, are gone.
        self.assertNotIn((214, 39, 40), seen)
        self.assertNotIn((44, 160, 44), seen)


if __name__ == "__main__":
    unittest.main()
