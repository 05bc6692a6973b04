"""API conformance of every registered env (Gymnasium tests/envs/test_envs.py style)."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import load_env_creator
from gymnasium.utils.env_checker import check_env as gym_check_env

import tactile_gym
from tactile_gym import ENV_IDS, JOINT_ENV_IDS
from tactile_gym.envs.hinge_probe import HingeProbeEnv
from tactile_gym.envs.hinge_probe_primitive import HingeProbePrimitiveEnv
from tactile_gym.envs.skills import PRIMITIVE_KIND
from tactile_gym.envs.task import REWARD_TERMS

N_STEPS = 15
#: The ids every conformance test runs on: the HingeProbe ids and the joint ids.
ALL_IDS = ENV_IDS + JOINT_ENV_IDS


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


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_gymnasium_check_env(env_id, monkeypatch):
    # Gymnasium's default check renders every declared mode. Without a display the env does
    # not declare "human" (it would open PyBullet's GUI and kill the process), so the check
    # passes headless; with one it would open the GUI, which CI never has.
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    # The env as its entry point makes it, without gym.make's checking wrappers; for the
    # primitive ids that is the primitive env driving its 6-D env.
    spec = gym.spec(env_id)
    env = load_env_creator(spec.entry_point)(**spec.kwargs)
    env.unwrapped.spec = spec  # what gym.make sets; the check re-makes the env from it
    assert "human" not in env.metadata["render_modes"]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*is different from the unwrapped")
        gym_check_env(env)
    env.close()


@pytest.mark.parametrize("env_id", [i for i in ALL_IDS if "Primitive" in i])
def test_primitive_ids_are_an_env_driving_the_6d_env(env_id):
    env = gym.make(env_id, max_primitives=3, probe_along=0.005)
    primitive = env.unwrapped
    # The env a user acts on is the unwrapped one (tools check and introspect it); the 6-D
    # env it drives, with its tare component (v2), is its control_env.
    assert isinstance(primitive, HingeProbePrimitiveEnv) and not isinstance(primitive, gym.Wrapper)
    assert primitive.action_space == env.action_space
    assert primitive.observation_space == env.observation_space
    assert primitive.max_primitives == 3 and primitive.scales.probe_along == 0.005
    assert isinstance(primitive.control_env, HingeProbeEnv)
    assert primitive.control_env.action_space.shape == (7,)
    assert env.spec.max_episode_steps == 3
    assert env.get_wrapper_attr("dict_observation_space") is primitive.dict_observation_space
    obs, info = env.reset(seed=0)
    assert info["primitive_kind"] == 0 and info["steps"] == 0
    for _ in range(3):
        obs, _, terminated, truncated, info = env.step(np.array([-1.0, 0.0, 0.0], np.float32))
    assert truncated and not terminated  # after max_primitives
    assert info["steps"] >= 1 and info["primitive_kind"] == PRIMITIVE_KIND["probe"]
    # The README's accessor: the episode's measurements, with their points and edges.
    assert primitive.measurements is primitive.control_env.measurements
    for m in primitive.measurements:
        assert m.point.shape == (3,) and m.edge.shape == (3,)
    assert info["n_measurements"] == len(primitive.measurements)
    env.close()


def test_human_render_without_a_display_is_a_clear_error(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    with pytest.raises(RuntimeError, match="needs a display"):
        gym.make(ENV_IDS[0], render_mode="human")


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_sb3_check_env(env_id):
    sb3_env_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(env_id)
    sb3_env_checker.check_env(env, warn=True)
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
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


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_consecutive_resets_differ(env_id):
    env = gym.make(env_id)
    obs_a, info_a = env.reset(seed=1)
    obs_b, info_b = env.reset()
    assert not np.array_equal(_flat(obs_a), _flat(obs_b))
    assert not np.allclose(info_a["true_axis_point"], info_b["true_axis_point"])
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_observations_in_space_and_float32(env_id):
    env = gym.make(env_id)
    traj, _ = _rollout(env, seed=3)
    for obs in traj:
        assert env.observation_space.contains(obs)
    for space in env.observation_space.spaces.values():
        assert space.dtype == np.float32
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_flat_observation_variant(env_id):
    env = gym.make(env_id, observation_mode="flat")
    assert isinstance(env.observation_space, gym.spaces.Box)
    obs, _ = env.reset(seed=0)
    dict_obs, _ = gym.make(env_id).reset(seed=0)
    layout = env.get_wrapper_attr("codec").layout  # the primitive ids' with their summary
    assert obs.shape == (sum(n for _, n in layout),)
    assert env.observation_space.contains(obs)
    space = env.get_wrapper_attr("dict_observation_space")
    np.testing.assert_array_equal(obs, gym.spaces.flatten(space, dict_obs))
    np.testing.assert_array_equal(obs, np.concatenate([dict_obs[k] for k, _ in layout]))
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
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


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_reward_is_sum_of_terms(env_id):
    env = gym.make(env_id)
    env.reset(seed=2)
    env.action_space.seed(2)
    for _ in range(N_STEPS):
        _, reward, terminated, truncated, info = env.step(env.action_space.sample())
        terms = [v for k, v in info.items() if k.startswith("reward_")]
        assert len(terms) == len(REWARD_TERMS)
        assert reward == pytest.approx(sum(terms), abs=1e-12)
        if terminated or truncated:
            break
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
@pytest.mark.parametrize("bad", ["short", "matrix", "nan", "inf"])
def test_bad_actions_raise(env_id, bad):
    env = gym.make(env_id)
    env.reset(seed=0)
    n = env.action_space.shape[0]
    action = {
        "short": np.zeros(n - 1),
        "matrix": np.zeros((2, n)),
        "nan": np.r_[np.nan, np.zeros(n - 1)],
        "inf": np.full(n, np.inf),
    }[bad]
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_stepping_after_the_episode_ended_raises(env_id):
    env = gym.make(env_id, max_steps=2)
    env.reset(seed=0)
    truncated = False
    while not truncated:
        *_, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape, np.float32))
        assert not terminated
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(np.zeros(env.action_space.shape, np.float32))
    env.reset(seed=1)
    env.step(np.zeros(env.action_space.shape, np.float32))
    env.close()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"not_a_keyword": 1}, "allowed"),
        ({"max_translation": -0.001}, "max_translation"),
        ({"families": ("sphere",)}, "families"),
        ({"estimator": "4d"}, "estimator"),
        ({"families": ("door",), "estimator": "planar"}, "planar"),
        ({"skin": {"friction": -0.1}}, "skin.friction"),
        ({"sensor": {"force_noise_std": "0.02"}}, "force_noise_std"),
        ({"object": {"holding_torque": True}}, "holding_torque"),
        ({"randomize": "False"}, "randomize"),
        ({"substeps": True}, "substeps"),
        ({"substeps": 10**6}, "substeps"),
        ({"scenario": {"position_jitter": 1000}}, "position_jitter"),
        ({"task": {"error_scale": 0}}, "error_scale"),
        ({"task": {"error_cap": -0.1}}, "error_cap"),
        ({"gate": {"force_band": (5.0, 1.0)}}, "force_band"),
        ({"task": {"bogus": 1}}, "allowed"),
        ({"substeps": 0}, "substeps"),
    ],
)
def test_bad_keywords_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(ENV_IDS[0], **kwargs)


def test_env_ids_registered():
    assert len(set(tactile_gym.ENV_IDS)) == len(set(tactile_gym.JOINT_ENV_IDS)) == 4
    assert {i for i in JOINT_ENV_IDS if "Primitive" in i} <= set(tactile_gym.PRIMITIVE_ENV_IDS)
    for env_id in ALL_IDS:
        # The env truncates by itself (its observation says how much time is left).
        assert gym.spec(env_id).max_episode_steps is None
    with pytest.raises(gym.error.Error):
        gym.spec("tactile_gym/HingeProbe-v0")


def test_render_rgb_array():
    env = gym.make(ENV_IDS[0], render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 0  # not a blank image
    env.close()
