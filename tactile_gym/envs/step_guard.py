"""The rules every id shares: reset first, no step after the end, well-formed actions, the
render modes, and the horizon in ``spec``.

``HingeProbeEnv`` and the primitive env each hold a ``StepGuard`` over their own action space
and take ``spec`` from ``EnvSpecOwnHorizon``, so the rules and their messages are written once
(``docs/design.md`` 7.8).
"""

from __future__ import annotations

import dataclasses
import os
import sys

import numpy as np
from gymnasium import spaces

__all__ = ["EnvSpecOwnHorizon", "StepGuard", "check_render_mode", "display_available"]


def display_available() -> bool:
    """Whether PyBullet's GUI can open a window (X11 or Wayland on Linux)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def check_render_mode(render_mode: str | None, modes: list[str]) -> None:
    """Refuse a render mode the env does not have, and ``"human"`` without a display."""
    if render_mode not in (None, *modes):
        raise ValueError(f"render_mode must be one of {modes} or None, got {render_mode!r}")
    if render_mode == "human" and not display_available():
        raise RuntimeError(
            "render_mode='human' opens PyBullet's GUI, which needs a display, and no DISPLAY"
            " or WAYLAND_DISPLAY is set. Use render_mode='rgb_array' for headless frames."
        )


class EnvSpecOwnHorizon:
    """``spec`` whose ``max_episode_steps`` is the env's own horizon (``_horizon``): the env
    counts its steps and truncates itself, and ``gym.make`` sets ``spec`` after building it,
    so tools that read the horizon from the spec (``TimeAwareObservation``) find it there."""

    _spec = None

    @property
    def spec(self):
        return self._spec

    @spec.setter
    def spec(self, value) -> None:
        self._spec = (
            None if value is None else dataclasses.replace(value, max_episode_steps=self._horizon)
        )


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
