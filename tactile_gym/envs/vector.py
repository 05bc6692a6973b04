"""A Gymnasium vector env of N scenes in one process, for every id (``docs/design.md`` 7.9).

``gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` makes a
``HingeProbeVectorEnv``: N sub-envs, each the env ``gym.make(id)`` would make (the 6-D
``HingeProbeEnv``, or the primitive wrapper over it) with its own PyBullet DIRECT client,
stepped in turn in this process. Sub-env i reset with seed s and given the same actions
reproduces ``gym.make(id)`` reset with seed s exactly; a primitive sub-env runs its own
primitive to completion within one vector step, however long the others' primitives are.

Gymnasium 1.x conventions: ``metadata["autoreset_mode"]`` (``NEXT_STEP`` by default, as
``SyncVectorEnv``; ``SAME_STEP`` and ``DISABLED`` on request), batched observations (a dict of
``(N, k)`` arrays, or ``(N, k)`` with ``observation_mode="flat"``), infos batched with ``_key``
masks, ``single_observation_space`` and ``single_action_space``. An exception raised by a
sub-env names its index.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from numbers import Integral
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from tactile_gym.envs.hinge_probe_primitive_v1 import make_primitive_env
from tactile_gym.envs.hinge_probe_v1 import HingeProbeEnv
from tactile_gym.validation import check_int

__all__ = [
    "MAX_NUM_ENVS",
    "HingeProbeVectorEnv",
    "make_primitive_vector_env",
    "make_vector_env",
]

#: The most sub-envs one vector env holds: each costs memory and build time
#: (``docs/design.md`` 7.9), so a typo such as ``num_envs=10_000`` fails at once.
MAX_NUM_ENVS = 256


def make_vector_env(num_envs: int = 1, **kwargs: Any) -> HingeProbeVectorEnv:
    """The vector entry point of the 6-D ids: ``num_envs`` ``HingeProbeEnv`` sub-envs."""
    return HingeProbeVectorEnv(HingeProbeEnv, num_envs, **kwargs)


def make_primitive_vector_env(num_envs: int = 1, **kwargs: Any) -> HingeProbeVectorEnv:
    """The vector entry point of the primitive ids: ``num_envs`` primitive sub-envs."""
    return HingeProbeVectorEnv(make_primitive_env, num_envs, **kwargs)


def _with_index(error: Exception, index: int, num_envs: int) -> Exception:
    """``error`` with the sub-env's index in its message, of the same type where the type
    takes a message; otherwise the original with the index as a note."""
    where = f"sub-env {index} of {num_envs}"
    try:
        indexed = type(error)(f"{where}: {error}")
    except Exception:  # a type whose constructor takes more than a message
        error.add_note(f"raised by {where}")
        return error
    indexed.index = index
    return indexed


class HingeProbeVectorEnv(VectorEnv):
    """N sub-envs of one id, stepped in one process (module docstring).

    Args:
        env_fn: makes one sub-env from the env keywords (the id's entry point).
        num_envs: how many sub-envs, 1 to ``MAX_NUM_ENVS``.
        autoreset_mode: ``AutoresetMode`` or its value. ``NEXT_STEP``: the step after a
            sub-env's episode ends resets it (its action is ignored, reward 0). ``SAME_STEP``:
            the step that ends it resets it and puts the last observation and info in
            ``info["final_obs"]`` and ``info["final_info"]``. ``DISABLED``: reset ended
            sub-envs with ``reset(options={"reset_mask": mask})``.
        **kwargs: the keywords of ``gym.make(id)`` (``render_mode`` included), the same for
            every sub-env.

    Raises:
        ValueError: ``num_envs`` not an integer in [1, ``MAX_NUM_ENVS``], an unknown
            ``autoreset_mode``, ``render_mode="human"`` with more than one sub-env; the
            sub-env's own errors for its keywords.
    """

    def __init__(
        self,
        env_fn: Callable[..., gym.Env],
        num_envs: int,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        self.num_envs = check_int("num_envs", num_envs, 1, MAX_NUM_ENVS)
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            allowed = [mode.value for mode in AutoresetMode]
            raise ValueError(
                f"autoreset_mode must be one of {allowed}, got {autoreset_mode!r}"
            ) from None
        if kwargs.get("render_mode") == "human" and self.num_envs > 1:
            raise ValueError(
                "render_mode='human' opens PyBullet's GUI, which one process can open once;"
                f" got num_envs={self.num_envs}. Use num_envs=1 or render_mode='rgb_array'."
            )
        self.envs: list[gym.Env] = []
        try:
            for _ in range(self.num_envs):
                self.envs.append(env_fn(**kwargs))
        except Exception:
            self.close_extras()  # the clients already opened
            raise
        first = self.envs[0]
        self.render_mode = first.render_mode
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._obs: list[Any] = [None] * self.num_envs
        self._ended = np.zeros(self.num_envs, dtype=bool)  # NEXT_STEP: reset on the next step

    # ------------------------------------------------------------------ vector API
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ):
        """Reset the sub-envs (those of ``options["reset_mask"]`` if given).

        Args:
            seed: ``None`` (fresh entropy), an int s (sub-env i gets s + i, as Gymnasium's
                vector envs do) or one seed (or ``None``) per sub-env in a list, tuple or array.
            options: passed to every sub-env's ``reset``; ``reset_mask`` (a bool array of
                shape ``(num_envs,)``) picks which sub-envs to reset.

        Returns:
            The batched observations (the others' last ones for sub-envs not reset) and
            the batched infos of the sub-envs reset.
        """
        seeds = self._seeds(seed)
        options = dict(options or {})
        mask = self._reset_mask(options.pop("reset_mask", None))
        infos: dict[str, Any] = {}
        for i in np.flatnonzero(mask):
            self._obs[i], info = self._call(i, "reset", seed=seeds[i], options=options or None)
            infos = self._add_info(infos, info, i)
        self._ended[mask] = False
        return self._batched_obs(), infos

    def step(self, actions):
        """Step every sub-env with its row of ``actions`` (an array of shape
        ``(num_envs, *single_action_space.shape)``); the autoreset mode says what an ended
        sub-env does."""
        actions = np.asarray(actions)
        expected = (self.num_envs, *self.single_action_space.shape)
        if actions.shape != expected:
            raise ValueError(f"actions must have shape {expected}, got {actions.shape}")
        rewards = np.zeros(self.num_envs, dtype=np.float64)
        terminations = np.zeros(self.num_envs, dtype=bool)
        truncations = np.zeros(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {}
        for i in range(self.num_envs):
            if self.autoreset_mode == AutoresetMode.NEXT_STEP and self._ended[i]:
                self._obs[i], info = self._call(i, "reset")
            else:
                self._obs[i], rewards[i], terminations[i], truncations[i], info = self._call(
                    i, "step", actions[i]
                )
                if self.autoreset_mode == AutoresetMode.SAME_STEP and (
                    terminations[i] or truncations[i]
                ):
                    infos = self._add_info(
                        infos, {"final_obs": self._obs[i], "final_info": info}, i
                    )
                    self._obs[i], info = self._call(i, "reset")
            infos = self._add_info(infos, info, i)
        self._ended = terminations | truncations
        return self._batched_obs(), rewards, terminations, truncations, infos

    def render(self) -> tuple[Any, ...]:
        """Every sub-env's frame (``render_mode="rgb_array"``), in order."""
        return tuple(self._call(i, "render") for i in range(self.num_envs))

    def close_extras(self, **kwargs: Any) -> None:
        """Close every sub-env (and its PyBullet client); ``close()`` twice is safe."""
        for env in self.envs:
            env.close()
        self.envs = []

    # ------------------------------------------------------------------ sub-env access
    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call the method ``name`` of every sub-env (or read it, if not callable)."""
        results = []
        for env in self.envs:
            attr = env.get_wrapper_attr(name)
            results.append(attr(*args, **kwargs) if callable(attr) else attr)
        return tuple(results)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """The attribute ``name`` of every sub-env."""
        return tuple(env.get_wrapper_attr(name) for env in self.envs)

    def set_attr(self, name: str, values: Any) -> None:
        """Set ``name`` on every sub-env: one value each from a list or tuple of
        ``num_envs``, otherwise the same value for all."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(
                f"set_attr needs one value per sub-env ({self.num_envs}), got {len(values)}"
            )
        for env, value in zip(self.envs, values):
            env.set_wrapper_attr(name, value)

    @property
    def np_random_seed(self) -> tuple[int | None, ...]:
        """Every sub-env's ``np_random_seed``."""
        return self.get_attr("np_random_seed")

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """Every sub-env's random generator."""
        return self.get_attr("np_random")

    # ------------------------------------------------------------------ helpers
    def _call(self, index: int, method: str, *args: Any, **kwargs: Any):
        if self.closed:
            raise RuntimeError("this vector env is closed")
        try:
            return getattr(self.envs[index], method)(*args, **kwargs)
        except Exception as error:
            indexed = _with_index(error, index, self.num_envs)
            if indexed is error:
                raise
            raise indexed from error

    def _seeds(self, seed) -> list[int | None]:
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, Integral) and not isinstance(seed, (bool, np.bool_)):
            return [int(seed) + i for i in range(n)]
        if isinstance(seed, np.ndarray) and seed.ndim == 1:
            seed = seed.tolist()
        if not isinstance(seed, (list, tuple)):
            raise ValueError(
                f"seed must be None, an int or a list of {n} seeds (one per sub-env), got {seed!r}"
            )
        if len(seed) != n:
            raise ValueError(
                f"seed must list one seed per sub-env: num_envs={n}, got {len(seed)} seeds"
            )
        return list(seed)

    def _reset_mask(self, mask) -> np.ndarray:
        if mask is None:
            return np.ones(self.num_envs, dtype=bool)
        mask = np.asarray(mask)
        if mask.dtype != np.bool_ or mask.shape != (self.num_envs,) or not mask.any():
            raise ValueError(
                f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) with"
                f" at least one True, got {mask!r}"
            )
        if any(self._obs[i] is None for i in np.flatnonzero(~mask)):
            raise ValueError("reset every sub-env once (no reset_mask) before a masked reset")
        return mask

    def _batched_obs(self):
        """The sub-envs' observations stacked into fresh arrays (the caller may keep them)."""
        space = self.single_observation_space
        return concatenate(space, self._obs, create_empty_array(space, self.num_envs))
