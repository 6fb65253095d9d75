"""Checking a step's actions, once for every environment: an action for an agent
that is not in the episode, or an action outside its space, is a ``ValueError``
naming the agent, never silently dropped, truncated or broadcast."""

from __future__ import annotations

import operator
from typing import Any

import numpy as np


def agent_index(agent: Any, index: dict, live: set) -> int:
    """The position of `agent` among the possible agents; it must be live (a set,
    so checking a step's actions costs one lookup an agent)."""
    i = index.get(agent)
    if i is None or agent not in live:
        raise ValueError(f"{agent!r} is not an agent in this episode ({len(live)} agents are)")
    return i


def fields(agent: str, value: Any, names: tuple) -> Any:
    """A dict action with exactly these keys."""
    if not isinstance(value, dict) or set(value) != set(names):
        got = sorted(value) if isinstance(value, dict) else type(value).__name__
        raise ValueError(f"{agent}: the action must be a dict of {', '.join(names)}, not {got}")
    return value


def wheels(agent: str, value: Any) -> np.ndarray:
    """A (forward, turn) pair of numbers (non-finite ones are the wheels' business)."""
    pair = np.asarray(value, dtype=np.float64)
    if pair.shape != (2,):
        raise ValueError(f"{agent}: wheels must be 2 numbers (forward, turn), not shape {pair.shape}")
    return pair


def choice(agent: str, value: Any, n: int, what: str) -> int:
    """An integer in 0..n (a float, even 2.0, is refused: it would be truncated;
    a boolean is 0 or 1)."""
    if isinstance(value, np.bool_):
        value = bool(value)
    try:
        k = operator.index(value)
    except TypeError:
        raise ValueError(f"{agent}: {what} must be an integer 0 to {n - 1}, not {value!r}") from None
    if not 0 <= k < n:
        raise ValueError(f"{agent}: {what} must be 0 to {n - 1}, not {k}")
    return k
