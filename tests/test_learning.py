"""Learning that goes beyond PPO's memoryless recipe (issue 29): RecurrentPPO cloned through
whole episodes, TQC warm-started, both saved and loaded without unpickling, the action
deadband, and each run's pick among its own checkpoints."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import yaml
from test_security import plant_in_data

import tactile_gym  # noqa: F401 - registers the envs
from agents import cli, runs, selection, sweep, train
from agents.demonstrations import record_demos
from agents.policies import ModelPolicy, deadband
from agents.warmstart import Sequences, WarmStart, action_nll, clone_actions, warm_start

pytest.importorskip("sb3_contrib")
ENV_ID = "tactile_gym/HingeProbePrimitive-v2"
SHORT = {"max_primitives": 6}
TINY = {
    "ppo": {"n_steps": 16, "batch_size": 16, "n_epochs": 1, "policy_kwargs": {"net_arch": [16]}},
    "recurrent_ppo": {
        "n_steps": 16, "batch_size": 16, "n_epochs": 1,
        "policy_kwargs": {"net_arch": [16], "lstm_hidden_size": 8},
    },
    "tqc": {
        "buffer_size": 2000, "learning_starts": 0, "batch_size": 16,
        "policy_kwargs": {"net_arch": [16], "n_quantiles": 5},
    },
}  # fmt: skip


@pytest.fixture(scope="module")
def demos():
    return record_demos(ENV_ID, 3, first_seed=50, env_kwargs=SHORT)


def _model(algo: str, seed: int = 0):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.hyperparams import algorithm_class

    env = VecNormalize(make_vec_env(ENV_ID, n_envs=2, seed=seed, env_kwargs=SHORT))
    policy = "MultiInputLstmPolicy" if algo == "recurrent_ppo" else "MultiInputPolicy"
    return algorithm_class(algo)(policy, env, seed=seed, **TINY[algo])


def _stepwise_means(policy, obs, episode: np.ndarray) -> np.ndarray:
    """The recurrent actor's mean actions, one step at a time with the LSTM state carried
    from a zero state at each episode's start: how the policy acts."""
    import torch

    means = []
    with torch.no_grad():
        for t in range(len(episode)):
            if t == 0 or episode[t] != episode[t - 1]:
                state = tuple(torch.zeros(policy.lstm_hidden_state_shape) for _ in range(2))
            step, _ = policy.obs_to_tensor({k: v[t] for k, v in obs.items()})
            dist, state = policy.get_distribution(step, state, torch.zeros(1))
            means.append(dist.distribution.mean[0].numpy())
    return np.array(means)


def test_a_recurrent_clone_is_fitted_as_it_acts(demos):
    """Cloning through padded episodes computes what stepping through them computes; it
    lowers the per-action loss; ``action_nll`` scores the clone as the loss defines."""
    import torch

    model = _model("recurrent_ppo")
    recipe = WarmStart(demos=1, bc_epochs=30, value_epochs=5, batch_size=8, action_std=0.2)
    before = action_nll(model, demos, 0.2)
    stats = warm_start(model, demos, recipe)
    assert stats["bc_loss"][-1] < stats["bc_loss"][0] and stats["value_loss"][-1] > 0
    after = action_nll(model, demos, 0.2)
    assert after < before
    policy = model.policy
    obs = model.get_vec_normalize_env().normalize_obs(demos.obs)
    means = _stepwise_means(policy, obs, demos.episode)
    expected = -torch.distributions.Normal(torch.as_tensor(means), 0.2).log_prob(
        torch.as_tensor(demos.acts)
    ).sum(-1).mean()  # fmt: skip
    assert after == pytest.approx(float(expected), rel=1e-4, abs=1e-4)
    # Padded batches: each row is one episode, its padding masked out.
    sequences = Sequences.of(policy, obs, demos.episode, actions=demos.acts)
    lengths = np.bincount(demos.episode)
    assert sequences.mask.shape == (3, lengths.max())
    assert sequences.mask.sum(1).tolist() == lengths.tolist()
    assert np.exp(policy.log_std.detach().numpy()) == pytest.approx(0.2)
    assert model.get_vec_normalize_env().training  # freeze_statistics is off by default


def test_a_tqc_warm_start_clones_fits_and_fills_the_buffer(demos):
    import torch

    model = _model("tqc")
    policy = model.policy
    obs = model.get_vec_normalize_env()
    before = action_nll(model, demos, 0.2)
    recipe = WarmStart(demos=1, bc_epochs=40, value_epochs=40, freeze_statistics=True)
    stats = warm_start(model, demos, recipe)
    assert stats["bc_loss"][-1] < stats["bc_loss"][0]
    assert stats["value_loss"][-1] < stats["value_loss"][0]
    for ours, target in zip(policy.critic.parameters(), policy.critic_target.parameters()):
        assert torch.equal(ours, target)
    # The buffer holds the demonstrated transitions as SB3 stores its own (raw, 2 per row).
    buffer, n = model.replay_buffer, len(demos) - len(demos) % 2
    assert buffer.pos == n // 2 and not buffer.full
    flat = buffer.observations["wrench"][: n // 2].reshape(n, -1)
    np.testing.assert_array_equal(flat, demos.obs["wrench"][:n])
    # As SB3 stores a squashed policy's actions: scaled to [-1, 1] (here the identity, up to
    # rounding).
    stored = buffer.actions[: n // 2].reshape(n, -1)
    np.testing.assert_allclose(stored, demos.acts[:n], atol=1e-6)
    ends = np.flatnonzero(buffer.dones[: n // 2].reshape(n))
    last = [int(np.flatnonzero(demos.episode == k)[-1]) for k in range(3)]
    assert ends.tolist() == [i for i in last if i < n]
    following = buffer.next_observations["wrench"][: n // 2].reshape(n, -1)
    np.testing.assert_array_equal(following[last[0]], demos.final_obs["wrench"][0])
    np.testing.assert_array_equal(following[0], demos.obs["wrench"][1])
    assert action_nll(model, demos, 0.2) < before
    assert obs.obs_rms["wrench"].count > len(demos)  # the statistics saw the demonstrations
    assert not obs.training  # and stay as they are (freeze_statistics)


def test_the_demonstrations_anchor_pulls_a_drifted_actor_back_after_each_update(demos):
    """DemoAnchor: after an update, ``anchor_epochs`` passes at PPO's learning rate lower the
    demonstrations' loss of an actor that drifted from its clone; without an update since its
    last pass it does nothing; the log std stays PPO's."""
    import torch
    from stable_baselines3.common.logger import Logger

    from agents.callbacks import DemoAnchor

    model = _model("ppo")
    recipe = WarmStart(demos=1, bc_epochs=30, value_epochs=1, anchor_epochs=3)
    warm_start(model, demos, recipe)
    cloned = action_nll(model, demos, 0.2)
    policy = model.policy
    with torch.no_grad():  # a fine-tuning that drifted: the actor's output layer shaken
        policy.action_net.weight.add_(0.5 * torch.randn_like(policy.action_net.weight))
        policy.log_std.fill_(-1.0)
    drifted = action_nll(model, demos, 0.2)
    assert drifted > cloned + 1.0
    model.set_logger(Logger(folder=None, output_formats=[]))  # what learn() sets up
    anchor = DemoAnchor(demos, recipe, seed=0)
    anchor.init_callback(model)
    anchor.on_rollout_start()  # no update yet: nothing to pull back
    assert anchor.losses == [] and action_nll(model, demos, 0.2) == drifted
    model._n_updates += 1  # as PPO's train() counts one
    for group in policy.optimizer.param_groups:
        group["lr"] = 1e-2
    anchor.on_rollout_start()
    assert len(anchor.losses) == 3
    assert action_nll(model, demos, 0.2) < drifted - 1.0
    assert torch.all(policy.log_std == -1.0)
    anchor.on_rollout_start()  # the same update: no second pass
    assert len(anchor.losses) == 3


def test_the_anchor_is_refused_where_it_has_no_meaning(demos):
    with pytest.raises(ValueError, match="anchor_epochs needs a feed-forward PPO"):
        warm_start(_model("tqc"), demos, WarmStart(demos=1, anchor_epochs=1))
    with pytest.raises(ValueError, match="anchor_epochs must be an integer >= 0"):
        WarmStart(demos=1, anchor_epochs=-1)


def test_a_run_with_the_anchor_pulls_after_its_update(tmp_path, monkeypatch):
    """agents.train wires the anchor from the run's recorded demonstrations: 32 steps in
    rollouts of 16 make one update, after which the anchor makes its one pass."""
    from agents import callbacks

    passes = []

    def counted(*args, **kwargs):
        passes.append(args[3])  # epochs
        return clone_actions(*args, **kwargs)

    monkeypatch.setattr(callbacks, "clone_actions", counted)
    recipe = {"demos": 2, "bc_epochs": 2, "value_epochs": 2, "batch_size": 8, "anchor_epochs": 1}
    run_dir = _train(tmp_path, "ppo", warm_start=recipe)
    assert passes == [1]
    assert yaml.safe_load((run_dir / "config.yml").read_text())["warm_start"]["anchor_epochs"] == 1
    assert (run_dir / "demos.npz").exists() and (run_dir / "final_model.zip").exists()


def _train(tmp_path, algo: str, seed: int = 0, **kwargs):
    return train.train(
        algo, ENV_ID, n_timesteps=32, n_envs=1, seed=seed, log_folder=tmp_path, eval_freq=16,
        eval_episodes=1, checkpoint_freq=16, vec_env="dummy", env_kwargs=SHORT,
        hyperparams=TINY[algo], **kwargs,
    )  # fmt: skip


@pytest.fixture(scope="module")
def recurrent_run(tmp_path_factory):
    return _train(
        tmp_path_factory.mktemp("rppo"), "recurrent_ppo", action_deadband=0.1,
        warm_start={"demos": 2, "bc_epochs": 2, "value_epochs": 2, "batch_size": 8},
    )  # fmt: skip


@pytest.fixture(scope="module")
def tqc_run(tmp_path_factory):
    return _train(tmp_path_factory.mktemp("tqc"), "tqc", warm_start={"demos": 2, "bc_epochs": 2})


@pytest.mark.parametrize("which", ["recurrent_run", "tqc_run"])
def test_the_new_algorithms_load_without_unpickling(which, request, monkeypatch, tmp_path):
    """Their zips' pickled entries are rebuilt (the policy class from the run's config, or
    from the algorithm and the observation space outside a run folder; TQC's entropy target
    from its config); a payload planted in them never runs; a new entry is refused."""
    import shutil

    import cloudpickle

    run = request.getfixturevalue(which)
    env = cli.make_env(ENV_ID, **SHORT)
    lone = tmp_path / "lone.zip"
    shutil.copy(run / "final_model.zip", lone)
    assert runs.saved_algo(lone) == yaml.safe_load((run / "config.yml").read_text())["algo"]

    def refuse(*args, **kwargs):
        raise AssertionError("something was unpickled")

    with monkeypatch.context() as patch:
        for module, name in ((pickle, "load"), (pickle, "loads"), (cloudpickle, "loads")):
            patch.setattr(module, name, refuse)
        for path in (run / "final_model.zip", run / "best_model.zip", lone):
            model = runs.load_model(path, env)
        policy = ModelPolicy(run / "checkpoints" / "rl_model_16_steps.zip", env)
    obs, _ = env.reset(seed=1)
    assert env.action_space.contains(policy.get_action(obs))
    assert type(model).__name__ == {"recurrent_run": "RecurrentPPO", "tqc_run": "TQC"}[which]
    marker = tmp_path / "payload_ran"
    plant_in_data(lone, marker, new_entry=False)
    runs.load_model(lone, env)
    plant_in_data(lone, marker, new_entry=True)
    with pytest.raises(ValueError, match="'extra'"):
        runs.load_model(lone, env)
    assert not marker.exists()
    env.close()


def test_a_recurrent_model_acts_on_its_memory_and_through_its_deadband(recurrent_run):
    """The same observation after different histories gets different actions; a reset
    forgets the history; the run's deadband applies: no component is nonzero below it."""
    env = cli.make_env(ENV_ID, **SHORT)
    policy = ModelPolicy(recurrent_run / "final_model.zip", env)
    assert policy.deadband == 0.1
    obs, _ = env.reset(seed=4)
    policy.deadband = 0.0  # the model's own actions first
    raw = np.array([policy.get_action(obs) for _ in range(20)])
    assert not np.allclose(raw[0], raw[-1])
    policy.reset()
    np.testing.assert_array_equal(policy.get_action(obs), raw[0])
    assert np.any((raw != 0) & (np.abs(raw) < 0.1))
    policy.deadband = 0.1
    policy.reset()
    banded = np.array([policy.get_action(obs) for _ in range(20)])
    np.testing.assert_array_equal(banded, np.where(np.abs(raw) < 0.1, 0.0, raw))
    env.close()


def test_the_deadband():
    action = np.array([0.02, -0.049, 0.05, -0.7, 0.0], dtype=np.float32)
    expected = np.array([0, 0, 0.05, -0.7, 0], dtype=np.float32)
    np.testing.assert_array_equal(deadband(action, 0.05), expected)
    assert deadband(action, 0.05).dtype == np.float32
    with pytest.raises(ValueError, match="action_deadband"):
        train.Trainer(train.TrainArgs("ppo", ENV_ID, action_deadband=1.5))


def test_each_run_picks_among_its_own_models(recurrent_run, tmp_path):
    other = _train(tmp_path / "runs", "recurrent_ppo", seed=1)
    record = selection.select_per_run(
        [recurrent_run, other], episodes=2, test_episodes=2, out=tmp_path / "out"
    )
    assert record["score"] == "position_mean_mm" and record["seeds"] == [200_000, 200_001]
    for run in (recurrent_run, other):
        entry = record["runs"][str(run)]
        candidates = [str(p) for p in selection.run_candidates(run)]
        assert list(entry["scores"]) == candidates
        assert [p.rsplit("/", 1)[-1] for p in candidates][-2:] == [
            "best_model.zip", "final_model.zip"
        ]  # fmt: skip
        assert entry["scores"][entry["selected"]] == min(entry["scores"].values())
    test = record["test"]
    errors = list(test["position_mean_mm"].values())
    assert test["mean_over_runs_mm"] == pytest.approx(np.mean(errors))
    assert test["ratio_to_scripted"] == pytest.approx(np.mean(errors) / test["scripted_mm"])
    differences = list(test["paired_difference_mm"].values())
    assert differences == pytest.approx([e - test["scripted_mm"] for e in errors])
    low, high = test["paired_difference_ci_mm"]
    assert min(differences) <= low <= high <= max(differences)
    with pytest.raises(ValueError, match="holds no model"):
        selection.run_candidates(tmp_path)
    with pytest.raises(ValueError, match="selection range"):
        selection.select_per_run([other], episodes=2, seed=1_000_000)


def test_a_sweep_can_train_without_the_truth():
    base = {"env_ids": [ENV_ID], "seeds": [0], "budgets": 16}
    config = sweep.load_sweep({**base, "train": {"truth_free": True, "action_deadband": 0.05}})
    (job,) = sweep.expand(config)
    assert job.train["truth_free"] is True
    with pytest.raises(ValueError, match="truth_free"):
        sweep.load_sweep({**base, "train": {"truth_free": "yes"}})
    truth = {"task": {"reward_source": "truth"}}
    bad = {**base, "train": {"truth_free": True}, "env_kwargs": truth}
    with pytest.raises(ValueError, match="reward_source"):
        sweep.expand(sweep.load_sweep(bad))
