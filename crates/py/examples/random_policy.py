"""Random robots: the floor any controller should beat, in sorting and in Capture the Flag.

    python random_policy.py --steps 500
"""

import argparse

from colony import CaptureTheFlagEnv, SortingEnv


def sorting(steps: int, seed: int) -> float:
    env = SortingEnv(max_steps=steps)
    obs, _ = env.reset(seed=seed)
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        obs, rewards, terms, truncs, infos = env.step(actions)
    return env.pc


def capture_the_flag(steps: int, seed: int) -> dict:
    env = CaptureTheFlagEnv(max_steps=steps)
    env.reset(seed=seed)
    total = 0.0
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        _, rewards, _, _, _ = env.step(actions)
        total += sum(rewards.values())
    return {"reward": total, **env.score()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    a = parser.parse_args()
    print(f"sorting: random robots reach PC {sorting(a.steps, a.seed):.3f} in {a.steps} steps")
    print(f"capture the flag against the scripted team: {capture_the_flag(a.steps, a.seed)}")


if __name__ == "__main__":
    main()
