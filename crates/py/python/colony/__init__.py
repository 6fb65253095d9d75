"""colony from Python: the swarm simulator, the sorting task and the strategy game
as PettingZoo ``ParallelEnv`` s (one agent per robot), Gymnasium environments
controlling a whole team, and batched worlds stepped on every core.

    >>> from colony.sorting import SortingEnv
    >>> env = SortingEnv(robots=4)
    >>> obs, infos = env.reset(seed=7)

Importing ``colony`` registers the team-as-one-agent environments with
Gymnasium: ``gymnasium.make("colony/Sorting-v0")``, ``"colony/CaptureTheFlag-v0"``,
``"colony/DeathMatch-v0"`` (keyword arguments go to the environment).

The protocol client (``python/colony_client.py`` in the repository) is separate
and needs only the standard library.
"""

from ._native import __version__
from .batch import GameBatch, SortingBatch
from .game import CaptureTheFlagEnv, DeathMatchEnv, GameEnv
from .joint import JointEnv
from .sorting import SortingEnv
from ._registry import register as _register

_register()

__all__ = [
    "CaptureTheFlagEnv",
    "DeathMatchEnv",
    "GameBatch",
    "GameEnv",
    "JointEnv",
    "SortingBatch",
    "SortingEnv",
    "__version__",
]
