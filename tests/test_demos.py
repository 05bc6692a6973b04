"""Demonstrations: recording, the file format and replay on the recorded seeds."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tactile_gym  # noqa: F401 - registers the envs
from agents import demos as demos_module
from agents.demonstrations import (
    EPISODE_FIELDS,
    STEP_FIELDS,
    load_demos,
    record_demos,
    save_demos,
    save_minari,
)
from agents.joint_scripted import joint_policy

ENV_ID = "tactile_gym/HingeProbePrimitive-v2"
SHORT = {"max_primitives": 6}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    path = tmp_path_factory.mktemp("demos") / "demos.npz"
    return save_demos(record_demos(ENV_ID, 2, first_seed=123, env_kwargs=SHORT), path)


def test_round_trip_keeps_shapes_seeds_and_meta(recorded):
    demos = load_demos(recorded)
    env = gym.make(ENV_ID, **SHORT)
    n = len(demos)
    assert n == len(demos.acts) and 2 <= n <= 12
    assert list(demos.seeds) == [123, 124]
    assert demos.acts.shape == (n, *env.action_space.shape)
    assert set(demos.obs) == set(env.observation_space.spaces)
    for key, space in env.observation_space.spaces.items():
        assert demos.obs[key].shape == (n, *space.shape)
    for key in STEP_FIELDS:
        assert getattr(demos, key).shape == (n,) or key == "acts"
    for key in EPISODE_FIELDS:
        assert getattr(demos, key).shape == (2,)
    assert sorted(set(demos.episode)) == [0, 1]
    # Each episode ends exactly once, at its last step.
    ends = demos.terminated | demos.truncated
    assert np.flatnonzero(ends).tolist() == [
        int(np.flatnonzero(demos.episode == k)[-1]) for k in range(2)
    ]
    assert demos.meta == {
        "env_id": ENV_ID,
        "env_kwargs": SHORT,
        "policy": "scripted",
    }
    env.close()


def test_replaying_the_actions_on_the_seeds_reproduces_the_rewards(recorded):
    demos = load_demos(recorded)
    env = gym.make(ENV_ID, **demos.meta["env_kwargs"])
    for k, seed in enumerate(demos.seeds):
        steps = np.flatnonzero(demos.episode == k)
        obs, _ = env.reset(seed=int(seed))
        for t in steps:
            for key in obs:
                np.testing.assert_array_equal(obs[key], demos.obs[key][t])
            obs, reward, terminated, truncated, info = env.step(demos.acts[t])
            assert reward == demos.rews[t]
            assert (terminated, truncated) == (demos.terminated[t], demos.truncated[t])
        assert info["position_error"] == demos.final_position_error[k]
    env.close()


def test_discounted_returns_restart_at_each_episode(recorded):
    demos = load_demos(recorded)
    returns = demos.discounted_returns(0.5)
    for k in range(2):
        steps = np.flatnonzero(demos.episode == k)
        expected = sum(0.5**i * demos.rews[t] for i, t in enumerate(steps))
        assert returns[steps[0]] == pytest.approx(expected)
        assert returns[steps[-1]] == demos.rews[steps[-1]]


def test_flat_observations_and_the_command_line(tmp_path, capsys):
    path = demos_module.main(
        ["--env", ENV_ID, "--episodes", "1", "--seed", "7", "--out", str(tmp_path),
         "--env-kwargs", "max_primitives:3", "observation_mode:flat"]
    )  # fmt: skip
    assert path == tmp_path / "HingeProbePrimitive-v2.npz"
    demos = load_demos(path)
    assert isinstance(demos.obs, np.ndarray) and demos.obs.shape[0] == len(demos) <= 3
    assert list(demos.seeds) == [7] and "seeds 7..7" in capsys.readouterr().out


def test_joint_ids_record_the_joint_baseline():
    """A joint id's demonstrations are agents.joint_scripted.joint_policy's actions (the
    hinge baseline refuses those ids), so the warm start clones the baseline it is compared
    with."""
    env_id = "tactile_gym/JointProbePrimitive-v1"
    demos = record_demos(env_id, 1, first_seed=5, env_kwargs=SHORT)
    env = gym.make(env_id, **SHORT)
    policy = joint_policy(env)
    obs, _ = env.reset(seed=5)
    policy.reset()
    for action in demos.acts:
        expected = policy.get_action(obs)
        np.testing.assert_array_equal(action, expected)
        obs, *_ = env.step(expected)
    env.close()


def test_bad_input_is_refused(tmp_path):
    with pytest.raises(ValueError, match="episodes"):
        record_demos(ENV_ID, 0)
    with pytest.raises(ValueError, match="env_id"):
        record_demos("tactile_gym/Nope-v1", 1)
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="lacks"):
        load_demos(tmp_path / "other.npz")


def test_demos_as_a_minari_dataset_that_minari_loads(recorded, tmp_path, monkeypatch):
    """Farama's dataset format: minari.load_dataset reads the demonstrations back, episode by
    episode, with the last observation, and recovers the env with its keywords."""
    minari = pytest.importorskip("minari", reason="Minari is in the [clients] extra")
    pytest.importorskip("h5py", reason="Minari's HDF5 storage is in the [clients] extra")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    demos = load_demos(recorded)
    dataset_id = "tactile_gym/HingeProbePrimitive-v2/scripted-v0"
    save_minari(demos, dataset_id)
    dataset = minari.load_dataset(dataset_id)
    assert dataset.total_episodes == 2 and dataset.total_steps == len(demos)
    for episode in dataset.iterate_episodes():
        rows = demos.episode == episode.id
        np.testing.assert_array_equal(episode.actions, demos.acts[rows])
        np.testing.assert_array_equal(episode.rewards, demos.rews[rows])
        np.testing.assert_array_equal(episode.terminations, demos.terminated[rows])
        for key, steps in demos.obs.items():
            np.testing.assert_array_equal(episode.observations[key][:-1], steps[rows])
            np.testing.assert_array_equal(
                episode.observations[key][-1], demos.final_obs[key][episode.id]
            )
    env = dataset.recover_environment()
    assert env.spec.id == ENV_ID and env.spec.kwargs["max_primitives"] == SHORT["max_primitives"]
    obs, _ = env.reset(seed=int(demos.seeds[0]))
    first = dataset[0].observations
    for key in obs:
        np.testing.assert_array_equal(obs[key], first[key][0])
    env.close()
