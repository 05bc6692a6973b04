"""Refactors keep behaviour: fixed-seed rollouts of every v2 and v1 id, and of the v0 joint
ids, match a recording.

``tests/data/rollouts.npz`` holds, for every v2 and v1 id (``LEGACY_ENV_IDS``) and v0 joint
id (``LEGACY_JOINT_ENV_IDS``) and two seeds, the scripted policy's and a random policy's
episodes (observations, rewards, terminations and the errors in ``info``): the v1 ids'
recorded on main before the probing stack was restructured, the v2 ids' before the
perception layer moved out of the env, the v0 joint ids' on main before their v1. A
change that moves them on purpose re-records them (``PYTHONPATH=. python
tests/test_rollout_identity.py``) and names the change in its commit and in the ids' Version
History.
"""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents.joint_scripted import joint_policy
from agents.scripted import scripted_policy
from tactile_gym import LEGACY_ENV_IDS, LEGACY_JOINT_ENV_IDS

RECORDING = Path(__file__).parent / "data" / "rollouts.npz"
SEEDS = (0, 1)
#: Control steps for the 6-D ids, primitives for the primitive ids.
STEPS = {True: 8, False: 60}
#: Floating-point order may move the last bits (docs/design.md, "Versions"); nothing else.
TOLERANCE = 1e-9


def _key(env_id: str, policy: str, seed: int) -> str:
    return f"{env_id.split('/')[-1]}|{policy}|{seed}"


def rollout(env_id: str, policy: str, seed: int) -> dict[str, np.ndarray]:
    """One episode, cut at ``STEPS`` steps: flat observations, rewards, ends and errors."""
    env = gym.make(env_id)
    primitive = env.action_space.shape == (3,)
    obs, info = env.reset(seed=seed)
    scripted = None
    if policy == "scripted":
        scripted = joint_policy(env) if env_id in LEGACY_JOINT_ENV_IDS else scripted_policy(env)
    if scripted is not None:
        scripted.reset()
    env.action_space.seed(seed)
    flat, rewards, ends, errors = [], [], [], []
    space = env.get_wrapper_attr("dict_observation_space")
    for _ in range(STEPS[primitive]):
        action = env.action_space.sample() if scripted is None else scripted.get_action(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        flat.append(gym.spaces.flatten(space, obs))
        rewards.append(reward)
        ends.append((terminated, truncated))
        errors.append((info["position_error"], info["angle_error"], info["n_measurements"]))
        if terminated or truncated:
            break
    env.close()
    return {
        "obs": np.asarray(flat, np.float64),
        "reward": np.asarray(rewards, np.float64),
        "ends": np.asarray(ends, bool),
        "errors": np.asarray(errors, np.float64),
    }


CASES = [
    (env_id, policy, seed)
    for env_id in LEGACY_ENV_IDS + LEGACY_JOINT_ENV_IDS
    for policy in ("scripted", "random")
    for seed in SEEDS
]


@pytest.mark.parametrize("env_id, policy, seed", CASES)
def test_rollout_matches_recording(env_id, policy, seed):
    recorded = np.load(RECORDING)
    key = _key(env_id, policy, seed)
    got = rollout(env_id, policy, seed)
    for field, value in got.items():
        want = recorded[f"{key}|{field}"]
        assert value.shape == want.shape, f"{key} {field}: {value.shape} != {want.shape}"
        if value.dtype == bool:
            np.testing.assert_array_equal(value, want, err_msg=f"{key} {field}")
        else:
            np.testing.assert_allclose(
                value, want, rtol=0, atol=TOLERANCE, err_msg=f"{key} {field}"
            )


def record() -> None:
    arrays = {}
    for env_id, policy, seed in CASES:
        for field, value in rollout(env_id, policy, seed).items():
            arrays[f"{_key(env_id, policy, seed)}|{field}"] = value
    RECORDING.parent.mkdir(exist_ok=True)
    np.savez_compressed(RECORDING, **arrays)
    print(f"recorded {len(CASES)} rollouts in {RECORDING}")


if __name__ == "__main__":
    sys.exit(record())
