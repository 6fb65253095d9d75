"""Type stubs for colony's Rust extension (crates/py/src). Arrays handed in are
written in place and must have exactly the shape named, in C order."""

from typing import Optional

import numpy as np
import numpy.typing as npt

__version__: str
MAX_RENDER_SIDE: int

class Publisher:
    """A hub client that only publishes (``render_mode="human"``)."""

    def __init__(self, hub: str) -> None: ...
    def publish(self, packets: list[bytes]) -> None: ...
    @property
    def sent(self) -> int: ...
    @property
    def hub(self) -> str: ...

class SortConfig:
    """A sorting environment's configuration, checked once (``SortingEnv`` documents each value)."""

    def __init__(
        self,
        *,
        scene: Optional[str] = None,
        params: Optional[str] = None,
        robots: Optional[int] = None,
        pucks: Optional[int] = None,
        kinds: Optional[int] = None,
        scale_robots: Optional[int] = None,
        max_steps: int = 2000,
        pc_target: Optional[float] = None,
        reward: str = "pc_change",
        grid: int = 16,
        engine: Optional[str] = None,
    ) -> None: ...

class SortCore:
    """One sorting world; ``colony.sorting.SortingEnv`` wraps it."""

    def __init__(self, config: SortConfig, seed: int = 0) -> None: ...
    def reset(self, seed: int) -> None: ...
    @property
    def agents(self) -> int: ...
    @property
    def kinds(self) -> int: ...
    @property
    def pucks(self) -> int:
        """The pucks in the world."""
    @property
    def layout(self) -> tuple[int, int, int, int]:
        """(map channels, grid cells per side, gripper length, pose length)."""
    def observe(
        self,
        map: npt.NDArray[np.float32],
        gripper: npt.NDArray[np.float32],
        pose: npt.NDArray[np.float32],
    ) -> None: ...
    def step(self, actions: npt.NDArray[np.float64]) -> tuple[float, float, bool, bool]:
        """(robots, 2) forward and turn: (reward, pc, terminated, truncated)."""
    def step_discrete(self, actions: npt.NDArray[np.uint32]) -> tuple[float, float, bool, bool]: ...
    def reference(self, method_name: str) -> npt.NDArray[np.float64]: ...
    @property
    def pc(self) -> float: ...
    @property
    def twc(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def step_seconds(self) -> float:
        """Simulated seconds of one control step."""
    def render(self, width: int, height: int) -> npt.NDArray[np.uint8]: ...
    def vision_packets(self) -> list[bytes]: ...
    @staticmethod
    def discrete_actions() -> npt.NDArray[np.float64]: ...
    @staticmethod
    def discrete_action_names() -> list[str]: ...

class SortBatch:
    """Many sorting worlds stepped together; ``colony.batch.SortingBatch`` wraps it."""

    def __init__(self, config: SortConfig, worlds: int, seed: int = 0) -> None: ...
    @property
    def worlds(self) -> int: ...
    @property
    def agents(self) -> int: ...
    @property
    def layout(self) -> tuple[int, int, int, int]: ...
    def reset(self, seed: Optional[int] = None, seeds: Optional[list[int]] = None) -> None: ...
    def observe(
        self,
        map: npt.NDArray[np.float32],
        gripper: npt.NDArray[np.float32],
        pose: npt.NDArray[np.float32],
    ) -> None: ...
    def step(
        self,
        actions: npt.NDArray[np.float64],
        map: npt.NDArray[np.float32],
        gripper: npt.NDArray[np.float32],
        pose: npt.NDArray[np.float32],
        reward: npt.NDArray[np.float64],
        terminated: npt.NDArray[np.bool_],
        truncated: npt.NDArray[np.bool_],
        last: npt.NDArray[np.float64],
    ) -> None: ...
    def reference(self, method_name: str) -> npt.NDArray[np.float64]: ...
    def pc(self) -> npt.NDArray[np.float64]: ...

_Step = tuple[list[float], bool, bool, tuple[int, int], Optional[str], int, int, int]

class GameConfig:
    """A game environment's configuration, checked once (``GameEnv`` documents each value)."""

    def __init__(
        self,
        *,
        mode: str = "ctf",
        map: Optional[str] = None,
        learner: Optional[str] = None,
        opponent: Optional[str] = None,
        opponent_policy: str = "scripted",
        control: str = "robot",
        max_steps: int = 3000,
        nearby: int = 8,
        patch: int = 11,
        rewards: Optional[dict[str, float]] = None,
    ) -> None: ...

class GameCore:
    """One Capture the Flag or Death Match match; ``colony.game.GameEnv`` wraps it."""

    def __init__(self, config: GameConfig, seed: int = 0) -> None: ...
    def reset(self, seed: int) -> None: ...
    @property
    def agents(self) -> list[tuple[int, str, str]]:
        """(robot id, type, squad) per agent."""
    @property
    def squads(self) -> list[str]: ...
    @property
    def teams(self) -> tuple[str, str]: ...
    @property
    def layout(self) -> list[tuple[str, list[int]]]:
        """Each observation part's name and shape per agent: own, nearby, flags, patch."""
    @property
    def motion_bounds(self) -> tuple[float, float]:
        """The largest |velocity| / top speed and |turn rate| / top turn rate in ``own``."""
    def alive(self) -> list[bool]: ...
    def observe(
        self,
        own: npt.NDArray[np.float32],
        nearby: npt.NDArray[np.float32],
        flags: npt.NDArray[np.float32],
        patch: npt.NDArray[np.float32],
    ) -> None: ...
    def step(
        self,
        wheels: npt.NDArray[np.float64],
        fire: npt.NDArray[np.int64],
        pickup: npt.NDArray[np.bool_],
    ) -> _Step:
        """(rewards, terminated, truncated, score, winner, refused, refused orders, invalid shots)."""
    def step_squads(self, orders: list[int]) -> _Step: ...
    def render(self, width: int, height: int) -> npt.NDArray[np.uint8]: ...
    def set_record(self, on: bool) -> None: ...
    def take_packets(self) -> list[bytes]: ...
    @staticmethod
    def squad_orders() -> list[str]: ...

class GameBatch:
    """Many matches (robot-level control) stepped together; ``colony.batch.GameBatch`` wraps it."""

    def __init__(self, config: GameConfig, worlds: int, seed: int = 0) -> None: ...
    @property
    def worlds(self) -> int: ...
    @property
    def agents(self) -> int: ...
    @property
    def layout(self) -> dict[str, list[int]]: ...
    def reset(self, seed: Optional[int] = None, seeds: Optional[list[int]] = None) -> None: ...
    def observe(
        self,
        own: npt.NDArray[np.float32],
        nearby: npt.NDArray[np.float32],
        flags: npt.NDArray[np.float32],
        patch: npt.NDArray[np.float32],
    ) -> None: ...
    def step(
        self,
        wheels: npt.NDArray[np.float64],
        fire: npt.NDArray[np.int64],
        pickup: npt.NDArray[np.bool_],
        own: npt.NDArray[np.float32],
        nearby: npt.NDArray[np.float32],
        flags: npt.NDArray[np.float32],
        patch: npt.NDArray[np.float32],
        reward: npt.NDArray[np.float64],
        terminated: npt.NDArray[np.bool_],
        truncated: npt.NDArray[np.bool_],
        last: npt.NDArray[np.float64],
    ) -> None: ...
