"""Every example runs, on a tiny budget, and says what it found."""

import os
import subprocess
import sys
import unittest

EXAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples")


def run(name, *args):
    done = subprocess.run(
        [sys.executable, os.path.join(EXAMPLES, name), *args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    if done.returncode != 0:
        raise AssertionError(f"{name} failed:\n{done.stdout}\n{done.stderr}")
    return done.stdout


class Examples(unittest.TestCase):
    def test_the_random_policy_plays_sorting_and_capture_the_flag(self):
        out = run("random_policy.py", "--steps", "60")
        self.assertIn("sorting: random robots reach PC", out)
        self.assertIn("capture the flag against the scripted team", out)

    def test_the_hand_written_controller_is_compared_with_random_and_cachecons(self):
        out = run("hand_controller.py", "--steps", "80", "--seeds", "1")
        for policy in ("random", "hand", "cachecons"):
            self.assertIn(f"{policy}: PC", out)

    def test_cma_es_training_runs_generations_on_a_batch(self):
        out = run("train_cma.py", "--generations", "2", "--population", "4", "--steps", "30", "--robots", "3")
        self.assertIn("generation 1:", out)
        self.assertIn("best PC", out)


if __name__ == "__main__":
    unittest.main()
