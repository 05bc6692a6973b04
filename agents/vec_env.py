"""Stable-Baselines3's ``VecEnv`` over the package's vector env (``docs/design.md`` 7.9).

``make_sb3_vec_env(env_id, n_envs, workers)`` makes ``gym.make_vec(env_id, num_envs=n_envs,
workers=workers)`` (N scenes in this process or spread over worker processes,
``tactile_gym.envs.vector``) with same-step autoreset and hands it
to SB3 as a ``VecEnv``: what ``DummyVecEnv`` over ``n_envs`` ``gym.make(env_id)`` envs would
give, without a Python loop of SB3's own around the envs. As SB3 expects, a sub-env whose
episode ended is reset in the same step, its last observation goes in the info as
``terminal_observation`` and ``TimeLimit.truncated`` says it was cut by time; seeds set with
``seed()`` and options with ``set_options()`` are used by the next ``reset()``.

Stable-Baselines3 is only in the ``[train]`` extra, so only ``agents`` imports this module.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Sequence
from operator import methodcaller
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.env_util import is_wrapped
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

import tactile_gym  # noqa: F401 - registers the ids
from tactile_gym.envs.vector import HingeProbeVectorEnv, call_or_read

__all__ = ["HingeProbeSB3VecEnv", "make_sb3_vec_env", "unbatch_infos"]

#: Where Gymnasium's same-step autoreset puts the ended episode's last observation and info.
_FINAL_KEYS = ("final_obs", "final_info")


def make_sb3_vec_env(
    env_id: str, n_envs: int, workers: int = 1, **env_kwargs: Any
) -> HingeProbeSB3VecEnv:
    """SB3's ``VecEnv`` of ``n_envs`` sub-envs of ``env_id`` with ``gym.make``'s keywords,
    stepped in this process (``workers=1``) or in ``workers`` processes."""
    vector = gym.make_vec(
        env_id,
        num_envs=n_envs,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
        workers=workers,
        **env_kwargs,
    )
    return HingeProbeSB3VecEnv(vector)


def unbatch_infos(infos: dict[str, Any], num_envs: int) -> list[dict[str, Any]]:
    """Gymnasium's batched infos (arrays with ``_key`` masks) as one dict per sub-env, each
    entry as a single env gives it (the envs' infos are NumPy scalars and arrays)."""
    out: list[dict[str, Any]] = [{} for _ in range(num_envs)]
    for key, value in infos.items():
        if key.startswith("_"):
            continue
        mask = infos[f"_{key}"]
        rows = unbatch_infos(value, num_envs) if isinstance(value, dict) else value
        for i in np.flatnonzero(mask):
            out[i][key] = rows[i]
    return out


class HingeProbeSB3VecEnv(VecEnv):
    """SB3's ``VecEnv`` interface over a ``HingeProbeVectorEnv`` (module docstring).

    Args:
        vector_env: the vector env, made with ``autoreset_mode=AutoresetMode.SAME_STEP``
            (``make_sb3_vec_env`` does); the adapter closes it.

    Raises:
        ValueError: another kind of vector env, or another autoreset mode.
    """

    def __init__(self, vector_env: HingeProbeVectorEnv) -> None:
        if not isinstance(vector_env, HingeProbeVectorEnv):
            raise ValueError(
                f"vector_env must be a HingeProbeVectorEnv, got {type(vector_env).__name__}"
            )
        if vector_env.autoreset_mode is not AutoresetMode.SAME_STEP:
            raise ValueError(
                "vector_env must reset ended sub-envs in the same step, as SB3 expects:"
                f" autoreset_mode=AutoresetMode.SAME_STEP, got {vector_env.autoreset_mode}"
            )
        self.vector_env = vector_env
        self._actions: np.ndarray | None = None
        super().__init__(
            vector_env.num_envs,
            vector_env.single_observation_space,
            vector_env.single_action_space,
        )

    def reset(self):
        options = self._options
        if any(o != options[0] for o in options):
            raise ValueError(
                "the vector env resets every sub-env with the same options;"
                f" got different ones per sub-env: {options}"
            )
        obs, infos = self.vector_env.reset(seed=self._seeds, options=options[0] or None)
        self.reset_infos = unbatch_infos(infos, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        if self._actions is None:
            raise RuntimeError("call step_async(actions) before step_wait()")
        obs, rewards, terminated, truncated, batched = self.vector_env.step(self._actions)
        self._actions = None
        infos = unbatch_infos(batched, self.num_envs)
        ended = terminated | truncated
        if ended.any():
            final_infos = unbatch_infos(batched["final_info"], self.num_envs)
            for i in np.flatnonzero(ended):
                # What the same-step reset returned, without the ended episode's entries.
                reset_info = {k: v for k, v in infos[i].items() if k not in _FINAL_KEYS}
                self.reset_infos[i] = reset_info
                infos[i] = {**final_infos[i], "terminal_observation": batched["final_obs"][i]}
        for i, info in enumerate(infos):
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), ended, infos

    def close(self) -> None:
        self.vector_env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        if self.render_mode != "rgb_array":
            warnings.warn(
                f"The render mode is {self.render_mode}, but get_images needs 'rgb_array'.",
                stacklevel=2,
            )
            return [None] * self.num_envs
        return list(self.vector_env.render())

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        fn = methodcaller("get_wrapper_attr", attr_name)
        return list(self.vector_env.apply(fn, self._get_indices(indices)))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        fn = methodcaller("set_wrapper_attr", attr_name, value)
        self.vector_env.apply(fn, self._get_indices(indices))

    def env_method(
        self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs
    ) -> list[Any]:
        fn = functools.partial(
            call_or_read, name=method_name, args=method_args, kwargs=method_kwargs
        )
        return list(self.vector_env.apply(fn, self._get_indices(indices)))

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        fn = functools.partial(is_wrapped, wrapper_class=wrapper_class)
        return list(self.vector_env.apply(fn, self._get_indices(indices)))
