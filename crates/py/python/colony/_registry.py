"""colony's environments in Gymnasium's registry, so ``gymnasium.make`` finds them
(``gymnasium.make("colony/Sorting-v0", robots=8)``). Gymnasium's ``Env`` is one
agent, so each id makes the environment's whole team one agent (:class:`JointEnv`);
keyword arguments go to the PettingZoo environment underneath."""

from __future__ import annotations

import gymnasium

from .game import CaptureTheFlagEnv, DeathMatchEnv
from .joint import JointEnv
from .sorting import SortingEnv


def sorting(**kwargs) -> JointEnv:
    return JointEnv(SortingEnv(**kwargs))


def capture_the_flag(**kwargs) -> JointEnv:
    return JointEnv(CaptureTheFlagEnv(**kwargs))


def death_match(**kwargs) -> JointEnv:
    return JointEnv(DeathMatchEnv(**kwargs))


IDS = {
    "colony/Sorting-v0": sorting,
    "colony/CaptureTheFlag-v0": capture_the_flag,
    "colony/DeathMatch-v0": death_match,
}


def register() -> None:
    for env_id, make in IDS.items():
        # Importing colony again (a reload, two import paths) must not make
        # Gymnasium warn that an id is overridden.
        if env_id not in gymnasium.registry:
            # Episodes end by the environments' own `max_steps`, which `make` passes
            # through, so no TimeLimit is stacked on them.
            gymnasium.register(id=env_id, entry_point=f"{__name__}:{make.__name__}")
