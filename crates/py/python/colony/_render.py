"""``render_mode="human"``: an environment's packets published to a colony hub.

colony's monitor (``colony monitor``), ``colony spy`` and any subscriber then show a
Python run exactly as they show a live run. Frames are paced to a rate, since a
person watches, and an environment can step thousands of times a second.
"""

from __future__ import annotations

import operator
import time

from . import _native


def check_mode(metadata: dict, render_mode, render_size: int) -> None:
    """An environment's `render_mode` is None or one its metadata names, and its
    pictures' side one the extension draws."""
    if render_mode is not None and render_mode not in metadata["render_modes"]:
        raise ValueError(f"render_mode must be one of {metadata['render_modes']}, not {render_mode!r}")
    if not 0 <= operator.index(render_size) <= _native.MAX_RENDER_SIDE:
        raise ValueError(f"render_size must be 0 to {_native.MAX_RENDER_SIDE}, not {render_size}")


class HumanView:
    def __init__(self, hub: str, fps: float):
        if not fps > 0:
            raise ValueError(f"the frame rate must be positive, not {fps}")
        self._publisher = _native.Publisher(hub)
        self._period = 1.0 / fps
        self._due = time.monotonic()

    def publish(self, packets: list) -> None:
        now = time.monotonic()
        if now < self._due:
            time.sleep(self._due - now)
        self._due = max(now, self._due) + self._period
        self._publisher.publish(packets)

    @property
    def sent(self) -> int:
        return self._publisher.sent

    def close(self) -> None:
        self._publisher = None
