"""Environment steps per second: colony's Python environments beside peer
environments from PyPI (PettingZoo's MPE, VMAS on CPU), measured in one run on
one machine. Run by ``scripts/bench-envs.sh``, which installs everything in a
virtual environment and passes the Rust-only rates (``--rust``) so the cost of
crossing between Python and Rust per step can be told apart.

Every colony figure is the best of five timed runs (a peer's, of three). Physics costs more when robots
push things, so colony's loops (and the Rust example) run the same steps: from
seed 1, robot ``i`` driven with forward 0.8 and turn 0.5 sin(i), the same number
of steps per scene (``STEPS``), a batch's worlds all from seed 1; the difference
between a loop in Python and the Rust example is then what crossing costs. Peers
run at least ``--seconds`` with one fixed random action per agent. Actions are
made beforehand so that making them is not measured.
"""

from __future__ import annotations

import argparse
import platform
import time
import timeit
from typing import Callable, Optional

import numpy as np


def timed(step: Callable[[], None], seconds: float) -> float:
    """Steps per second: the best of three runs of at least `seconds`."""
    best = 0.0
    for _ in range(3):
        n, start = 0, time.perf_counter()
        while True:
            step()
            n += 1
            elapsed = time.perf_counter() - start
            if elapsed >= seconds and n >= 3:
                break
        best = max(best, n / elapsed)
    return best


def fixed_commands(n: int) -> np.ndarray:
    """Robot i: forward 0.8, turn 0.5 sin(i) (the Rust example's commands too)."""
    return np.stack([np.full(n, 0.8), 0.5 * np.sin(np.arange(n))], axis=1)


def parallel_env_rate(env, seconds: float, actions: Optional[dict] = None, seed: int = 1) -> float:
    """A PettingZoo ParallelEnv stepped through its dict API with fixed actions."""
    env.reset(seed=seed)
    if actions is None:
        for i, a in enumerate(env.possible_agents):
            env.action_space(a).seed(seed + i)
        actions = {a: env.action_space(a).sample() for a in env.possible_agents}

    def step():
        if not env.agents:
            env.reset()
        env.step({a: actions[a] for a in env.agents})

    return timed(step, seconds)


# Steps per timed run for each scene (robots; 12 is Capture the Flag): the Rust
# example (examples/env_speed.rs) runs exactly these, from the same seed.
STEPS = {4: 4000, 64: 800, 256: 300, 12: 2000}


def runs(steps: int, reset: Callable[[], None], step: Callable[[], None]) -> float:
    """The best of five runs of `steps` steps, each after `reset`, in steps per second."""
    best = float("inf")
    for _ in range(5):
        reset()
        start = time.perf_counter()
        for _ in range(steps):
            step()
        best = min(best, time.perf_counter() - start)
    return steps / best


def colony_rows(rust: dict, batch_worlds: int) -> tuple:
    from colony import CaptureTheFlagEnv, GameBatch, SortingBatch, SortingEnv

    rows = []
    for robots in (4, 64, 256):
        scene = {"robots": 4} if robots == 4 else {"scale_robots": robots}
        n = STEPS[robots]
        env = SortingEnv(max_steps=10**9, **scene)
        acts = fixed_commands(robots)
        by_agent = {a: acts[i] for i, a in enumerate(env.possible_agents)}
        single = runs(n, lambda: env.reset(seed=1), lambda: env.step(by_agent))
        core = env.core

        def native():
            core.step(acts)
            core.observe(env._map, env._gripper, env._pose)

        raw = runs(n, lambda: core.reset(1), native)
        # Every world of the batch from the same seed: the same work as the single world's.
        worlds = max(1, batch_worlds if robots <= 64 else batch_worlds // 4)
        batch = SortingBatch(worlds, max_steps=10**9, **scene)
        bacts = np.broadcast_to(acts, (worlds, robots, 2)).copy()
        batched = runs(n, lambda: batch.reset(seeds=[1] * worlds), lambda: batch.step(bacts)) * worlds
        rows.append(("colony sorting", robots, single, raw, batched, worlds, rust.get(f"sorting-{robots}")))
    # timeit's loop, not `timed`'s, whose clock reads and lambda cost as much as the call.
    getter = min(timeit.repeat("core.steps", globals={"core": core}, number=200_000, repeat=5)) / 200_000
    env = CaptureTheFlagEnv(max_steps=10**9)
    core, agents = env.core, len(env.possible_agents)
    wheels = fixed_commands(agents)
    fire, pickup = np.ones(agents, np.int64), np.ones(agents, np.bool_)
    game_actions = {a: {"wheels": wheels[i], "fire": 1, "pickup": 1} for i, a in enumerate(env.possible_agents)}

    def step_env():
        if not env.agents:
            env.reset(seed=2)
        env.step({a: game_actions[a] for a in env.agents})

    single = runs(STEPS[12], lambda: env.reset(seed=1), step_env)

    def native_game():
        _, terminated, truncated, *_ = core.step(wheels, fire, pickup)
        if terminated or truncated:
            core.reset(2)
        env._observe()

    raw = runs(STEPS[12], lambda: core.reset(1), native_game)
    worlds = batch_worlds
    batch = GameBatch(worlds, max_steps=10**9)
    bw = np.broadcast_to(wheels, (worlds, agents, 2)).copy()
    bf, bp = np.ones((worlds, agents), np.int64), np.ones((worlds, agents), np.bool_)
    batched = runs(STEPS[12], lambda: batch.reset(seeds=[1] * worlds), lambda: batch.step(bw, bf, bp)) * worlds
    # 12 robots play; 6 of them are agents.
    rows.append(("colony Capture the Flag (6 v 6)", 12, single, raw, batched, worlds, rust.get("ctf-12")))
    return rows, getter


def mpe_rows(seconds: float) -> list:
    from mpe2 import simple_spread_v3, simple_tag_v3

    rows = []
    for n in (4, 64, 256):
        env = simple_spread_v3.parallel_env(N=n, max_cycles=10**9, continuous_actions=True)
        rows.append(("MPE simple_spread (mpe2)", n, parallel_env_rate(env, seconds), None, None, None, None))
    env = simple_tag_v3.parallel_env(num_good=6, num_adversaries=6, num_obstacles=2, max_cycles=10**9, continuous_actions=True)
    rows.append(("MPE simple_tag (mpe2, 6 v 6)", 12, parallel_env_rate(env, seconds), None, None, None, None))
    return rows


def vmas_rows(seconds: float, batch_worlds: int) -> list:
    import torch
    import vmas

    torch.set_num_threads(2)
    rows = []
    for n in (4, 64, 256):
        per = {}
        for worlds in (1, batch_worlds if n <= 64 else max(1, batch_worlds // 4)):
            env = vmas.make_env("dispersion", num_envs=worlds, device="cpu", continuous_actions=True, seed=0, n_agents=n)
            env.reset()
            acts = [torch.rand(worlds, 2) * 2 - 1 for _ in range(n)]
            per[worlds] = timed(lambda: env.step(acts), seconds) * worlds
        r1, (wb, rb) = per[1], max(per.items())
        rows.append(("VMAS dispersion (CPU, torch)", n, r1, None, rb, wb, None))
    return rows


def rate(r: Optional[float]) -> str:
    if not r:
        return "—"
    return f"{r:,.0f}" if r >= 10 else f"{r:.2g}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--batch", type=int, default=16, help="worlds in a batch (a quarter of it for 256 robots)")
    parser.add_argument("--rust", default="", help="NAME=RATE,... from the env_speed example")
    parser.add_argument("--peers", default="mpe,vmas")
    a = parser.parse_args()
    rust = {k: float(v) for k, v in (kv.split("=") for kv in a.rust.split(",") if kv)}
    rows, getter = colony_rows(rust, a.batch)
    peers = a.peers.split(",")
    if "mpe" in peers:
        rows += mpe_rows(a.seconds)
    if "vmas" in peers:
        rows += vmas_rows(a.seconds, a.batch)
    print(f"machine: {platform.machine()}, {platform.processor() or '?'}; python {platform.python_version()}")
    print()
    print("| environment | robots | env steps/s (ParallelEnv) | agent-steps/s | native call steps/s | batched world-steps/s (worlds) | Rust alone steps/s | Python-Rust crossing per step |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for name, robots, single, raw, batched, worlds, rs in rows:
        agents = 6 if robots == 12 and "colony" in name else robots
        cross = f"{(1 / raw - 1 / rs) * 1e6:.1f} µs" if raw and rs else "—"
        print(
            f"| {name} | {robots} | {rate(single)} | {rate(single * agents)} | "
            f"{rate(raw)} | {f'{rate(batched)} ({worlds})' if batched else '—'} | "
            f"{rate(rs)} | {cross} |"
        )
    print()
    print(f"a bare call into the extension (a getter): {getter * 1e9:.0f} ns")


if __name__ == "__main__":
    main()
