"""Evolves a sorting controller with CMA-ES (the `cma` package), the way evolutionary
swarm robotics trains one: every robot runs the same small linear policy, and a
candidate's fitness is the percentage completion its swarm reaches.

A generation's candidates are evaluated together in one :class:`colony.SortingBatch`,
one world each, stepped on every core in one call per step.

    python train_cma.py --generations 30 --steps 1500 --robots 6
"""

import argparse

import cma
import numpy as np

from colony import SortingBatch

# The map is pooled to 3 x 3 regions (near/far x left/centre/right) per channel.
POOL = 3


def features(obs: dict) -> np.ndarray:
    """(worlds, robots, F): pooled map, gripper and a bias, for a linear policy."""
    m = obs["map"]
    w, n, c, g, _ = m.shape
    cut = g - g % POOL
    pooled = m[..., :cut, :cut].reshape(w, n, c, POOL, cut // POOL, POOL, cut // POOL).mean(axis=(4, 6))
    return np.concatenate(
        [pooled.reshape(w, n, -1), obs["gripper"], np.ones((w, n, 1), np.float32)], axis=2
    )


def evaluate(batch: SortingBatch, weights: np.ndarray, steps: int, seed: int) -> np.ndarray:
    """Each world's PC after `steps` steps, world b driven by weights[b], every
    world from the same arrangement of pucks (the seed), so candidates compete fairly."""
    obs = batch.reset(seeds=[seed] * batch.worlds)
    for _ in range(steps):
        x = features(obs)
        actions = np.tanh(np.einsum("wnf,wfa->wna", x, weights))
        obs, _, _, _, _ = batch.step(actions)
    return batch.pc()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generations", type=int, default=30)
    parser.add_argument("--population", type=int, default=8)
    parser.add_argument("--steps", type=int, default=1500)
    parser.add_argument("--robots", type=int, default=6)
    parser.add_argument("--seed", type=int, default=1)
    a = parser.parse_args()

    batch = SortingBatch(a.population, robots=a.robots, max_steps=a.steps + 1)
    size = features(batch.reset(seed=a.seed)).shape[2]
    es = cma.CMAEvolutionStrategy(
        np.zeros(size * 2), 0.5, {"popsize": a.population, "seed": a.seed, "verbose": -9}
    )
    best = 0.0
    for generation in range(a.generations):
        candidates = es.ask()
        weights = np.stack([np.reshape(c, (size, 2)) for c in candidates])
        # A new arrangement each generation, so the policy cannot learn one by heart.
        pc = evaluate(batch, weights, a.steps, seed=a.seed + generation)
        es.tell(candidates, list(-pc))
        best = max(best, float(pc.max()))
        print(f"generation {generation}: PC mean {pc.mean():.3f} best {pc.max():.3f}")
    print(f"best PC {best:.3f}")


if __name__ == "__main__":
    main()
