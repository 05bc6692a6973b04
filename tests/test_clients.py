"""The RL clients people already use work on every id as is (the ``[clients]`` extra).

Each client's test is skipped, with the reason, when its package is absent; CI installs the
extra. What the clients read by convention is checked here too:

* an unknown keyword raises an error that is a ``TypeError`` in Python's wording (TorchRL's
  ``GymEnv`` passes ``frameskip`` and drops it on that error) and a ``ValueError``;
* ``info`` is flat: NumPy scalars or arrays, no dicts, no strings, no key shared with the
  observation, the same keys at reset and at every step (TorchRL's info reader);
* ``spec.max_episode_steps`` is the env's horizon (``TimeAwareObservation``);
* ``env.unwrapped`` is the env a user acts on, so checkers run on it (Gymnasium's and SB3's);
* TorchRL's ``GymEnv`` and ``check_env_specs`` on every id, and its ``GymWrapper`` over the
  vector env with same-step autoreset; skrl over a single env and over the vector env with
  same-step autoreset (skrl's wrapper takes every step's observation as the next state, so a
  next-step autoreset would hand it a transition that is no step of the env).
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers import TimeAwareObservation

from tactile_gym import ENV_IDS, JOINT_ENV_IDS, PRIMITIVE_ENV_IDS
from tactile_gym.envs.observation import ProgressObs

#: The HingeProbe ids and the joint ids.
ALL_IDS = ENV_IDS + JOINT_ENV_IDS
SIX_D = [i for i in ALL_IDS if i not in PRIMITIVE_ENV_IDS]
PRIMITIVE = [i for i in ALL_IDS if i in PRIMITIVE_ENV_IDS]
SHORT = {"max_steps": 40}


def _make(env_id: str, **kwargs):
    return gym.make(env_id, **{**SHORT, **kwargs})


# --------------------------------------------------------------------------- conventions


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_an_unknown_keyword_is_a_type_error_in_pythons_wording_and_a_value_error(env_id):
    for error in (TypeError, ValueError):
        with pytest.raises(error, match="unexpected keyword argument 'frameskip'"):
            gym.make(env_id, frameskip=1)


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_info_is_flat_numeric_and_the_same_at_reset_and_every_step(env_id):
    env = _make(env_id)
    obs_keys = set(env.observation_space.spaces)
    _, first = env.reset(seed=0)
    infos = [first]
    env.action_space.seed(0)
    done = False
    while not done:
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        infos.append(info)
        done = terminated or truncated
    env.close()
    for info in infos:
        assert set(info) == set(first)
        assert not set(info) & obs_keys
        for key, value in info.items():
            assert isinstance(value, (np.generic, np.ndarray)), (key, type(value))
            assert not isinstance(value, np.str_), key
    assert {"termination_left_workspace", "termination_shell_contact"} <= set(first)


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_the_horizon_is_in_the_spec_and_time_aware_observation_reads_it(env_id):
    env = _make(env_id)
    horizon = 64 if env_id in PRIMITIVE else SHORT["max_steps"]
    assert env.spec.max_episode_steps == horizon
    aware = TimeAwareObservation(env, flatten=False)
    obs, _ = aware.reset(seed=1)
    assert obs["time"] == 0
    obs, *_ = aware.step(aware.action_space.sample())
    assert obs["time"] == 1
    # The env's own clock (the observation's time left) agrees with its horizon.
    if env_id not in PRIMITIVE:
        assert ProgressObs.read(obs).time_left == pytest.approx(1 - 1 / horizon)
    aware.close()


@pytest.mark.parametrize("env_id", PRIMITIVE)
def test_checkers_run_on_the_unwrapped_primitive_env(env_id, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = _make(env_id)
    unwrapped = env.unwrapped
    assert unwrapped.action_space.shape == (3,) == env.action_space.shape
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*is different from the unwrapped")
        gym_check_env(unwrapped)
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(unwrapped, warn=True)
    env.close()


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_an_out_of_bound_action_acts_as_its_bound_on_the_unwrapped_env(env_id):
    """Gymnasium's own env tests (``test_box_actions_out_of_bound``) step ``unwrapped`` with
    an action beyond the bounds and expect what the bound gives; their comparison is of
    array observations, this one of the Dict observation."""
    from gymnasium.utils.env_checker import data_equivalence

    # A joint id's primitive at its bound moves up to 80 mm, lifting first (the TorchRL test).
    steps = SHORT["max_steps"] * (4 if env_id in JOINT_ENV_IDS else 1)
    bound, beyond = (_make(env_id, max_steps=steps).unwrapped for _ in range(2))
    high = bound.action_space.high
    for env in (bound, beyond):
        env.reset(seed=42)
    for i in range(len(high)):
        oob = high.copy()
        oob[i] += 3.0
        obs, *_ = bound.step(high)
        oob_obs, *_ = beyond.step(oob)
        assert data_equivalence(obs, oob_obs), i
    bound.close()
    beyond.close()


# --------------------------------------------------------------------------- TorchRL


@pytest.fixture
def torchrl():
    torchrl = pytest.importorskip("torchrl", reason="TorchRL is in the [clients] extra")
    import logging

    logging.getLogger("torchrl").setLevel(logging.WARNING)
    return torchrl


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_torchrl_gym_env_and_its_spec_check(torchrl, env_id):
    from torchrl.envs import GymEnv, default_info_dict_reader
    from torchrl.envs.utils import check_env_specs

    # A joint id's random primitive moves up to 80 mm, lifting first: longer than 40 steps.
    env = GymEnv(env_id, max_steps=SHORT["max_steps"] * (4 if env_id in JOINT_ENV_IDS else 1))
    env.set_info_dict_reader(default_info_dict_reader())
    check_env_specs(env, seed=0)
    env.set_seed(0)
    # A random primitive can end an episode early (leaving the workspace); the rollout goes on
    # through the reset, so its length does not hang on the actions drawn.
    rollout = env.rollout(3, break_when_any_done=False)
    assert rollout["next", "position_error"].shape == (3,)
    assert rollout["next", "termination_overloaded"].dtype.is_floating_point is False
    env.close()


@pytest.mark.parametrize("env_id", [SIX_D[0], PRIMITIVE[0]])
@pytest.mark.parametrize("mode", ["vector_entry_point", "sync"])
def test_torchrl_over_a_same_step_vector_env(torchrl, env_id, mode):
    from torchrl.envs import GymWrapper

    same = {"autoreset_mode": AutoresetMode.SAME_STEP}
    kwargs = same if mode == "vector_entry_point" else {"vector_kwargs": same}
    envs = gym.make_vec(env_id, 2, vectorization_mode=mode, max_steps=12, **kwargs)
    wrapped = GymWrapper(envs)
    wrapped.set_seed(0)
    rollout = wrapped.rollout(15 if env_id in SIX_D else 3, break_when_any_done=False)
    assert rollout["next", "reward"].shape[:2] == (2, 15 if env_id in SIX_D else 3)
    assert rollout["next", "done"].any() or env_id in PRIMITIVE
    wrapped.close()


# --------------------------------------------------------------------------- skrl


@pytest.fixture
def skrl_wrap():
    pytest.importorskip("skrl", reason="skrl is in the [clients] extra")
    from skrl.envs.wrappers.torch import wrap_env

    return lambda env: wrap_env(env, verbose=False)


@pytest.mark.parametrize("env_id", [SIX_D[0], PRIMITIVE[0]])
def test_skrl_over_a_single_env_and_a_same_step_vector_env(skrl_wrap, env_id):
    import torch

    single = skrl_wrap(_make(env_id))
    states, _ = single.reset()
    assert states.shape == (1, gym.spaces.flatdim(single.observation_space))
    action = torch.zeros((1, *single.action_space.shape))
    states, reward, terminated, truncated, _ = single.step(action)
    assert reward.shape == terminated.shape == (1, 1)
    single.close()
    envs = gym.make_vec(env_id, 2, max_steps=8, autoreset_mode=AutoresetMode.SAME_STEP)
    vector = skrl_wrap(envs)
    envs.action_space.seed(0)
    states, _ = vector.reset()
    # Where the flat state holds the time left (the keys in sorted order, as flattened).
    layout = envs.get_attr("codec")[0].layout
    time_left = sum(size for key, size in layout[: [k for k, _ in layout].index("progress")])
    time_left += [name for name, _ in ProgressObs.entries()].index("time_left")
    for _ in range(10 if env_id in SIX_D else 4):
        actions = torch.as_tensor(envs.action_space.sample(), dtype=torch.float32)
        states, reward, terminated, truncated, _ = vector.step(actions)
        ended = (terminated | truncated)[:, 0]
        if ended.any():
            break
    assert ended.any()
    # Same-step autoreset: the state skrl takes next is the new episode's first.
    assert (states[ended, time_left] == 1.0).all()
    vector.close()
