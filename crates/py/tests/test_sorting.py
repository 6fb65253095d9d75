"""The sorting environment under PettingZoo's and Gymnasium's own checkers, and
its built-in methods against `colony sort run`."""

import csv
import gc
import os
import subprocess
import tempfile
import unittest
import warnings

import time
import weakref

import numpy as np
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test

from colony import JointEnv, SortingBatch, SortingEnv, _native
from hubwatch import heard

COLONY = os.environ.get("COLONY_BIN", "colony")


def small(**kwargs):
    kwargs.setdefault("robots", 4)
    kwargs.setdefault("max_steps", 150)
    return SortingEnv(**kwargs)


def episode(env, seed, steps, actions_seed=5):
    """Rewards, PCs and a digest of the observations of `steps` random steps."""
    rng = np.random.default_rng(actions_seed)
    obs, _ = env.reset(seed=seed)
    trace = [sum(float(o["map"].sum() + o["pose"].sum()) for o in obs.values())]
    for _ in range(steps):
        if not env.agents:
            break
        actions = {a: rng.uniform(-1, 1, 2) for a in env.agents}
        obs, rew, term, trunc, info = env.step(actions)
        trace.append(
            (
                sum(rew.values()),
                next(iter(info.values()))["pc"],
                sum(float(o["map"].sum() + o["gripper"].sum() + o["pose"].sum()) for o in obs.values()),
            )
        )
    return trace


class PettingZooChecks(unittest.TestCase):
    def test_parallel_api_test_passes_with_continuous_actions(self):
        parallel_api_test(small(), num_cycles=200)

    def test_parallel_api_test_passes_with_discrete_actions(self):
        parallel_api_test(small(actions="discrete", reward="twc_change"), num_cycles=200)

    def test_parallel_seed_test_passes(self):
        parallel_seed_test(lambda: small(max_steps=60), num_cycles=60)


class GymnasiumChecks(unittest.TestCase):
    def test_the_env_checker_passes_for_the_swarm_as_one_agent(self):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            # Made without gymnasium.make, it has no spec to try the other render
            # modes with (test_gymnasium makes it through the registry).
            warnings.filterwarnings("ignore", message=".*not having a spec")
            check_env(JointEnv(small(render_mode="rgb_array")), skip_render_check=False)
            check_env(JointEnv(small(actions="discrete")), skip_render_check=True)


class Determinism(unittest.TestCase):
    def test_the_same_seed_gives_identical_episodes_twice_and_another_seed_differs(self):
        a = episode(small(), seed=11, steps=120)
        b = episode(small(), seed=11, steps=120)
        self.assertEqual(a, b)
        # One environment reset with the same seed repeats itself too.
        env = small()
        self.assertEqual(episode(env, seed=11, steps=120), episode(env, seed=11, steps=120))
        self.assertNotEqual(a, episode(small(), seed=12, steps=120))

    def test_resets_without_a_seed_give_new_episodes_that_repeat_from_the_first_seed(self):
        def three(env):
            env.reset(seed=3)
            return [episode_start(env) for _ in range(2)]

        def episode_start(env):
            obs, _ = env.reset()
            return float(sum(o["pose"].sum() for o in obs.values()))

        first, second = three(small()), three(small())
        self.assertEqual(first, second)
        self.assertNotEqual(first[0], first[1])


class Observations(unittest.TestCase):
    def test_observations_lie_in_their_spaces_and_do_not_change_under_a_caller(self):
        env = small()
        obs, _ = env.reset(seed=2)
        kept = {a: {k: v.copy() for k, v in o.items()} for a, o in obs.items()}
        space = env.observation_space(env.agents[0])
        for o in obs.values():
            self.assertTrue(space.contains(o), o)
        env.step({a: np.array([1.0, 0.3]) for a in env.agents})
        for a, o in obs.items():
            for k in o:
                np.testing.assert_array_equal(o[k], kept[a][k])

    def test_bad_actions_are_refused_or_made_safe_never_a_crash(self):
        env = small()
        env.reset(seed=1)
        # Non-finite and out-of-range commands: the wheels' clamp and NaN as zero.
        env.step({a: np.array([np.nan, np.inf]) for a in env.agents})
        env.step({a: np.array([1e300, -1e300]) for a in env.agents})
        self.assertTrue(np.isfinite(env.pc))
        with self.assertRaises(ValueError):
            env.step({env.agents[0]: np.array([1.0, 2.0, 3.0])})
        d = small(actions="discrete")
        d.reset(seed=1)
        with self.assertRaises(ValueError):
            d.step({a: 999 for a in d.agents})

    def test_unknown_agents_and_actions_outside_their_space_are_refused(self):
        env = small()
        env.reset(seed=1)
        for bad in ({"typo": np.zeros(2)}, {"robot_0": 1.0}, {"robot_0": np.zeros(3)}):
            with self.subTest(bad=str(bad)):
                with self.assertRaises(ValueError):
                    env.step(bad)
        d = small(actions="discrete")
        d.reset(seed=1)
        for bad in (2.7, -1, 7, "3"):
            with self.subTest(action=bad):
                with self.assertRaises(ValueError):
                    d.step({"robot_0": bad})
        d.step({"robot_0": np.int64(3), "robot_1": 1})

    def test_a_seed_must_be_an_integer_not_a_float_that_would_be_truncated(self):
        env = small()
        for bad in (1.9, "3"):
            with self.assertRaises(TypeError):
                env.reset(seed=bad)
        with self.assertRaises(TypeError):
            SortingBatch(2, robots=4).reset(seed=1.5)

    def test_a_seed_the_world_refuses_leaves_the_episode_as_it_was(self):
        env, twin = small(), small()
        env.reset(seed=4)
        twin.reset(seed=4)
        with self.assertRaises((OverflowError, ValueError)):
            env.reset(seed=2**64)
        self.assertEqual(env.agents, twin.agents)
        go = {a: np.array([1.0, 0.2]) for a in env.agents}
        a, b = env.step(go), twin.step(go)
        np.testing.assert_array_equal(a[0]["robot_0"]["pose"], b[0]["robot_0"]["pose"])
        # The seeds of later resets still follow from 4.
        np.testing.assert_array_equal(env.reset()[0]["robot_1"]["pose"], twin.reset()[0]["robot_1"]["pose"])

    def test_an_environment_is_freed_when_it_is_dropped(self):
        env = small()
        env.observation_space("robot_0")
        JointEnv(env)
        gone = weakref.ref(env)
        del env
        gc.collect()
        self.assertIsNone(gone(), "nothing keeps an environment alive")

    def test_fortran_order_and_misshapen_buffers_are_refused_not_misread(self):
        core = _native.SortCore(_native.SortConfig(robots=3, pucks=10, kinds=2, grid=4))
        channels, g, gripper, pose = core.layout
        m = np.zeros((3, channels, g, g), np.float32)
        grip = np.zeros((3, gripper), np.float32)
        with self.assertRaises(ValueError):
            core.observe(m, grip, np.asfortranarray(np.zeros((3, pose), np.float32)))
        with self.assertRaises(ValueError):
            core.step(np.asfortranarray(np.zeros((3, 2))))
        with self.assertRaises(ValueError):
            core.step(np.zeros(6))

    def test_sizes_past_what_a_machine_holds_are_clear_errors(self):
        # A huge scale once overflowed (10 pucks a robot) and panicked.
        for kwargs in ({"scale_robots": 2**62}, {"scale_robots": 2**64 - 1}, {"scale_robots": 0}):
            with self.assertRaises((ValueError, OverflowError)):
                _native.SortConfig(**kwargs)
        with self.assertRaises(ValueError):
            SortingBatch(65536, scale_robots=1000)

    def test_the_contact_engine_is_chosen_by_name_and_an_unknown_one_refused(self):
        env = small(engine="rapier")
        env.reset(seed=1)
        env.step({})
        with self.assertRaisesRegex(ValueError, r'no contact engine named "warp" \(there are: rapier, disc\)'):
            SortingEnv(engine="warp")
        with self.assertRaisesRegex(ValueError, "warp"):
            SortingBatch(2, robots=2, engine="warp")

    def test_the_human_view_is_paced_to_the_scenes_control_step(self):
        env = small(render_mode="human", hub="127.0.0.1:9", render_speed=20.0)
        self.addCleanup(env.close)
        env.reset(seed=1)
        started = time.monotonic()
        for _ in range(10):
            env.step({})
        # Ten steps of 3/14 s at 20 times real time take at least 0.1 s.
        self.assertGreaterEqual(time.monotonic() - started, 10 * (3 / 14) / 20 * 0.99)

    def test_bad_configuration_is_a_clear_error(self):
        for kwargs in (
            {"robots": 0},
            {"grid": 0},
            {"reward": "money"},
            {"actions": "telepathy"},
            {"scene": "/nonexistent/scene.toml"},
            {"pc_target": float("nan")},
            {"render_mode": "hologram"},
            {"render_mode": "rgb_array", "render_size": 10**5},
        ):
            with self.subTest(**{k: str(v) for k, v in kwargs.items()}):
                with self.assertRaises((ValueError, OSError)):
                    SortingEnv(**kwargs)

    def test_rgb_array_rendering_gives_an_image_of_the_arena(self):
        env = small(render_mode="rgb_array", render_size=120)
        env.reset(seed=4)
        image = env.render()
        self.assertEqual(image.shape, (120, 120, 3))
        self.assertEqual(image.dtype, np.uint8)
        self.assertGreater(len(np.unique(image.reshape(-1, 3), axis=0)), 3, "arena, pucks and robots")


class HumanView(unittest.TestCase):
    def test_human_mode_publishes_the_live_vision_a_subscriber_reads(self):
        def make(hub):
            env = small(render_mode="human", hub=hub, render_speed=50.0)
            env.reset(seed=1)
            return env

        frames = heard(self, "vision", make, lambda env: env.step({}))
        self.assertTrue(frames, "a subscriber of vision heard the swarm")
        self.assertIn("vision", frames[0].subjects)


class ReferencePolicies(unittest.TestCase):
    def test_cachecons_through_the_environment_reaches_the_pc_of_colony_sort_run(self):
        steps, seed = 400, 9
        with tempfile.TemporaryDirectory() as out:
            subprocess.run(
                [COLONY, "sort", "run", "--method", "cachecons", "--trials", "1",
                 "--steps", str(steps), "--seed", str(seed), "--out", out],
                check=True, capture_output=True, timeout=300,
            )
            with open(os.path.join(out, "cachecons-types2-trial00.csv")) as f:
                series = {int(r["step"]): float(r["pc"]) for r in csv.DictReader(f)}
        env = SortingEnv(max_steps=steps)
        env.reset(seed=seed)
        ours = {0: env.pc}
        for step in range(1, steps + 1):
            _, _, _, _, info = env.step(env.reference_actions("cachecons"))
            ours[step] = next(iter(info.values()))["pc"]
        self.assertFalse(env.agents, "truncated at max_steps")
        for step, pc in series.items():
            self.assertAlmostEqual(ours[step], pc, places=4, msg=f"PC at step {step}")
        self.assertGreater(series[steps], 0.0)


class Batches(unittest.TestCase):
    def test_a_batch_steps_like_the_same_worlds_one_at_a_time(self):
        batch = SortingBatch(3, robots=4, max_steps=40)
        obs = batch.reset(seed=20)
        self.assertEqual(obs["map"].shape[:2], (3, 4))
        rng = np.random.default_rng(0)
        actions = rng.uniform(-1, 1, (40, 3, 4, 2))
        singles = [small(max_steps=40) for _ in range(3)]
        for b, env in enumerate(singles):
            env.reset(seed=20 + b)
        for t in range(39):
            obs, reward, term, trunc, final = batch.step(actions[t])
            for b, env in enumerate(singles):
                o, r, _, _, _ = env.step({a: actions[t, b, i] for i, a in enumerate(env.agents)})
                np.testing.assert_array_equal(obs["pose"][b], np.stack([o[a]["pose"] for a in env.possible_agents]))
                self.assertEqual(reward[b, 0], r["robot_0"])
        self.assertFalse(term.any() or trunc.any())
        # The 40th step ends every world; each is reset within the call.
        obs, reward, term, trunc, final = batch.step(actions[39])
        for b, env in enumerate(singles):
            env.step({a: actions[39, b, i] for i, a in enumerate(env.agents)})
        self.assertTrue(trunc.all())
        np.testing.assert_allclose(final, [env.pc for env in singles], atol=0)

    def test_worlds_ending_at_different_steps_repeat_from_the_first_seeds(self):
        def run():
            batch = SortingBatch(3, robots=4, max_steps=400, pc_target=20.0)
            batch.reset(seed=5)
            ends, finals = [], []
            for t in range(400):
                _, _, term, trunc, final = batch.step(batch.reference("cachecons"))
                ends += [(t, b) for b in np.flatnonzero(term | trunc)]
                finals.append(final.copy())
            return ends, np.array(finals), batch.pc()

        first, second = run(), run()
        self.assertEqual(first[0], second[0])
        np.testing.assert_array_equal(first[1], second[1])
        self.assertGreater(len({t for t, _ in first[0]}), 1, "worlds ended at different steps")

    def test_final_is_each_worlds_pc_after_the_step(self):
        batch = SortingBatch(2, robots=4, max_steps=50)
        batch.reset(seed=1)
        for _ in range(5):
            _, _, _, _, final = batch.step(np.zeros((2, 4, 2)))
            np.testing.assert_array_equal(final, batch.pc())

    def test_a_world_whose_next_seed_cannot_be_laid_out_tries_the_seeds_after_it(self):
        # 437 pucks crowd the standard arena: some seeds cannot place them all
        # (12's successor among them), which once made every later step fail.
        batch = SortingBatch(1, robots=4, pucks=437, max_steps=3, seed=12)
        for _ in range(12):
            batch.step(np.zeros((1, 4, 2)))

    def test_the_batch_returns_the_same_arrays_without_a_copy_unless_asked(self):
        batch = SortingBatch(2, robots=4, max_steps=10)
        first = batch.reset()
        again = batch.step(np.zeros((2, 4, 2)))[0]
        self.assertIs(first["map"], again["map"])
        copied = batch.step(np.zeros((2, 4, 2)), copy=True)[0]
        self.assertIsNot(copied["map"], first["map"])
        with self.assertRaises(ValueError):
            batch.step(np.zeros((3, 4, 2)))


if __name__ == "__main__":
    unittest.main()
