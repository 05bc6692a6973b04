"""The warm start: behaviour cloning and the critic's pre-fit on demonstrations, the recipe's
config, and a training run that uses it."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

import tactile_gym  # noqa: F401 - registers the envs
from agents.demonstrations import record_demos
from agents.warmstart import WarmStart, load_recipe, normalise_from_demos, warm_start

pytest.importorskip("stable_baselines3")
ENV_ID = "tactile_gym/HingeProbePrimitive-v2"
SHORT = {"max_primitives": 8}


@pytest.fixture(scope="module")
def demos():
    return record_demos(ENV_ID, 3, first_seed=40, env_kwargs=SHORT)


def _model(seed: int = 0, **kwargs):
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    env = VecNormalize(make_vec_env(ENV_ID, n_envs=1, seed=seed, env_kwargs=SHORT))
    return PPO("MultiInputPolicy", env, n_steps=16, batch_size=16, seed=seed,
               policy_kwargs={"net_arch": [32, 32]}, **kwargs)  # fmt: skip


def _action_error(model, demos) -> float:
    obs = model.get_vec_normalize_env().normalize_obs(demos.obs)
    actions, _ = model.predict(obs, deterministic=True)
    return float(np.mean((actions - demos.acts) ** 2))


def test_cloning_lowers_its_loss_and_moves_the_policy_to_the_demonstrations(demos):
    model = _model()
    normalise_from_demos(model.get_vec_normalize_env(), demos)
    before = _action_error(model, demos)
    recipe = WarmStart(demos=3, bc_epochs=40, value_epochs=40, batch_size=16, action_std=0.3)
    stats = warm_start(model, demos, recipe)
    assert stats["samples"] == len(demos) and stats["episodes"] == 3
    assert stats["bc_loss"][1] < stats["bc_loss"][0]
    assert stats["value_loss"][1] < stats["value_loss"][0]
    assert _action_error(model, demos) < 0.5 * before
    assert np.exp(model.policy.log_std.detach().numpy()) == pytest.approx(0.3)
    model.get_env().close()


def test_a_gsde_policy_explores_with_the_recipes_deviation(demos):
    """With gSDE the action noise is the actor's latent times a random matrix, so the clone's
    log_std is scaled by the latent's size: on the demonstrations' observations the actions'
    standard deviation (Monte Carlo over noise matrices) averages action_std."""
    import torch

    model = _model(use_sde=True)
    warm_start(model, demos, WarmStart(demos=3, bc_epochs=5, value_epochs=1, action_std=0.3))
    policy = model.policy
    obs, _ = policy.obs_to_tensor(model.get_vec_normalize_env().normalize_obs(demos.obs))
    with torch.no_grad():
        latent = policy.mlp_extractor.forward_actor(policy.extract_features(obs))
        draws = []
        for _ in range(400):
            policy.reset_noise()
            draws.append(policy.action_dist.get_noise(latent))
    std = torch.stack(draws).std(dim=0)  # (samples, actions)
    assert float(std.pow(2).mean().sqrt()) == pytest.approx(0.3, rel=0.1)
    model.get_env().close()


def test_normalisation_statistics_come_from_the_demonstrations(demos):
    model = _model()
    vec_normalize = model.get_vec_normalize_env()
    normalise_from_demos(vec_normalize, demos)
    for key in vec_normalize.norm_obs_keys:
        np.testing.assert_allclose(
            vec_normalize.obs_rms[key].mean, demos.obs[key].mean(0), rtol=1e-4, atol=1e-6
        )  # the prior count of 1e-4
    assert vec_normalize.ret_rms.count == pytest.approx(len(demos) + 1e-4)
    model.get_env().close()


def test_warm_start_refuses_a_mismatched_model(demos):
    from dataclasses import replace

    model = _model()
    wrong = replace(demos, acts=np.zeros((len(demos), 7), np.float32))
    with pytest.raises(ValueError, match="action space"):
        warm_start(model, wrong, WarmStart(demos=1))
    model.get_env().close()


def test_recipe_is_read_per_id_and_checked(tmp_path):
    config = tmp_path / "ppo.yml"
    table = {"default": {"policy": "MultiInputPolicy"}, "warm_start": {ENV_ID: {"demos": 5}}}
    config.write_text(yaml.safe_dump(table))
    assert load_recipe(config, ENV_ID) == WarmStart(demos=5)
    assert load_recipe(config, ENV_ID, {"bc_epochs": 3}).bc_epochs == 3
    assert not load_recipe(config, "tactile_gym/HingeProbe-v1").enabled
    for bad, field in [({"demos": -1}, "demos"), ({"bc_epochs": 1.5}, "bc_epochs"),
                       ({"action_std": 0}, "action_std"), ({"epochs": 3}, "epochs")]:  # fmt: skip
        with pytest.raises(ValueError, match=field):
            WarmStart.from_mapping(bad)


def test_training_with_a_warm_start_records_it(tmp_path, capsys):
    from agents import train

    run = train.train(
        "ppo", ENV_ID, n_timesteps=32, n_envs=1, log_folder=tmp_path, eval_freq=32,
        eval_episodes=2, checkpoint_freq=0, env_kwargs={"max_primitives": 3},
        hyperparams={"n_steps": 16, "batch_size": 16, "n_epochs": 1},
        warm_start={"demos": 2, "bc_epochs": 2, "value_epochs": 2}, vec_env="dummy",
    )  # fmt: skip
    record = yaml.safe_load((run / "config.yml").read_text())
    assert record["warm_start"]["demos"] == 2
    assert record["seeds"]["demonstrations"] == [100_000, 100_001]
    assert record["seeds"]["selection"] == [200_000, 200_001]
    stats = yaml.safe_load((run / "warm_start.yml").read_text())
    assert stats["episodes"] == 2 and stats["seeds"] == [100_000, 100_001]
    assert (run / "demos.npz").exists()
    # It says what it does while it records, and sums up in words, not as a dict.
    out = capsys.readouterr().out
    assert "recording 2 episodes of the scripted policy" in out
    assert "2/2 demonstrations (100 %)" in out
    assert "policy cloned: 2 epochs, loss" in out and "critic fitted: 2 epochs" in out
    assert "{" not in out
    assert "trained ppo on" in out and f"run saved in {run}" in out
