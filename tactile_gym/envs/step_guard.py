"""The step rules every id shares: reset first, no step after the end, well-formed actions.

``HingeProbeEnv`` and the primitive ids' wrapper each hold a ``StepGuard`` over their own
action space, so the rules and their messages are written once (``docs/design.md`` 7.8).
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

__all__ = ["StepGuard"]


class StepGuard:
    """Checks each ``step`` against the episode's state and the action space.

    Args:
        action_space: the env's ``Box`` action space.
    """

    def __init__(self, action_space: spaces.Box) -> None:
        self.action_space = action_space
        self._low = action_space.low.astype(float)
        self._high = action_space.high.astype(float)
        self._started = False
        self._over = True

    def begin(self) -> None:
        """An episode started (``reset``)."""
        self._started, self._over = True, False

    def end(self, done: bool) -> None:
        """Record whether the step just taken ended the episode (terminated or truncated)."""
        self._over = bool(done)

    def stop(self) -> None:
        """The env was closed: the next ``step`` needs a ``reset``."""
        self._started, self._over = False, True

    def check(self, action) -> np.ndarray:
        """The action as float64, clipped to the space, if the env may step with it.

        Raises:
            RuntimeError: before ``reset``, or after the episode ended.
            ValueError: an action of the wrong shape or with non-finite values.
        """
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._over:
            raise RuntimeError(
                "the episode has ended (terminated or truncated); call reset() before step()"
            )
        action = np.asarray(action)
        space = self.action_space
        if action.shape != space.shape:
            raise ValueError(f"action must have shape {space.shape}, got {action.shape}")
        if not np.isfinite(action).all():
            raise ValueError(f"action must be finite, got {action.tolist()}")
        action = action.astype(float)
        return np.clip(action, self._low, self._high, out=action)
