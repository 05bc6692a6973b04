"""API conformance of every registered env (Gymnasium tests/envs/test_envs.py style)."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import tactile_gym
from tactile_gym import ENV_IDS

N_STEPS = 15


def _rollout(env: gym.Env, seed: int, n_steps: int = N_STEPS):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    trajectory = [obs]
    rewards = []
    for _ in range(n_steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        trajectory.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            break
    return trajectory, rewards


def _flat(obs) -> np.ndarray:
    if isinstance(obs, dict):
        return np.concatenate([np.ravel(obs[k]) for k in sorted(obs)])
    return np.ravel(obs)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id).unwrapped
    gym_check_env(env, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_check_env(env_id):
    sb3_env_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(env_id)
    sb3_env_checker.check_env(env, warn=True)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_rollout(env_id):
    env_a, env_b = gym.make(env_id), gym.make(env_id)
    traj_a, rew_a = _rollout(env_a, seed=7)
    traj_b, rew_b = _rollout(env_b, seed=7)
    assert len(traj_a) == len(traj_b)
    for a, b in zip(traj_a, traj_b):
        np.testing.assert_array_equal(_flat(a), _flat(b))
    np.testing.assert_array_equal(rew_a, rew_b)
    # The same env, reset with the same seed again, replays the episode exactly.
    traj_c, _ = _rollout(env_a, seed=7)
    for a, c in zip(traj_a, traj_c):
        np.testing.assert_array_equal(_flat(a), _flat(c))
    env_a.close()
    env_b.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_consecutive_resets_differ(env_id):
    env = gym.make(env_id)
    obs_a, info_a = env.reset(seed=1)
    obs_b, info_b = env.reset()
    assert not np.array_equal(_flat(obs_a), _flat(obs_b))
    assert not np.allclose(info_a["true_axis_point"], info_b["true_axis_point"])
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_observations_in_space_and_float32(env_id):
    env = gym.make(env_id)
    traj, _ = _rollout(env, seed=3)
    for obs in traj:
        assert env.observation_space.contains(obs)
    for space in env.observation_space.spaces.values():
        assert space.dtype == np.float32
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_flat_observation_variant(env_id):
    env = gym.make(env_id, observation_mode="flat")
    assert isinstance(env.observation_space, gym.spaces.Box)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (34,) and env.observation_space.contains(obs)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_close_twice_and_pickle(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    clone = pickle.loads(pickle.dumps(gym.make(env_id)))
    clone.reset(seed=0)
    clone.close()
    env.close()
    env.close()


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_envs(mode):
    envs = gym.make_vec(ENV_IDS[0], num_envs=2, vectorization_mode=mode)
    obs, _ = envs.reset(seed=0)
    for _ in range(3):
        obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert reward.shape == (2,)
    assert obs["wrench"].shape == (2, 6)
    envs.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reward_is_sum_of_terms(env_id):
    env = gym.make(env_id)
    env.reset(seed=2)
    env.action_space.seed(2)
    for _ in range(N_STEPS):
        _, reward, terminated, truncated, info = env.step(env.action_space.sample())
        terms = [v for k, v in info.items() if k.startswith("reward_")]
        assert len(terms) == 3
        assert reward == pytest.approx(sum(terms), abs=1e-12)
        if terminated or truncated:
            break
    env.close()


@pytest.mark.parametrize(
    "action",
    [np.zeros(5), np.zeros((2, 6)), np.array([0, 0, np.nan, 0, 0, 0]), np.full(6, np.inf)],
)
def test_bad_actions_raise(action):
    env = gym.make(ENV_IDS[0])
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    env.close()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"not_a_keyword": 1}, "allowed"),
        ({"max_translation": -0.001}, "max_translation"),
        ({"families": ("sphere",)}, "families"),
        ({"estimator_mode": "4d"}, "estimator_mode"),
        ({"families": ("door",), "estimator_mode": "planar"}, "planar"),
        ({"gate": {"force_band": (5.0, 1.0)}}, "force_band"),
        ({"task": {"bogus": 1}}, "allowed"),
        ({"substeps": 0}, "substeps"),
    ],
)
def test_bad_keywords_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(ENV_IDS[0], **kwargs)


def test_env_ids_registered():
    for env_id in tactile_gym.ENV_IDS:
        spec = gym.spec(env_id)
        assert spec.max_episode_steps == tactile_gym.MAX_EPISODE_STEPS


def test_render_rgb_array():
    env = gym.make(ENV_IDS[0], render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 0  # not a blank image
    env.close()
