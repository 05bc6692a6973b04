"""Agents: scripted baseline, training smoke test, evaluation and the paper reproduction."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import yaml

import tactile_gym  # noqa: F401 - registers the envs
from agents import evaluate, reproduce_paper, train
from agents.scripted import ScriptedProbePolicy
from tactile_gym.presets import preset_path


def _run_scripted(seed: int) -> dict:
    env = gym.make("tactile_gym/HingeProbe-v0")
    policy = ScriptedProbePolicy.for_env(env.unwrapped)
    obs, info = env.reset(seed=seed)
    policy.reset()
    done = False
    while not done:
        action = policy.get_action(obs)
        assert env.action_space.contains(action)
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
    env.close()
    return info


def test_scripted_policy_measures_and_turns_the_link():
    info = _run_scripted(seed=0)
    assert info["n_measurements"] >= 4
    # The error fell from the cap (100 mm, no estimate) to a few centimetres or less.
    assert info["position_error"] < 0.05
    # The pushes turned the link by more than the 30 deg of one stop.
    assert abs(info["joint_angle"]) > np.deg2rad(30.0)


def test_scripted_policy_beats_random(tmp_path):
    summaries = evaluate.evaluate(["scripted", "random"], episodes=10, out=tmp_path, plot=False)
    scripted, random = summaries["scripted"], summaries["random"]
    # A regression guard on what the baseline achieves (README evaluation table: a median
    # final error near 14 mm, 45% of episodes within 5 mm at some step). Random actions
    # never form an estimate (100 mm is the cap).
    assert scripted["position_median_mm"] < 25.0
    assert scripted["reached_5mm_rate"] >= 0.2
    assert random["position_median_mm"] > 2 * scripted["position_median_mm"]


def test_scripted_policy_never_reads_the_truth():
    env = gym.make("tactile_gym/HingeProbe-v0")
    policy = ScriptedProbePolicy.for_env(env.unwrapped)
    obs, _ = env.reset(seed=3)
    action = policy.get_action(obs)
    env.close()
    # Same observation, different (hidden) world: the same action.
    policy.reset()
    np.testing.assert_array_equal(policy.get_action(obs), action)


TINY = {
    "ppo": {"n_steps": 16, "batch_size": 32, "n_epochs": 1},
    "sac": {"buffer_size": 1000, "learning_starts": 16, "batch_size": 16},
}


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_training_smoke(tmp_path, algo):
    pytest.importorskip("stable_baselines3")
    config = tmp_path / f"{algo}.yml"
    hyper = {"policy": "MultiInputPolicy", "n_timesteps": 64, "n_envs": 1, "normalize": True}
    config.write_text(yaml.safe_dump({"default": {**hyper, **TINY[algo]}}))
    run_dir = train.main(
        ["--algo", algo, "--n-timesteps", "64", "--n-envs", "2", "--log-folder", str(tmp_path),
         "--eval-freq", "0", "--checkpoint-freq", "0", "--no-progress-bar", "--config",
         str(config)]
    )  # fmt: skip
    record = yaml.safe_load((run_dir / "config.yml").read_text())
    # Two envs run in worker processes, which must register the ids themselves.
    assert record["hyperparameters"]["n_envs"] == 2
    assert record["hyperparameters"]["n_timesteps"] == 64
    assert record["command"].startswith("python -m agents.train")
    assert (run_dir / "final_model.zip").exists()
    assert (run_dir / "vecnormalize.pkl").exists()
    model = str(run_dir / "final_model.zip")
    summaries = evaluate.evaluate([model], episodes=1, out=tmp_path / "eval", plot=False)
    assert summaries[f"{algo} final_model"]["episodes"] == 1


def test_hyperparameters_resolve_per_env():
    config = train.load_hyperparameters("ppo", "tactile_gym/HingeProbe3D-v0")
    default = train.load_hyperparameters("ppo", "tactile_gym/HingeProbe-v0")
    assert config["n_timesteps"] > default["n_timesteps"]
    with pytest.raises(ValueError, match="algo"):
        train.load_hyperparameters("dqn", "tactile_gym/HingeProbe-v0")


def test_evaluation_writes_json(tmp_path):
    summaries = evaluate.main(
        ["--policies", "random", "scripted", "--episodes", "2", "--out", str(tmp_path)]
    )
    data = json.loads((tmp_path / "evaluation.json").read_text())
    assert set(data["summaries"]) == {"random", "scripted"}
    assert (tmp_path / "error_vs_step.png").exists()
    for name in ("random", "scripted"):
        assert summaries[name]["episodes"] == 2
        assert len(data["episodes_detail"][name]) == 2


def test_evaluation_rejects_unknown_policy(tmp_path):
    with pytest.raises(ValueError, match="policy"):
        evaluate.evaluate(["nonexistent_policy"], episodes=1, out=tmp_path)


def test_paper_reproduction_reduced(tmp_path):
    results = reproduce_paper.main(["--trials", "2", "--out", str(tmp_path)])
    assert (tmp_path / "table1.json").exists()
    assert (tmp_path / "fig_slides.png").exists()
    sliding = results[("paper", "slides")]
    # The paper's finding in miniature: sliding contacts break the simple method.
    assert np.median(sliding["simple_mm"]) > 2 * np.median(sliding["proposed_mm"])


def test_env_presets_match_registered_defaults():
    from tactile_gym.envs.hinge_probe_v0 import HingeProbeConfig

    for name, env_id in (
        ("hinge_probe", tactile_gym.ENV_IDS[0]),
        ("hinge_probe_3d", tactile_gym.ENV_IDS[1]),
    ):
        with open(preset_path("env", name)) as f:
            preset = yaml.safe_load(f)
        config = HingeProbeConfig(**preset)
        registered = HingeProbeConfig(**gym.spec(env_id).kwargs)
        for field in ("families", "estimator_mode", "force_limit", "max_translation"):
            assert getattr(config, field) == getattr(registered, field)
        env = gym.make(env_id, **preset)
        env.reset(seed=0)
        env.close()
