"""The vector env of every id (``tactile_gym/envs/vector.py``, ``docs/design.md`` 7.9).

Sub-env i must be ``gym.make(id)`` with the same seed and actions, across autoresets; one
sub-env's end must not disturb the others; the vector env must behave as Gymnasium's own
``SyncVectorEnv`` over ``gym.make`` (the reference implementation of the conventions; the
installed Gymnasium ships no vector env checker) and reject bad input by name. With worker
processes (``workers=2``) it must give exactly what it gives in one process.
"""

from __future__ import annotations

import functools
import gc
import multiprocessing
import os
import signal

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.wrappers.vector import FlattenObservation, RecordEpisodeStatistics

from tactile_gym import ENV_IDS, JOINT_ENV_IDS
from tactile_gym.envs.vector import MAX_NUM_ENVS, HingeProbeVectorEnv

#: Short episodes, so that a few steps cross an autoreset.
SHORT = {True: {"max_primitives": 2}, False: {"max_steps": 4}}


def _primitive(env_id: str) -> bool:
    return "Primitive" in env_id


def _make_vec(env_id: str, num_envs: int, **kwargs) -> VectorEnv:
    return gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
    )


def _row(obs, i: int):
    return {k: v[i] for k, v in obs.items()} if isinstance(obs, dict) else obs[i]


@pytest.mark.parametrize("env_id", ENV_IDS + JOINT_ENV_IDS)
def test_make_vec_gives_the_vector_env_with_gymnasium_conventions(env_id):
    envs = _make_vec(env_id, 2)
    assert isinstance(envs, HingeProbeVectorEnv) and isinstance(envs, VectorEnv)
    # Without a mode, make_vec picks the vector entry point too.
    default = gym.make_vec(env_id, num_envs=1)
    assert isinstance(default, HingeProbeVectorEnv)
    single = gym.make(env_id)
    assert envs.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert envs.single_observation_space == single.observation_space
    assert envs.single_action_space == single.action_space
    assert envs.action_space.shape == (2, *single.action_space.shape)
    obs, info = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)
    assert all(v.shape[0] == 2 for v in obs.values())
    obs, rewards, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert envs.observation_space.contains(obs)
    assert rewards.shape == terminated.shape == truncated.shape == (2,)
    assert rewards.dtype == np.float64 and terminated.dtype == truncated.dtype == np.bool_
    # Infos batched the Gymnasium way: one entry per sub-env and a mask.
    assert info["position_error"].shape == (2,) and info["_position_error"].all()
    # Flat and numeric: one flag per termination reason (NumPy booleans, which Gymnasium's
    # batching keeps as objects, as SyncVectorEnv does), no nested dicts, no strings.
    assert info["termination_left_workspace"].shape == (2,)
    assert all(isinstance(flag, np.bool_) for flag in info["termination_left_workspace"])
    assert not any(isinstance(v, (dict, str)) for v in info.values())
    flat = _make_vec(env_id, 2, observation_mode="flat")
    flat_obs, _ = flat.reset(seed=0)
    space = single.get_wrapper_attr("dict_observation_space")
    first, _ = single.reset(seed=0)
    assert flat_obs.shape == (2, gym.spaces.flatdim(space))
    np.testing.assert_array_equal(flat_obs[0], gym.spaces.flatten(space, first))
    # Worker processes through make_vec's keywords: the same env, the same first step.
    spread = _make_vec(env_id, 2, workers=2)
    assert spread.workers == 2 and spread.metadata == envs.metadata
    assert spread.observation_space == envs.observation_space
    actions = envs.action_space.sample()
    assert data_equivalence(spread.reset(seed=0), envs.reset(seed=0), exact=True)
    assert data_equivalence(spread.step(actions), envs.step(actions), exact=True)
    for env in (envs, default, flat, single, spread):
        env.close()


def _worker_processes() -> list[multiprocessing.Process]:
    return [p for p in multiprocessing.active_children() if "HingeProbeVectorEnv" in p.name]


@pytest.mark.parametrize(
    "env_id, workers",
    [(i, 1) for i in ENV_IDS + JOINT_ENV_IDS]
    + [(ENV_IDS[0], 2), (ENV_IDS[2], 2), (JOINT_ENV_IDS[3], 2)],
)
def test_sub_env_i_is_gym_make_with_its_seed_across_autoresets(env_id, workers):
    kwargs = SHORT[_primitive(env_id)]
    seeds = [11, 3, 7]
    envs = _make_vec(env_id, len(seeds), workers=workers, **kwargs)
    singles = [gym.make(env_id, **kwargs) for _ in seeds]
    obs, _ = envs.reset(seed=np.array(seeds) if _primitive(env_id) else seeds)
    expected = [env.reset(seed=s)[0] for env, s in zip(singles, seeds)]
    envs.action_space.seed(0)
    ended = [False] * len(seeds)
    autoresets, lengths = 0, set()
    for _ in range(7):
        for i, want in enumerate(expected):
            assert data_equivalence(_row(obs, i), want, exact=True), i
        actions = envs.action_space.sample()
        obs, rewards, terminated, truncated, info = envs.step(actions)
        expected = []
        for i, env in enumerate(singles):
            if ended[i]:  # NEXT_STEP: this step resets it, as reset() without a seed would
                want, _ = env.reset()
                autoresets += 1
                assert rewards[i] == 0.0 and not (terminated[i] or truncated[i])
                ended[i] = False
            else:
                want, reward, term, trunc, single_info = env.step(actions[i])
                assert (rewards[i], terminated[i], truncated[i]) == (reward, term, trunc)
                assert info["position_error"][i] == single_info["position_error"]
                lengths.add(single_info.get("steps"))
                ended[i] = term or trunc
            expected.append(want)
    assert autoresets >= len(seeds)
    if _primitive(env_id):  # primitives of different lengths ran side by side
        assert len(lengths) > 1, lengths
    envs.close()
    for env in singles:
        env.close()


@pytest.mark.parametrize("env_id", [ENV_IDS[0], ENV_IDS[2], JOINT_ENV_IDS[0], JOINT_ENV_IDS[2]])
def test_the_vector_env_matches_gymnasiums_sync_vector_env(env_id):
    kwargs = SHORT[_primitive(env_id)]
    ours = _make_vec(env_id, 2, **kwargs)
    reference = gym.make_vec(env_id, num_envs=2, vectorization_mode="sync", **kwargs)
    assert ours.metadata["autoreset_mode"] == reference.metadata["autoreset_mode"]
    assert data_equivalence(ours.reset(seed=5), reference.reset(seed=5), exact=True)
    ours.action_space.seed(1)
    for _ in range(6):
        actions = ours.action_space.sample()
        assert data_equivalence(ours.step(actions), reference.step(actions), exact=True)
    ours.close()
    reference.close()


def test_one_sub_envs_termination_leaves_the_others_alone():
    env_id, kwargs = ENV_IDS[0], {"task": {"workspace_radius": 0.12}}
    envs = _make_vec(env_id, 2, **kwargs)
    other = gym.make(env_id, **kwargs)
    envs.reset(seed=[0, 1])
    want, _ = other.reset(seed=1)
    rng = np.random.default_rng(0)
    n = envs.single_action_space.shape[0]
    up = np.zeros(n, np.float32)
    up[2] = 1.0  # sub-env 0 rises out
    ended_at = None
    for step in range(80):
        actions = np.stack([up, rng.uniform(-1, 1, n).astype(np.float32)])
        obs, rewards, terminated, truncated, info = envs.step(actions)
        want, reward, *_ = other.step(actions[1])
        assert data_equivalence(_row(obs, 1), want, exact=True) and rewards[1] == reward
        assert not (terminated[1] or truncated[1])
        if terminated[0]:
            assert info["termination_left_workspace"][0]
            ended_at = step
            break
    assert ended_at is not None, "sub-env 0 never left the workspace"
    # The next step resets sub-env 0 only; sub-env 1 steps on as before.
    obs, rewards, terminated, *_ = envs.step(actions)
    want, reward, *_ = other.step(actions[1])
    assert data_equivalence(_row(obs, 1), want, exact=True) and rewards[1] == reward
    assert rewards[0] == 0.0 and not terminated[0]
    envs.close()
    other.close()


def test_same_step_autoreset_reports_the_final_observation():
    env_id = ENV_IDS[0]
    envs = _make_vec(env_id, 2, max_steps=2, autoreset_mode="SameStep")
    single = gym.make(env_id, max_steps=2)
    assert envs.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    envs.reset(seed=[4, 9])
    single.reset(seed=4)
    actions = np.zeros((2, *envs.single_action_space.shape), np.float32)
    envs.step(actions)
    single.step(actions[0])
    obs, _, _, truncated, info = envs.step(actions)
    final, *_ = single.step(actions[0])
    assert truncated.all() and info["_final_obs"].all()
    assert data_equivalence(info["final_obs"][0], final, exact=True)
    assert data_equivalence(_row(obs, 0), single.reset()[0], exact=True)
    envs.close()
    single.close()


@pytest.mark.parametrize("workers", [1, 2])
def test_a_reset_after_an_end_cancels_the_pending_autoreset(workers):
    envs = _make_vec(ENV_IDS[0], 2, workers=workers, max_steps=2)
    single = gym.make(ENV_IDS[0], max_steps=2)
    actions = np.full((2, *envs.single_action_space.shape), 0.3, np.float32)
    envs.reset(seed=0)
    for _ in range(2):
        *_, truncated, _ = envs.step(actions)
    assert truncated.all()  # both would reset on the next step (NEXT_STEP) ...
    envs.reset(seed=0)  # ... but this reset comes first, so the next step is a step
    single.reset(seed=0)
    obs, rewards, *_ = envs.step(actions)
    want, reward, *_ = single.step(actions[0])
    assert data_equivalence(_row(obs, 0), want, exact=True) and rewards[0] == reward
    envs.close()
    single.close()


def test_disabled_autoreset_and_masked_reset():
    envs = _make_vec(ENV_IDS[0], 2, max_steps=1, autoreset_mode=AutoresetMode.DISABLED)
    first, _ = envs.reset(seed=0)
    actions = np.zeros((2, *envs.single_action_space.shape), np.float32)
    envs.step(actions)
    with pytest.raises(RuntimeError, match="sub-env 0 of 2: the episode has ended"):
        envs.step(actions)
    obs, info = envs.reset(seed=[None, 1], options={"reset_mask": np.array([False, True])})
    assert info["_is_success"].tolist() == [False, True]
    single = gym.make(ENV_IDS[0])
    assert data_equivalence(_row(obs, 1), single.reset(seed=1)[0], exact=True)
    single.close()
    with pytest.raises(ValueError, match="reset_mask"):
        envs.reset(options={"reset_mask": np.array([False, False])})
    envs.close()


def _random_run(envs: VectorEnv, steps: int) -> list:
    """Everything ``steps`` steps of ``envs`` return after a seeded reset, with random
    actions; with autoreset disabled, the ended sub-envs are reset by mask (seeded, so that
    the runs compare). A masked reset of the first sub-env alone after the first step (so
    that its episodes end a step after the others') and of the last one alone at the end:
    each time one worker's block resets nothing."""
    out = [envs.reset(seed=5)]
    rng = np.random.default_rng(0)

    def masked_reset(i: int) -> None:
        mask = np.arange(envs.num_envs) == i
        out.append(envs.reset(seed=[7] * envs.num_envs, options={"reset_mask": mask}))

    def step() -> None:
        actions = rng.uniform(-1, 1, envs.action_space.shape).astype(np.float32)
        out.append(envs.step(actions))
        ended = out[-1][2] | out[-1][3]
        if envs.metadata["autoreset_mode"] is AutoresetMode.DISABLED and ended.any():
            seeds = [100 * len(out) + i if e else None for i, e in enumerate(ended)]
            out.append(envs.reset(seed=seeds, options={"reset_mask": ended}))

    step()
    masked_reset(0)
    for _ in range(steps):
        step()
    masked_reset(envs.num_envs - 1)
    step()
    return out


@pytest.mark.parametrize(
    "env_id, mode",
    [(ENV_IDS[0], mode) for mode in AutoresetMode] + [(ENV_IDS[2], AutoresetMode.SAME_STEP)],
)
def test_workers_give_exactly_what_one_process_gives(env_id, mode):
    kwargs = {**SHORT[_primitive(env_id)], "autoreset_mode": mode}
    one = _make_vec(env_id, 3, **kwargs)
    spread = _make_vec(env_id, 3, workers=2, **kwargs)
    want, got = _random_run(one, 6), _random_run(spread, 6)
    assert len(got) == len(want) >= 10  # a DISABLED run holds its masked resets too
    for k, (a, b) in enumerate(zip(got, want)):
        assert data_equivalence(a, b, exact=True), k
    ended = [step[2] | step[3] for step in want if len(step) == 5]
    assert np.any(ended)  # an autoreset (or a masked reset) was compared
    if mode is AutoresetMode.SAME_STEP:  # some steps end sub-envs of one worker only
        steps = [step for step in got if len(step) == 5]
        finals = [step[4]["_final_obs"] for step in steps if "final_obs" in step[4]]
        assert any(mask[:2].any() != mask[2:].any() for mask in finals), finals
    for envs in (one, spread):
        envs.close()


def test_sub_env_access_and_rendering_across_workers():
    kwargs = {"render_mode": "rgb_array", "max_primitives": 2}
    envs = _make_vec(ENV_IDS[2], 3, workers=2, **kwargs)
    one = _make_vec(ENV_IDS[2], 3, **kwargs)
    envs.reset(seed=4)
    one.reset(seed=4)
    assert envs.get_attr("max_primitives") == (2, 2, 2)
    envs.set_attr("max_primitives", [3, 4, 5])
    assert envs.call("max_primitives") == (3, 4, 5)
    envs.set_attr("probe_note", "x")
    assert envs.get_attr("probe_note") == ("x",) * 3
    assert envs.np_random_seed == one.np_random_seed == (4, 5, 6)
    draws = [g.random() for g in envs.np_random]
    assert draws == [g.random() for g in one.np_random]
    frames = envs.render()
    assert len(frames) == 3
    assert all(np.array_equal(a, b) for a, b in zip(frames, one.render()))
    with pytest.raises(RuntimeError, match="with workers=2 the sub-envs live in worker"):
        _ = envs.envs
    # What cannot cross between processes is a clear error, and the pipes stay in step.
    with pytest.raises(TypeError, match="arguments of set_attr must pickle"):
        envs.set_attr("probe_note", lambda: 0)
    envs.set_attr("probe_note", functools.partial(os.walk, "."))  # calling it: a generator
    with pytest.raises(TypeError, match="apply gave a result that cannot be pickled"):
        envs.call("probe_note")
    assert envs.get_attr("max_primitives") == (3, 4, 5)
    envs.close()
    one.close()


@pytest.mark.parametrize("workers", [0, -1, 1.5, True, "2", 4])
def test_bad_workers_is_a_value_error_naming_it(workers):
    with pytest.raises(ValueError, match=r"workers must be an integer in \[1, 3\]"):
        _make_vec(ENV_IDS[0], 3, workers=workers)


def test_a_workers_errors_name_the_sub_env_and_its_death_is_an_error():
    envs = _make_vec(ENV_IDS[2], 3, workers=2)
    envs.reset(seed=0)
    actions = np.zeros((3, 3), np.float32)
    for index in (0, 2):  # in either worker
        bad = actions.copy()
        bad[index, 1] = np.inf
        with pytest.raises(ValueError, match=f"sub-env {index} of 3: action must be finite") as e:
            envs.step(bad)
        assert e.value.index == index
    envs.step(actions)  # the others went on; the vector env still works
    with pytest.raises(ValueError, match="unexpected keyword argument"):
        _make_vec(ENV_IDS[0], 2, workers=2, max_stepz=3)
    with pytest.raises(ValueError, match="render_mode='human'.*workers=2"):
        _make_vec(ENV_IDS[0], 2, workers=2, render_mode="human")
    (victim,) = [p for p in _worker_processes() if p.name.endswith("worker 1")]
    os.kill(victim.pid, signal.SIGKILL)
    with pytest.raises(RuntimeError, match=r"worker process 1 \(sub-envs 2-2\) died"):
        envs.step(actions)
    assert envs.closed and not _worker_processes()
    envs.close()


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="no CPU affinity here")
def test_workers_are_pinned_only_where_they_take_every_cpu():
    cpus = sorted(os.sched_getaffinity(0))
    n = min(len(cpus), 4)
    if n < 2:
        pytest.skip("pinning needs 2 CPUs or more")
    envs = _make_vec(ENV_IDS[0], n, workers=n)
    workers = sorted(_worker_processes(), key=lambda p: p.name)  # "... worker k", k < 4
    pinned = {os.sched_getaffinity(p.pid) == {cpus[k]} for k, p in enumerate(workers)}
    envs.close()
    assert pinned == {n == len(cpus)}  # pinned one per CPU, or (more CPUs) none pinned


def test_closing_stops_the_workers_and_so_does_garbage_collection():
    envs = _make_vec(ENV_IDS[0], 4, workers=2)
    assert len(_worker_processes()) == 2
    envs.reset(seed=0)
    envs.close()
    envs.close()  # twice is safe
    assert envs.closed and not _worker_processes()
    with pytest.raises(RuntimeError, match="closed"):
        envs.step(np.zeros(envs.action_space.shape, np.float32))
    dropped = _make_vec(ENV_IDS[0], 2, workers=2)
    assert len(_worker_processes()) == 2
    del dropped
    gc.collect()
    assert not _worker_processes()


def test_gymnasiums_vector_wrappers_work_on_it():
    base = _make_vec(ENV_IDS[0], 2, max_steps=2)
    envs = FlattenObservation(RecordEpisodeStatistics(base))
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (2, gym.spaces.flatdim(base.single_observation_space))
    actions = np.zeros((2, *envs.single_action_space.shape), np.float32)
    envs.step(actions)
    *_, truncated, info = envs.step(actions)
    assert truncated.all() and info["episode"]["l"].tolist() == [2, 2]
    envs.close()


@pytest.mark.parametrize("num_envs", [0, -3, 2.0, "4", True, None, MAX_NUM_ENVS + 1, 10**9])
def test_bad_num_envs_is_a_value_error_naming_it(num_envs):
    with pytest.raises(ValueError, match=rf"num_envs must be an integer in \[1, {MAX_NUM_ENVS}\]"):
        _make_vec(ENV_IDS[0], num_envs)


def test_bad_input_and_closing():
    envs = _make_vec(ENV_IDS[2], 2)
    with pytest.raises(ValueError, match="num_envs=2, got 3 seeds"):
        envs.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match="seed must be None, an int or a list"):
        envs.reset(seed="7")
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 3\)"):
        envs.step(np.zeros((3, 3), np.float32))
    actions = np.zeros((2, 3), np.float32)
    actions[1, 2] = np.nan
    with pytest.raises(ValueError, match="sub-env 1 of 2: action must be finite") as error:
        envs.step(actions)
    assert error.value.index == 1
    with pytest.raises(ValueError, match="autoreset_mode must be one of"):
        _make_vec(ENV_IDS[0], 1, autoreset_mode="sometimes")
    with pytest.raises(ValueError, match="unexpected keyword argument"):
        _make_vec(ENV_IDS[0], 1, max_stepz=3)
    with pytest.raises(ValueError, match="render_mode='human'.*num_envs=2"):
        _make_vec(ENV_IDS[0], 2, render_mode="human")
    envs.close()
    envs.close()  # twice is safe
    assert envs.closed
    with pytest.raises(RuntimeError, match="closed"):
        envs.step(actions)


def test_sub_env_access_and_rendering():
    envs = _make_vec(ENV_IDS[2], 2, render_mode="rgb_array")
    envs.reset(seed=0)
    assert envs.get_attr("max_primitives") == (64, 64)
    envs.set_attr("max_primitives", [3, 4])
    assert envs.call("max_primitives") == (3, 4)
    assert [len(m) for m in envs.call("get_wrapper_attr", "measurements")] == [0, 0]
    assert envs.np_random_seed == (0, 1)
    frames = envs.render()
    assert len(frames) == 2 and frames[0].ndim == 3
    envs.close()


# ---------------------------------------------------------------------- the SB3 adapter
def _sb3_reference(env_id: str, n_envs: int, **kwargs):
    """SB3's own in-process VecEnv over ``gym.make``: what the adapter must give."""
    dummy = pytest.importorskip("stable_baselines3.common.vec_env").DummyVecEnv
    return dummy([lambda: gym.make(env_id, **kwargs) for _ in range(n_envs)])


@pytest.mark.parametrize(("env_id", "workers"), [(ENV_IDS[1], 1), (ENV_IDS[3], 2)])
def test_sb3_adapter_matches_dummy_vec_env(env_id, workers):
    # With workers, get_attr, set_attr, env_method and env_is_wrapped reach the sub-envs in
    # their processes (HingeProbeVectorEnv.apply).
    vec_env = pytest.importorskip("agents.vec_env")
    kwargs = SHORT[_primitive(env_id)]
    ours = vec_env.make_sb3_vec_env(env_id, 2, workers, **kwargs)
    reference = _sb3_reference(env_id, 2, **kwargs)
    assert ours.observation_space == reference.observation_space
    assert ours.action_space == reference.action_space
    for env in (ours, reference):
        env.seed(3)
    assert data_equivalence(ours.reset(), dict(reference.reset()), exact=True)
    assert data_equivalence(ours.reset_infos, reference.reset_infos, exact=True)
    rng = np.random.default_rng(0)
    dones = 0
    for _ in range(6):
        actions = rng.uniform(-1, 1, (2, *ours.action_space.shape)).astype(np.float32)
        ours.step_async(actions)
        reference.step_async(actions)
        got, (obs, *want) = ours.step_wait(), reference.step_wait()
        assert data_equivalence(got, (dict(obs), *want), exact=True)  # DummyVecEnv: OrderedDict
        assert data_equivalence(ours.reset_infos, reference.reset_infos, exact=True)
        dones += int(got[2].sum())
    assert dones >= 2  # terminal_observation and TimeLimit.truncated were compared
    assert ours.get_attr("render_mode") == [None, None]
    space = ("get_wrapper_attr", "dict_observation_space")
    assert ours.env_method(*space, indices=[1]) == reference.env_method(*space, indices=[1])
    ours.set_attr("probe_note", "a", indices=0)
    ours.set_attr("probe_note", "b", indices=[1])
    assert ours.get_attr("probe_note") == ["a", "b"]
    # The sub-envs are the ids' envs themselves (the primitive env is no wrapper either).
    assert ours.env_is_wrapped(gym.Wrapper) == [False, False]
    ours.close()
    ours.close()
    reference.close()


def test_sb3_adapter_rejects_the_wrong_autoreset_and_works_with_sb3_wrappers():
    vec_env = pytest.importorskip("agents.vec_env")
    sb3 = pytest.importorskip("stable_baselines3.common.vec_env")
    with pytest.raises(ValueError, match="SAME_STEP"):
        vec_env.HingeProbeSB3VecEnv(_make_vec(ENV_IDS[0], 1))
    env = sb3.VecNormalize(
        sb3.VecMonitor(
            sb3.VecCheckNan(
                vec_env.make_sb3_vec_env(ENV_IDS[0], 2, max_steps=3), raise_exception=True
            )
        )
    )
    env.seed(0)
    env.reset()
    episodes = []
    for _ in range(4):
        obs, rewards, dones, infos = env.step(np.zeros((2, *env.action_space.shape), np.float32))
        episodes += [info["episode"]["l"] for info in infos if "episode" in info]
    assert episodes == [3, 3]  # VecMonitor saw both sub-envs' ends
    env.close()


def test_ppo_learns_on_the_adapter_for_a_few_hundred_steps():
    ppo = pytest.importorskip("stable_baselines3").PPO
    vec_env = pytest.importorskip("agents.vec_env")
    env = vec_env.make_sb3_vec_env(ENV_IDS[0], 2, max_steps=50)
    model = ppo("MultiInputPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0)
    model.learn(total_timesteps=256)
    assert model.num_timesteps == 256
    env.close()
