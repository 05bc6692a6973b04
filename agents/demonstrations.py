"""Demonstrations: the scripted policy's episodes recorded, written and read back
(``docs/design.md``, Learning); ``python -m agents.demos`` is their command.

:func:`record_demos` runs the scripted baseline (:func:`agents.scripted.scripted_policy`, on
the 6-D ids the scripted skill executor; on the joint ids
:func:`agents.joint_scripted.joint_policy`) on episodes seeded ``DEMO_SEED + k`` (``agents.seeds``);
:func:`save_demos` writes them as plain NumPy (``.npz``), one row per env step
(:data:`STEP_FIELDS`) or per episode (:data:`EPISODE_FIELDS`), and :func:`save_minari` as a
Minari dataset (Farama's format for offline RL and imitation datasets, in Minari's dataset
folder: ``MINARI_DATASETS_PATH`` or ``~/.minari/datasets``), which
``minari.load_dataset(DATASET_ID)`` reads and whose ``recover_environment()`` makes the env
with the recording's keywords (the ``[clients]`` extra installs Minari):

========================  ==========  =====================================================
key                       shape       meaning
========================  ==========  =====================================================
``obs.<name>``            (T, ...)    dict observations, one array per key, before each step
``obs``                   (T, n)      flat observations (``observation_mode="flat"``) instead
``final_obs.<name>``      (E, ...)    each episode's last observation (``final_obs``: flat)
``acts``                  (T, A)      the actions taken (the env's action space)
``rews``                  (T,)        rewards
``terminated``            (T,)        the step ended the episode as a failure
``truncated``             (T,)        the step ended the episode by the step budget
``episode``               (T,)        index of the step's episode
``seeds``                 (E,)        reset seed of each episode
``final_position_error``  (E,)        m, at the episode's end (``info``; a record only:
                                      nothing that trains reads it)
``success``               (E,)        ``info["is_success"]`` at the end (a record only)
``meta``                  ()          JSON: env id, ``gym.make`` keywords, policy
========================  ==========  =====================================================

The ``imitation`` library's trajectory format was the alternative; its release pins
Gymnasium 0.29 and Stable-Baselines3 2.2, below this package's (design notes, Learning).
Minari installs beside Gymnasium 1.x and SB3 2.x; its own recorder (``DataCollector``) needs
JAX, so the dataset is written from the recorded arrays instead (``save_minari``).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from .cli import check_env_id, require
from .seeds import DEMO_SEED

__all__ = [
    "Demos",
    "EPISODE_FIELDS",
    "demos_path",
    "STEP_FIELDS",
    "load_demos",
    "record_demos",
    "save_demos",
    "save_minari",
]

#: Per-step arrays besides the observations.
STEP_FIELDS = ("acts", "rews", "terminated", "truncated", "episode")
#: Per-episode arrays.
EPISODE_FIELDS = ("seeds", "final_position_error", "success")


@dataclass
class Demos:
    """Demonstrations: per-step arrays (``T`` steps) and per-episode arrays (``E`` episodes).

    Attributes:
        obs: a dict of ``(T, ...)`` arrays (dict observations) or one ``(T, n)`` array.
        acts: ``(T, A)`` actions.
        rews: ``(T,)`` rewards.
        terminated: ``(T,)`` failure ends.
        truncated: ``(T,)`` step-budget ends.
        episode: ``(T,)`` episode index of each step.
        seeds: ``(E,)`` reset seeds.
        final_position_error: ``(E,)`` final position errors, m.
        success: ``(E,)`` final successes.
        meta: env id, ``gym.make`` keywords, policy.
        final_obs: each episode's last observation, as ``obs`` with ``E`` rows (None in files
            recorded before it was kept).
    """

    obs: dict[str, np.ndarray] | np.ndarray
    acts: np.ndarray
    rews: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    episode: np.ndarray
    seeds: np.ndarray
    final_position_error: np.ndarray
    success: np.ndarray
    meta: dict[str, Any]
    final_obs: dict[str, np.ndarray] | np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.acts)

    def discounted_returns(self, gamma: float, rewards: np.ndarray | None = None) -> np.ndarray:
        """``(T,)`` discounted return from each step to its episode's end (Monte Carlo,
        nothing bootstrapped after a truncation) of ``rewards`` (default: ``rews``)."""
        rewards = self.rews if rewards is None else rewards
        out = np.zeros(len(rewards))
        ahead = 0.0
        for t in range(len(rewards) - 1, -1, -1):
            last = t == len(rewards) - 1 or self.episode[t + 1] != self.episode[t]
            ahead = rewards[t] + (0.0 if last else gamma * ahead)
            out[t] = ahead
        return out


def record_demos(
    env_id: str,
    episodes: int,
    first_seed: int = DEMO_SEED,
    env_kwargs: dict[str, Any] | None = None,
    progress: Callable[[int], None] | None = None,
) -> Demos:
    """The scripted policy's episodes seeded ``first_seed + k`` (the joint ids':
    ``agents.joint_scripted.joint_policy``, as ``agents.policies.make_policy`` picks).

    Args:
        env_id: the id.
        episodes: how many.
        first_seed: the first episode's seed.
        env_kwargs: ``gym.make`` keywords.
        progress: called with the number of episodes recorded after each one.

    Raises:
        ValueError: an unknown id or fewer than one episode.
    """
    from .policies import make_policy

    check_env_id("env_id", env_id)
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    env = gym.make(env_id, **(env_kwargs or {}))
    policy = make_policy("scripted", env)
    steps: dict[str, list] = {key: [] for key in ("obs", *STEP_FIELDS)}
    seeds, errors, successes, finals = [], [], [], []
    try:
        for k in range(episodes):
            seed = first_seed + k
            obs, info = env.reset(seed=seed)
            env.action_space.seed(seed)
            policy.reset()
            terminated = truncated = False
            while not (terminated or truncated):
                action = policy.get_action(obs)
                steps["obs"].append(obs)
                obs, reward, terminated, truncated, info = env.step(action)
                for key, value in zip(
                    STEP_FIELDS, (action, reward, terminated, truncated, k), strict=True
                ):
                    steps[key].append(value)
            seeds.append(seed)
            finals.append(obs)
            errors.append(float(info["position_error"]))
            successes.append(bool(info["is_success"]))
            if progress is not None:
                progress(k + 1)
    finally:
        env.close()
    return Demos(
        obs=_stacked(steps["obs"]),
        acts=np.asarray(steps["acts"], dtype=np.float32),
        rews=np.asarray(steps["rews"], dtype=float),
        terminated=np.asarray(steps["terminated"], dtype=bool),
        truncated=np.asarray(steps["truncated"], dtype=bool),
        episode=np.asarray(steps["episode"], dtype=np.int64),
        seeds=np.asarray(seeds, dtype=np.int64),
        final_position_error=np.asarray(errors),
        success=np.asarray(successes, dtype=bool),
        meta={"env_id": env_id, "env_kwargs": dict(env_kwargs or {}), "policy": "scripted"},
        final_obs=_stacked(finals),
    )


def _stacked(observations: list) -> dict[str, np.ndarray] | np.ndarray:
    """A list of dict (or flat) observations as one array per key (or one array)."""
    if isinstance(observations[0], dict):
        return {key: np.stack([o[key] for o in observations]) for key in observations[0]}
    return np.stack(observations)


def save_demos(demos: Demos, path: str | Path) -> Path:
    """Write ``demos`` to ``path`` (``.npz``) and return it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {key: getattr(demos, key) for key in (*STEP_FIELDS, *EPISODE_FIELDS)}
    for name in ("obs", "final_obs"):
        value = getattr(demos, name)
        if isinstance(value, dict):
            arrays |= {f"{name}.{key}": array for key, array in value.items()}
        elif value is not None:
            arrays[name] = value
    np.savez_compressed(path, **arrays, meta=np.array(json.dumps(demos.meta)))
    return path


def load_demos(path: str | Path) -> Demos:
    """Demonstrations written by :func:`save_demos`.

    Raises:
        ValueError: a file that lacks one of the format's arrays, naming it.
    """
    with np.load(path) as data:
        missing = [k for k in (*STEP_FIELDS, *EPISODE_FIELDS, "meta") if k not in data.files]
        if missing:
            raise ValueError(f"{path} is not a demonstrations file: it lacks {missing}")
        obs, final_obs = (_read_obs(data, name) for name in ("obs", "final_obs"))
        fields = {k: data[k] for k in (*STEP_FIELDS, *EPISODE_FIELDS)}
        meta = json.loads(str(data["meta"]))
    return Demos(obs=obs, meta=meta, final_obs=final_obs, **fields)


def _read_obs(data, name: str) -> dict[str, np.ndarray] | np.ndarray | None:
    """The observations stored under ``name`` (one array, or ``name.<key>`` arrays)."""
    if name in data.files:
        return data[name]
    prefix = f"{name}."
    keyed = {k.removeprefix(prefix): data[k] for k in data.files if k.startswith(prefix)}
    return keyed or None


def save_minari(demos: Demos, dataset_id: str) -> Any:
    """Write ``demos`` as the Minari dataset ``dataset_id`` (e.g.
    ``tactile_gym/HingeProbePrimitive-v2/scripted-v0``) in Minari's dataset folder: one
    episode per demonstrated episode, with its reset seed, its observations (the last one
    included), actions, rewards and ends, and the env's spec with the recording's keywords.

    Returns:
        The ``minari.MinariDataset``.

    Raises:
        ImportError: Minari is not installed (the ``[clients]`` extra).
        ValueError: demonstrations without their final observations (an old file).
    """
    minari = require("minari", "clients")
    from minari.data_collector import EpisodeBuffer

    if demos.final_obs is None:
        raise ValueError("these demonstrations lack their final observations; record them again")
    buffers = []
    for k, seed in enumerate(demos.seeds):
        rows = demos.episode == k

        def observations(steps, final, k=k, rows=rows):
            return np.concatenate([steps[rows], final[k : k + 1]])

        if isinstance(demos.obs, dict):
            obs = {key: observations(demos.obs[key], demos.final_obs[key]) for key in demos.obs}
        else:
            obs = observations(demos.obs, demos.final_obs)
        buffers.append(
            EpisodeBuffer(
                id=k,
                seed=int(seed),
                observations=obs,
                actions=demos.acts[rows],
                rewards=demos.rews[rows].tolist(),
                terminations=demos.terminated[rows].tolist(),
                truncations=demos.truncated[rows].tolist(),
            )
        )
    env = gym.make(demos.meta["env_id"], **demos.meta["env_kwargs"])
    try:
        return minari.create_dataset_from_buffers(
            dataset_id,
            buffers,
            env=env.spec,
            algorithm_name=demos.meta["policy"],
            author="tactile_gym",
            description=f"{demos.meta['policy']} policy on {demos.meta['env_id']}, seeds "
            f"{int(demos.seeds[0])}..{int(demos.seeds[-1])} (agents.demos)",
            observation_space=env.observation_space,
            action_space=env.action_space,
        )
    finally:
        env.close()


def demos_path(out: str | Path, env_id: str) -> Path:
    """``<out>/<Name>.npz`` for an id ``tactile_gym/<Name>``."""
    return Path(out) / f"{env_id.split('/')[-1]}.npz"
