"""Capture the Flag and Death Match under PettingZoo's and Gymnasium's own
checkers, batched matches, and the "human" view over a real hub."""

import time
import unittest
import warnings

import numpy as np
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test

from colony import CaptureTheFlagEnv, DeathMatchEnv, GameBatch, GameEnv, JointEnv

from hubwatch import heard


def toward_enemy_flag(obs):
    """A scripted learner: drive at the enemy flag, fire at the nearest enemy, grab the flag."""
    flag = obs["flags"][1]
    turn = float(np.clip(np.arctan2(flag[2], flag[1]), -1, 1))
    return {"wheels": np.array([0.8, turn]), "fire": 1, "pickup": 1}


def episode(env, seed, steps):
    obs, _ = env.reset(seed=seed)
    trace = []
    for _ in range(steps):
        if not env.agents:
            break
        obs, rew, term, trunc, info = env.step({a: toward_enemy_flag(obs[a]) for a in env.agents})
        trace.append(
            (
                tuple(sorted(rew.items())),
                tuple(sorted(term.items())),
                sum(float(o["own"].sum() + o["nearby"].sum() + o["patch"].sum()) for o in obs.values()),
            )
        )
    return trace


class PettingZooChecks(unittest.TestCase):
    def test_parallel_api_test_passes_for_capture_the_flag_and_death_match(self):
        parallel_api_test(CaptureTheFlagEnv(max_steps=150), num_cycles=150)
        parallel_api_test(DeathMatchEnv(max_steps=150), num_cycles=150)

    def test_parallel_api_test_passes_with_squad_orders_against_the_scripted_player(self):
        parallel_api_test(CaptureTheFlagEnv(max_steps=150, control="squad"), num_cycles=150)

    def test_parallel_seed_test_passes(self):
        parallel_seed_test(lambda: CaptureTheFlagEnv(max_steps=60), num_cycles=60)


class GymnasiumChecks(unittest.TestCase):
    def test_the_env_checker_passes_for_the_team_as_one_agent(self):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            # Made without gymnasium.make, it has no spec to try the other render
            # modes with (test_gymnasium makes it through the registry).
            warnings.filterwarnings("ignore", message=".*not having a spec")
            check_env(JointEnv(CaptureTheFlagEnv(max_steps=50, render_mode="rgb_array")), skip_render_check=False)
            check_env(JointEnv(DeathMatchEnv(max_steps=50, control="squad")), skip_render_check=True)


class Episodes(unittest.TestCase):
    def test_the_same_seed_gives_identical_episodes_and_another_seed_differs(self):
        a = episode(CaptureTheFlagEnv(max_steps=200), seed=5, steps=200)
        self.assertEqual(a, episode(CaptureTheFlagEnv(max_steps=200), seed=5, steps=200))
        self.assertNotEqual(a, episode(CaptureTheFlagEnv(max_steps=200), seed=6, steps=200))

    def test_a_match_against_the_scripted_player_plays_to_its_end(self):
        env = CaptureTheFlagEnv(max_steps=600)
        obs, _ = env.reset(seed=3)
        total, steps = 0.0, 0
        while env.agents:
            obs, rew, term, trunc, info = env.step({a: toward_enemy_flag(obs[a]) for a in env.agents})
            total += sum(rew.values())
            steps += 1
        score = env.score()
        self.assertEqual(set(score), {"red", "blue", "winner"})
        # It ran to the clock, or ended before it with a winner or with every learner destroyed.
        if steps < 600:
            self.assertTrue(score["winner"] is not None or not any(env.core.alive()), (steps, score))
        # Fighting happened: rewards include damage dealt and taken.
        self.assertNotEqual(total, 0.0)

    def test_destroyed_robots_leave_the_episode_terminated_and_never_come_back(self):
        # Two scouts walk into six robots that fire on their own.
        env = DeathMatchEnv(learner="alpha:scout,scout", max_steps=1500)
        obs, _ = env.reset(seed=1)
        destroyed, cut_off = set(), set()
        while env.agents:
            obs, rew, term, trunc, info = env.step({a: toward_enemy_flag(obs[a]) for a in env.agents})
            alive = dict(zip(env.possible_agents, env.core.alive()))
            for a in term:
                self.assertNotIn(a, destroyed | cut_off, "an agent that left came back")
                self.assertFalse(term[a] and trunc[a])
                if term[a] and not alive[a]:
                    destroyed.add(a)
                elif term[a] or trunc[a]:
                    cut_off.add(a)
                else:
                    self.assertTrue(alive[a], "a destroyed robot is still an agent")
        self.assertTrue(destroyed, "a scout was destroyed, and left terminated")

    def test_bad_actions_and_configuration_are_clear_errors_never_crashes(self):
        env = CaptureTheFlagEnv(max_steps=20)
        env.reset(seed=0)
        wild = {"wheels": np.array([np.nan, np.inf]), "fire": 1, "pickup": True}
        env.step({a: wild for a in env.agents})
        robot = env.agents[0]
        for bad in (
            {"robot_999": wild},
            {robot: {"wheels": [0.0, 0.0]}},
            {robot: {**wild, "jump": 1}},
            {robot: [0.0, 0.0, 1, 1]},
            {robot: {**wild, "fire": 10**9}},
            {robot: {**wild, "fire": -1}},
            {robot: {**wild, "fire": 1.0}},
            {robot: {**wild, "wheels": 0.5}},
            {robot: {**wild, "pickup": 2}},
        ):
            with self.subTest(bad=str(bad)):
                with self.assertRaises(ValueError):
                    env.step(bad)
        squads = CaptureTheFlagEnv(max_steps=20, control="squad")
        squads.reset(seed=0)
        for bad in ({"squad_nobody": 1}, {squads.agents[0]: 99}, {squads.agents[0]: -5}):
            with self.assertRaises(ValueError):
                squads.step(bad)
        for kwargs in (
            {"mode": "chess"},
            {"learner": "alpha:dragon"},
            {"opponent_policy": "cheating"},
            {"control": "telepathy"},
            {"patch": 0},
            {"nearby": 0},
            {"nearby": 10**9},
            {"max_steps": 0},
            {"rewards": {"money": 1.0}},
            {"rewards": {"score": float("nan")}},
            {"map": "/nonexistent.map"},
            {"render_mode": "hologram"},
            {"render_mode": "rgb_array", "render_size": 10**5},
            {"render_mode": "rgb_array", "render_size": -1},
        ):
            with self.subTest(**{k: str(v) for k, v in kwargs.items()}):
                with self.assertRaises((ValueError, OSError, TypeError)):
                    GameEnv(**kwargs)

    def test_closing_the_human_view_stops_keeping_the_matchs_packets(self):
        env = CaptureTheFlagEnv(max_steps=20, render_mode="human", hub="127.0.0.1:9", render_speed=100.0)
        env.reset(seed=1)
        env.close()
        env.step({})
        self.assertEqual(env.core.take_packets(), [])

    def test_rgb_array_rendering_gives_an_image_of_the_battlefield(self):
        env = CaptureTheFlagEnv(render_mode="rgb_array", render_size=160)
        env.reset(seed=2)
        image = env.render()
        self.assertEqual((image.shape, image.dtype), ((160, 160, 3), np.uint8))
        self.assertGreater(len(np.unique(image.reshape(-1, 3), axis=0)), 4)


class HumanView(unittest.TestCase):
    def test_human_mode_publishes_the_match_to_a_hub_a_subscriber_reads(self):
        def make(hub):
            env = CaptureTheFlagEnv(max_steps=300, render_mode="human", hub=hub, render_speed=10.0)
            env.last_obs, _ = env.reset(seed=1)
            return env

        def step(env):
            env.last_obs = env.step({a: toward_enemy_flag(env.last_obs[a]) for a in env.agents})[0]

        states = heard(self, "game.state", make, step)
        self.assertTrue(states, "a subscriber of game.state heard the match")
        self.assertIn("game.state", states[0].subjects)


class Batches(unittest.TestCase):
    def test_a_batch_with_no_nearby_robots_or_past_its_budget_is_refused(self):
        # `nearby=0` once panicked inside the batch (pieces of no values).
        with self.assertRaises(ValueError):
            GameBatch(2, nearby=0)
        with self.assertRaises(ValueError):
            GameBatch(65536)
        with self.assertRaises(ValueError):
            GameBatch(2, control="squad")

    def test_a_batch_of_matches_steps_like_the_same_matches_one_at_a_time(self):
        batch = GameBatch(2, max_steps=30)
        obs = batch.reset(seed=40)
        n = batch.agents
        singles = [CaptureTheFlagEnv(max_steps=30) for _ in range(2)]
        for b, env in enumerate(singles):
            env.reset(seed=40 + b)
        rng = np.random.default_rng(1)
        for t in range(29):
            wheels = rng.uniform(-1, 1, (2, n, 2))
            fire = rng.integers(0, 3, (2, n))
            pickup = rng.integers(0, 2, (2, n)).astype(bool)
            obs, reward, term, trunc, final = batch.step(wheels, fire, pickup)
            for b, env in enumerate(singles):
                acts = {
                    a: {"wheels": wheels[b, i], "fire": fire[b, i], "pickup": pickup[b, i]}
                    for i, a in enumerate(env.possible_agents)
                    if a in env.agents
                }
                o, r, _, _, _ = env.step(acts)
                for i, a in enumerate(env.possible_agents):
                    if a in o:
                        np.testing.assert_array_equal(obs["own"][b, i], o[a]["own"])
                        self.assertEqual(reward[b, i], r[a])
        obs, reward, term, trunc, final = batch.step(np.zeros((2, n, 2)), np.zeros((2, n)), np.zeros((2, n), bool))
        self.assertTrue(trunc.all(), "the 30th step ends both matches, which start again")
        self.assertTrue((obs["own"][:, :, 13] == 0).all(), "steps / max_steps is 0 after the reset")


if __name__ == "__main__":
    unittest.main()
