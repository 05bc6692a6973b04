"""Agents: scripted baseline, training smoke test, evaluation and the paper reproduction."""

from __future__ import annotations

import json
import math
import shutil

import gymnasium as gym
import numpy as np
import pytest
import yaml

import tactile_gym  # noqa: F401 - registers the envs
from agents import cli, episodes, evaluate, hyperparams, paired, policies, resources, runs, train
from tactile_gym.presets import preset_path

TINY = {
    "ppo": {"n_steps": 16, "batch_size": 16, "n_epochs": 1},
    "sac": {"buffer_size": 1000, "learning_starts": 16, "batch_size": 16},
    "recurrent_ppo": {"n_steps": 16, "batch_size": 16, "n_epochs": 1},
    "tqc": {"buffer_size": 1000, "learning_starts": 16, "batch_size": 16},
}


def _tiny_config(tmp_path, algo: str):
    config = tmp_path / f"{algo}.yml"
    hyper = {"policy": "MultiInputPolicy", "n_timesteps": 64, "n_envs": 1, "normalize": True}
    config.write_text(yaml.safe_dump({"default": {**hyper, **TINY[algo]}}))
    return config


@pytest.fixture(scope="module")
def flat_ppo_run(tmp_path_factory):
    """A tiny PPO run on flat observations, with an evaluation (so a best model) and a
    checkpoint, through the command line."""
    pytest.importorskip("stable_baselines3")
    tmp_path = tmp_path_factory.mktemp("flat_ppo")
    return train.main(
        ["--algo", "ppo", "--n-timesteps", "64", "--n-envs", "2", "--log-folder", str(tmp_path),
         "--eval-episodes", "1", "--checkpoint-freq", "32", "--no-progress-bar",
         "--config", str(_tiny_config(tmp_path, "ppo")),
         "--env-kwargs", "observation_mode:flat", "--hyperparams", "policy:MlpPolicy"]
    )  # fmt: skip


def _sac_run(tmp_path, vec_env: str, *more: str):
    pytest.importorskip("stable_baselines3")
    run_dir = train.main(
        ["--algo", "sac", "--n-timesteps", "64", "--n-envs", "2", "--log-folder", str(tmp_path),
         "--eval-freq", "0", "--checkpoint-freq", "0", "--no-progress-bar", "--vec-env",
         vec_env, "--config", str(_tiny_config(tmp_path, "sac")), *more]
    )  # fmt: skip
    record = yaml.safe_load((run_dir / "config.yml").read_text())
    assert record["hyperparameters"]["n_envs"] == 2
    assert record["resources"]["vec_env"] == vec_env
    return run_dir, record


@pytest.mark.slow  # the workers' start-up (each imports torch) takes most of 10 s
def test_training_in_worker_processes(tmp_path):
    # Two envs run in worker processes, which must register the ids themselves.
    run_dir, _ = _sac_run(tmp_path, "subproc")
    assert (run_dir / "final_model.zip").exists()
    run_dir, record = _sac_run(tmp_path, "vector", "--env-workers", "2")
    assert record["resources"]["env_workers"] == 2
    assert (run_dir / "final_model.zip").exists()


def test_env_factory_registers_the_ids_in_a_fresh_process():
    """What the workers of a subprocess vector env rely on, without torch: the factory
    ``agents.train`` hands them makes the env in a process that never imported tactile_gym."""
    import functools
    import multiprocessing

    factory = functools.partial(cli.make_env, cli.DEFAULT_ENV_ID)
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        assert pool.apply(_action_space_shape, (factory,)) == (7,)  # v2: motion and tare


def _action_space_shape(factory) -> tuple:
    env = factory()
    env.close()
    return env.action_space.shape


def test_training_smoke_sac_dict_observations(tmp_path):
    run_dir, record = _sac_run(tmp_path, "dummy")
    assert record["hyperparameters"]["n_timesteps"] == 64
    assert record["command"].startswith("python -m agents.train")
    assert (run_dir / "final_model.zip").exists()
    assert (run_dir / "vecnormalize.json").exists()
    assert not list(run_dir.rglob("*.pkl"))  # nothing pickled beside the models
    summaries = evaluate.evaluate([str(run_dir / "final_model.zip")], episodes=1, plot=False,
                                  out=tmp_path / "eval")  # fmt: skip
    (label,) = summaries
    assert label == f"{run_dir.name}/final_model"
    # Outside its run folder (no config.yml), the model still loads as SAC: the algorithm
    # comes from its zip, not from a default.
    lone = tmp_path / "elsewhere" / "model.zip"
    lone.parent.mkdir()
    shutil.copy(run_dir / "final_model.zip", lone)
    env = gym.make(cli.DEFAULT_ENV_ID, max_steps=5)
    assert type(policies.make_policy(str(lone), env).model).__name__ == "SAC"
    env.close()


def test_training_records_resolved_run(flat_ppo_run):
    record = yaml.safe_load((flat_ppo_run / "config.yml").read_text())
    hyper = record["hyperparameters"]
    assert hyper["env_kwargs"] == {"observation_mode": "flat"}
    assert hyper["policy"] == "MlpPolicy"
    # 2 cores or fewer: a 6-D id's envs share them with the learner, so they run in-process,
    # as the package's vector env.
    assert record["resources"]["vec_env"] == "vector"
    if resources.available_cpus() <= 2:
        assert record["resources"]["env_workers"] == 1
    assert record["resources"]["torch_threads"] == resources.DEFAULT_TORCH_THREADS


def test_short_run_saves_best_model_with_its_statistics(flat_ppo_run):
    # 64 steps is below the default eval_freq (10,000): the run still evaluates once.
    assert (flat_ppo_run / "best_model.zip").exists()
    assert (flat_ppo_run / "eval" / "evaluations.npz").exists()
    best_stats = runs.statistics_path(flat_ppo_run / "best_model.zip")
    assert best_stats == flat_ppo_run / "best_model_vecnormalize.json"
    assert best_stats.exists()
    checkpoint = flat_ppo_run / "checkpoints" / "rl_model_32_steps.zip"
    assert checkpoint.exists()
    assert runs.statistics_path(checkpoint).exists()
    assert not list(flat_ppo_run.rglob("*.pkl"))


def test_model_uses_the_statistics_saved_with_it(flat_ppo_run, tmp_path):
    from stable_baselines3.common.vec_env import DummyVecEnv

    env = cli.make_env(cli.DEFAULT_ENV_ID, observation_mode="flat")
    checkpoint = flat_ppo_run / "checkpoints" / "rl_model_32_steps.zip"
    for model in (flat_ppo_run / "best_model.zip", checkpoint, flat_ppo_run / "final_model.zip"):
        policy = policies.ModelPolicy(model, env)
        saved = runs.read_statistics(runs.statistics_path(model), DummyVecEnv([lambda: env]))
        np.testing.assert_array_equal(policy.normalizer.obs_rms.mean, saved.obs_rms.mean)
        assert policy.normalizer.obs_rms.count == saved.obs_rms.count
    # The checkpoint at 32 steps saw fewer observations than the final model.
    final = policies.ModelPolicy(flat_ppo_run / "final_model.zip", env).normalizer
    early = policies.ModelPolicy(checkpoint, env).normalizer
    assert early.obs_rms.count < final.obs_rms.count
    # Without its own statistics, a normalised model is refused, not scaled with others'.
    copy = tmp_path / "run"
    shutil.copytree(flat_ppo_run, copy)
    (copy / "best_model_vecnormalize.json").unlink()
    with pytest.raises(ValueError, match="best_model_vecnormalize.json"):
        policies.ModelPolicy(copy / "best_model.zip", env)
    env.close()


def test_evaluation_labels_and_env_kwargs_per_run(flat_ppo_run, tmp_path):
    # Two seeds' runs: the same file names, in two run folders.
    other = flat_ppo_run.parent / (flat_ppo_run.name.replace("_s0_", "_s1_"))
    shutil.copytree(flat_ppo_run, other)
    models = [str(flat_ppo_run / "final_model.zip"), str(other / "final_model.zip"),
              str(flat_ppo_run / "best_model.zip"), "random"]  # fmt: skip
    # 60-step episodes: the labels and keywords are the point, not the episodes.
    short = {"max_steps": 60}
    summaries = evaluate.evaluate(models, episodes=1, out=tmp_path, plot=False, env_kwargs=short)
    assert list(summaries) == [
        f"{flat_ppo_run.name}/final_model",
        f"{other.name}/final_model",
        f"{flat_ppo_run.name}/best_model",
        "random",
    ]
    data = json.loads((tmp_path / "evaluation.json").read_text())
    # The models ran on flat observations, as they were trained; random on the default; the
    # keywords given update each run's.
    shown = data["policies"]
    flat = {"observation_mode": "flat", **short}
    assert shown[f"{other.name}/final_model"]["env_kwargs"] == flat
    assert shown["random"]["env_kwargs"] == short
    assert data["env_id"] == cli.DEFAULT_ENV_ID
    with pytest.raises(ValueError, match="listed once"):
        policies.policy_labels([models[0], models[0]])


def test_policy_labels_grow_until_unique(tmp_path):
    for sweep in ("a", "b"):
        run = tmp_path / sweep / "ppo" / "HingeProbe-v1_s0"
        run.mkdir(parents=True)
        (run / "final_model.zip").touch()
    labels = policies.policy_labels(
        [str(tmp_path / s / "ppo" / "HingeProbe-v1_s0" / "final_model.zip") for s in ("a", "b")]
    )
    assert labels == ["a/ppo/HingeProbe-v1_s0/final_model", "b/ppo/HingeProbe-v1_s0/final_model"]


def test_vecnormalize_paths():
    assert runs.statistics_path("r/final_model.zip").as_posix() == "r/vecnormalize.json"
    assert runs.statistics_path("r/best_model.zip").as_posix() == "r/best_model_vecnormalize.json"
    old = runs.statistics_path("r/best_model.zip", ".pkl")
    assert old.as_posix() == "r/best_model_vecnormalize.pkl"
    checkpoint = runs.statistics_path("r/checkpoints/rl_model_500_steps.zip")
    assert checkpoint.as_posix() == "r/checkpoints/rl_model_vecnormalize_500_steps.json"


def test_env_workers_choice():
    primitive, six_d = "tactile_gym/HingeProbePrimitive-v2", "tactile_gym/HingeProbe-v2"
    # A primitive is worth a round trip to a worker: one per env, up to the cores.
    assert resources.choose_env_workers(primitive, n_envs=2, n_cpus=2) == 2
    assert resources.choose_env_workers(primitive, n_envs=8, n_cpus=2) == 2
    assert resources.choose_env_workers(primitive, n_envs=2, n_cpus=1) == 1
    assert resources.choose_env_workers(primitive, n_envs=1, n_cpus=16) == 1
    # A control step is not, unless every env gets a core of its own beside the learner.
    assert resources.choose_env_workers(six_d, n_envs=2, n_cpus=2) == 1
    assert resources.choose_env_workers(six_d, n_envs=1, n_cpus=16) == 1
    assert resources.choose_env_workers(six_d, n_envs=2, n_cpus=3) == 2
    assert resources.choose_env_workers(six_d, n_envs=8, n_cpus=16) == 8
    with pytest.raises(ValueError, match="vec_env"):
        train.train(vec_env="forkserver")
    with pytest.raises(ValueError, match="env_workers"):
        train.train(env_workers=3, n_envs=2)
    with pytest.raises(ValueError, match="env_workers"):
        train.train(vec_env="dummy", env_workers=1)


def test_hyperparameters_resolve_per_env():
    config = hyperparams.load_hyperparameters("ppo", "tactile_gym/HingeProbe3D-v1")
    default = hyperparams.load_hyperparameters("ppo", "tactile_gym/HingeProbe-v1")
    assert config["n_timesteps"] > default["n_timesteps"]
    with pytest.raises(ValueError, match="algo"):
        hyperparams.load_hyperparameters("dqn", "tactile_gym/HingeProbe-v1")


def test_resolve_config_overrides_and_rejects():
    config = hyperparams.resolve_config(
        "ppo", cli.DEFAULT_ENV_ID, hyperparams={"learning_rate": "lin_1e-3"},
        env_kwargs={"observation_mode": "flat"}, n_timesteps=100, n_envs=3,
    )  # fmt: skip
    assert (config["n_timesteps"], config["n_envs"]) == (100, 3)
    assert config["env_kwargs"] == {"observation_mode": "flat"}
    schedule = hyperparams.algo_kwargs(config)["learning_rate"]
    assert schedule(1.0) == pytest.approx(1e-3) and schedule(0.5) == pytest.approx(5e-4)
    with pytest.raises(ValueError, match="frame_stack"):
        hyperparams.resolve_config("ppo", cli.DEFAULT_ENV_ID, hyperparams={"frame_stack": 4})
    with pytest.raises(ValueError, match="normalize"):
        hyperparams.resolve_config("ppo", cli.DEFAULT_ENV_ID, hyperparams={"normalize": "yes"})
    with pytest.raises(ValueError, match="learning_rate"):
        hyperparams.algo_kwargs({"learning_rate": "exp_1e-3"})
    with pytest.raises(ValueError, match="n_envs"):
        hyperparams.resolve_config("ppo", cli.DEFAULT_ENV_ID, n_envs=0)


@pytest.mark.parametrize("env_id", tactile_gym.ENV_IDS)
@pytest.mark.parametrize("algo", hyperparams.ALGOS)
def test_rl_zoo3_reads_our_hyperparameters(algo, env_id, tmp_path):
    """rl_zoo3 reads the env's entry alone: it must be complete and mean what ours means."""
    import argparse
    import inspect

    pytest.importorskip("rl_zoo3")
    from rl_zoo3.exp_manager import ExperimentManager

    path = str(preset_path("train", algo))
    zoo_algo = hyperparams.ZOO_NAMES.get(algo, algo)
    manager = ExperimentManager(argparse.Namespace(), zoo_algo, env_id, str(tmp_path), config=path,
                                verbose=0)  # fmt: skip
    theirs, _ = manager.read_hyperparameters()
    kwargs, *_ = manager._preprocess_hyperparams(dict(theirs))
    ours = hyperparams.load_hyperparameters(algo, env_id)
    assert theirs == ours
    assert manager.n_timesteps == ours["n_timesteps"]
    assert manager.n_envs == ours["n_envs"]
    assert manager.normalize == ours["normalize"]
    assert manager.env_kwargs == ours.get("env_kwargs", {})
    constructor = inspect.signature(hyperparams.algorithm_class(algo)).parameters
    assert set(kwargs) <= set(constructor)
    assert set(hyperparams.algo_kwargs(ours)) | {"policy"} == set(kwargs)


@pytest.mark.slow
@pytest.mark.parametrize("algo", hyperparams.ALGOS)
def test_rl_zoo3_trains_with_our_config(algo, tmp_path):
    import subprocess
    import sys

    pytest.importorskip("rl_zoo3")
    tiny = [f"{k}:{v}" for k, v in TINY[algo].items()]
    zoo_algo = hyperparams.ZOO_NAMES.get(algo, algo)
    command = [sys.executable, "-m", "rl_zoo3.train", "--algo", zoo_algo, "--env",
               cli.DEFAULT_ENV_ID, "--gym-packages", "tactile_gym", "-conf",
               str(preset_path("train", algo)), "-n", "64", "--eval-freq", "-1", "-f",
               str(tmp_path), "-params", *tiny]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    (model,) = (tmp_path / zoo_algo).glob("*/*.zip")
    assert (model.parent / model.stem / "vecnormalize.pkl").exists()
    # agents.evaluate reads rl_zoo3's run layout too, whose files are pickles: only trusted.
    with pytest.raises(ValueError, match="rl_zoo3 run"):
        evaluate.evaluate([str(model)], episodes=1, out=tmp_path / "eval", plot=False)
    summaries = evaluate.evaluate(
        [str(model)], episodes=1, out=tmp_path / "eval", plot=False, trust_pickle=True
    )
    assert summaries[f"{model.parent.name}/{model.stem}"]["episodes"] == 1


def test_model_run_reads_rl_zoo3_layout(tmp_path):
    from collections import OrderedDict

    run_dir = tmp_path / "ppo" / "tactile_gym-HingeProbe-v1_1"
    params = run_dir / "tactile_gym-HingeProbe-v1"
    params.mkdir(parents=True)
    args = OrderedDict(algo="sac", env=cli.DEFAULT_ENV_ID, env_kwargs={"observation_mode": "flat"})
    (params / "args.yml").write_text(yaml.dump(args))  # rl_zoo3 dumps with the Python tag
    (params / "config.yml").write_text(yaml.dump(OrderedDict(normalize=True, n_envs=2)))
    for name in ("tactile_gym-HingeProbe-v1", "best_model", "rl_model_64_steps"):
        (run_dir / f"{name}.zip").touch()
    run = runs.model_run(run_dir / "tactile_gym-HingeProbe-v1.zip")
    assert (run.algo, run.env_id, run.normalize) == ("sac", cli.DEFAULT_ENV_ID, True)
    assert run.env_kwargs == {"observation_mode": "flat"}
    assert run.layout == "rl_zoo3"
    assert run.pickled_statistics == params / "vecnormalize.pkl"
    checkpoint = runs.model_run(run_dir / "rl_model_64_steps.zip").pickled_statistics
    assert checkpoint == run_dir / "rl_model_vecnormalize_64_steps.pkl"
    # rl_zoo3 saves no statistics with its best model: evaluating it is refused, not guessed.
    best = runs.model_run(run_dir / "best_model.zip")
    assert not best.statistics.exists() and not best.pickled_statistics.exists()


def test_evaluation_writes_json(tmp_path):
    summaries = evaluate.main(
        ["--policies", "random", "scripted", "--episodes", "2", "--out", str(tmp_path),
         "--env-kwargs", "max_steps:60"]  # 60 steps take the scripted policy past a press
    )  # fmt: skip
    data = json.loads((tmp_path / "evaluation.json").read_text())
    assert set(data["summaries"]) == {"random", "scripted"}
    assert (tmp_path / "error_vs_step.png").exists()
    for name in ("random", "scripted"):
        assert summaries[name]["episodes"] == 2
        assert len(data["episodes_detail"][name]) == 2


def test_evaluation_json_is_strict(tmp_path):
    # On this seed random actions never come within 5 mm: the mean step to 5 mm is undefined.
    summaries = evaluate.evaluate(["random"], episodes=1, seed=1000, out=tmp_path, plot=False)
    assert np.isnan(summaries["random"]["steps_to_5mm_mean"])

    def reject(constant):
        raise ValueError(f"non-standard JSON constant {constant}")

    data = json.loads((tmp_path / "evaluation.json").read_text(), parse_constant=reject)
    assert data["summaries"]["random"]["steps_to_5mm_mean"] is None
    assert "| - |" in evaluate.markdown_table(summaries)


def test_episode_chunks_match_a_serial_run():
    """Each episode depends on its seed alone, so workers given any chunks of the seeds
    reproduce a serial run exactly (what agents.evaluate --workers relies on)."""
    assert evaluate.chunks([1, 2, 3, 4, 5], 2) == [[1, 2], [3, 4, 5]]
    assert evaluate.chunks([1, 2], 5) == [[1], [2]]
    for name, seeds in (("random", [5, 6, 7]), ("scripted", [5, 6])):
        # 60 steps take the scripted policy through its approach, press and slide.
        spec = policies.PolicySpec(name, name, cli.DEFAULT_ENV_ID, {"max_episode_steps": 60})
        serial = episodes.run_episodes(spec, seeds)
        parts = episodes.run_episodes(spec, seeds[1:]) + episodes.run_episodes(spec, seeds[:1])
        assert [r.seed for r in parts] == seeds[1:] + seeds[:1]
        assert parts[-1:] + parts[:-1] == serial


def test_evaluation_rejects_unknown_policy(tmp_path):
    with pytest.raises(ValueError, match="policy"):
        evaluate.evaluate(["nonexistent_policy"], episodes=1, out=tmp_path)


def test_core_never_imports_ray():
    import subprocess
    import sys

    code = (
        "import sys, gymnasium as gym, tactile_gym\n"
        "import agents.train, agents.evaluate\n"
        "env = gym.make(tactile_gym.ENV_IDS[0]); env.reset(seed=0); env.close()\n"
        "assert 'ray' not in sys.modules, 'ray was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_a_primitive_policy_drives_the_6d_id(tmp_path):
    """A model learned on a primitive id acts on the matching 6-D id through the same skills."""
    pytest.importorskip("stable_baselines3")
    run_dir = train.main(
        ["--algo", "ppo", "--env", "tactile_gym/HingeProbePrimitive-v2", "--n-timesteps", "32",
         "--n-envs", "1", "--log-folder", str(tmp_path), "--eval-freq", "0",
         "--checkpoint-freq", "0", "--no-progress-bar",
         "--config", str(_tiny_config(tmp_path, "ppo")), "--env-kwargs", "max_primitives:64"]
    )  # fmt: skip
    model = str(run_dir / "final_model.zip")
    [spec] = policies.resolve_policies([model], env_id="tactile_gym/HingeProbe-v2")
    assert "max_primitives" not in spec.env_kwargs
    env = gym.make("tactile_gym/HingeProbe-v2", max_steps=60)
    policy = policies.make_policy(model, env)
    assert isinstance(policy, policies.PrimitiveModelPolicy)
    record = episodes.run_episode(env, policy, seed=1000)
    assert len(record.position_error) == 61  # a 6-D action every control step
    env.close()


def test_the_commands_take_the_joint_ids(tmp_path):
    """agents.train and agents.evaluate accept the joint ids (which joint is it): a tiny run,
    then the model, random and the joint baseline evaluated on it."""
    pytest.importorskip("stable_baselines3")
    assert set(tactile_gym.JOINT_ENV_IDS) <= set(cli.KNOWN_ENV_IDS)
    env_id = tactile_gym.JOINT_ENV_IDS[2]  # JointProbePrimitive, the newest
    run_dir = train.main(
        ["--algo", "ppo", "--env", env_id, "--n-timesteps", "32", "--n-envs", "1",
         "--log-folder", str(tmp_path), "--eval-freq", "0", "--checkpoint-freq", "0",
         "--no-progress-bar", "--config", str(_tiny_config(tmp_path, "ppo")),
         "--env-kwargs", "max_primitives:8"]
    )  # fmt: skip
    assert yaml.safe_load((run_dir / "config.yml").read_text())["env_id"] == env_id
    model = str(run_dir / "final_model.zip")
    summaries = evaluate.main(
        ["--env", env_id, "--policies", "random", "scripted", model, "--episodes", "1",
         "--out", str(tmp_path / "evaluation"), "--env-kwargs", "max_primitives:8", "--no-plot"]
    )  # fmt: skip
    assert len(summaries) == 3
    assert all(summary["episodes"] == 1 for summary in summaries.values())
    assert all(0.0 <= summary["type_accuracy"] <= 1.0 for summary in summaries.values())


def _record(joint_type, correct, position, angle):
    return episodes.EpisodeRecord(
        seed=0,
        position_error=[0.1, position],
        angle_error=[1.0, angle],
        success=correct,
        n_measurements=2,
        terminated=False,
        joint_type=joint_type,
        type_correct=correct,
    )


def test_joint_figures_on_hand_made_episodes():
    """Type accuracy over every episode; each type's mean final error over its own episodes
    (revolute position in mm, prismatic direction in degrees); none on the hinge ids."""
    records = [
        _record(1, True, 0.002, 0.5),  # revolute
        _record(1, False, 0.004, 0.5),
        _record(2, True, 0.05, math.radians(1.0)),  # prismatic
        _record(2, True, 0.05, math.radians(3.0)),
        _record(0, False, 0.09, 0.9),  # rigid: no parameter
    ]
    figures = episodes.joint_figures(records)
    assert figures["type_accuracy"] == pytest.approx(3 / 5)
    assert figures["revolute_position_mean_mm"] == pytest.approx(3.0)
    assert figures["prismatic_angle_mean_deg"] == pytest.approx(2.0)
    assert math.isnan(episodes.joint_figures(records[4:])["revolute_position_mean_mm"])
    hinge = [episodes.EpisodeRecord(0, [0.1, 0.002], [1.0, 0.1], True, 3, False)]
    assert episodes.joint_figures(hinge) == {}
    assert "type_accuracy" not in episodes.summarize(hinge)
    table = evaluate.markdown_table({"a": episodes.summarize(records)})
    assert "| a | 60.0% | 3.00 | 2.00 |" in table


def test_an_interrupted_run_resumes_from_its_latest_checkpoint(tmp_path, capsys):
    """What a sweep does with a job whose attempt was cut off: the run continues from its
    checkpoint with its normalisation statistics and its evaluation log, to the full budget."""
    pytest.importorskip("stable_baselines3")

    run_dir = tmp_path / "run"
    common = dict(
        algo="ppo", env_id=cli.DEFAULT_ENV_ID, n_envs=1, eval_episodes=1,
        config_path=_tiny_config(tmp_path, "ppo"), env_kwargs={"max_steps": 40},
        run_dir=run_dir, checkpoint_freq=32, eval_freq=32,
    )  # fmt: skip
    train.train(n_timesteps=64, **common)
    (run_dir / "final_model.zip").unlink()  # as if stopped after the second checkpoint
    assert runs.latest_checkpoint(run_dir).name == "rl_model_64_steps.zip"
    with pytest.raises(ValueError, match="already holds a run"):
        train.train(n_timesteps=96, **common)
    train.train(n_timesteps=96, resume=True, **common)
    assert "resuming from" in capsys.readouterr().out
    record = yaml.safe_load((run_dir / "config.yml").read_text())
    assert record["resumed_from"] == "checkpoints/rl_model_64_steps.zip"
    env = cli.make_env(cli.DEFAULT_ENV_ID)
    assert runs.load_model(run_dir / "final_model.zip", env).num_timesteps == 96
    env.close()
    with np.load(run_dir / "eval" / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == [32, 64, 96]  # the first two kept


def test_a_failed_run_leaves_no_empty_folder(tmp_path):
    pytest.importorskip("stable_baselines3")
    with pytest.raises(ValueError, match="batch_size"):
        train.train(
            n_timesteps=16, n_envs=1, log_folder=tmp_path, hyperparams={"batch_size": "x"},
            config_path=_tiny_config(tmp_path, "ppo"),
        )  # fmt: skip
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ppo.yml"]  # the config alone


@pytest.mark.parametrize("kind", ["dummy", "vector"])
def test_fixed_seed_evaluation_plays_the_same_episodes_every_time(kind):
    """Every reset starts the seed list over and each ended episode is followed by the next
    seed's: the selection episodes are those of gym.make with the same seeds."""
    from stable_baselines3.common.env_util import make_vec_env

    from agents.callbacks import FixedSeedVecEnv
    from agents.vec_env import make_sb3_vec_env

    env_id, kwargs, seeds = "tactile_gym/HingeProbePrimitive-v1", {"max_primitives": 2}, [5, 9, 2]
    if kind == "vector":
        inner = make_sb3_vec_env(env_id, 1, **kwargs)
    else:
        inner = make_vec_env(env_id, n_envs=1, seed=77, env_kwargs=kwargs)
    venv = FixedSeedVecEnv(inner, seeds)
    action = np.array([[-1.0, 0.3, 0.0]], dtype=np.float32)

    def evaluation(episodes: int) -> list[np.ndarray]:
        starts = [venv.reset()["contact"][0]]
        while len(starts) <= episodes:
            obs, _, dones, _ = venv.step(action)
            if dones[0]:
                starts.append(obs["contact"][0])
        return starts[:episodes]

    first = evaluation(3)
    venv.step(action)  # a step between evaluations, as training does
    np.testing.assert_array_equal(np.stack(evaluation(3)), np.stack(first))
    single = gym.make(env_id, **kwargs)
    expected = [single.reset(seed=s)[0]["contact"] for s in seeds]
    np.testing.assert_allclose(np.stack(first), np.stack(expected), rtol=0, atol=1e-6)
    venv.close()
    with pytest.raises(ValueError, match="1 env"):
        FixedSeedVecEnv(make_vec_env(env_id, n_envs=2, env_kwargs=kwargs), seeds)


def test_bootstrap_ci_on_hand_made_numbers():
    # Constant values: the interval collapses onto them.
    assert paired.bootstrap_ci([2.0, 2.0, 2.0]) == (2.0, 2.0)
    # Two values: every resample's mean is 1, 1.5 or 2, with probabilities 1/4, 1/2, 1/4,
    # so the 2.5% and 97.5% quantiles are the extremes.
    assert paired.bootstrap_ci([1.0, 2.0]) == (1.0, 2.0)
    # An 80% interval leaves out the extremes' 25% tails: it is the middle value.
    assert paired.bootstrap_ci([1.0, 2.0], confidence=0.4) == (1.5, 1.5)
    # Many samples: the percentile interval approaches mean +- 1.96 std / sqrt(n).
    values = np.random.default_rng(1).normal(10.0, 2.0, 400)
    low, high = paired.bootstrap_ci(values)
    half = 1.96 * values.std(ddof=1) / math.sqrt(values.size)
    assert low == pytest.approx(values.mean() - half, abs=0.05)
    assert high == pytest.approx(values.mean() + half, abs=0.05)
    # Reproducible, and undefined for one value.
    assert paired.bootstrap_ci(values) == (low, high)
    assert all(math.isnan(x) for x in paired.bootstrap_ci([3.0]))
    with pytest.raises(ValueError, match="confidence"):
        paired.bootstrap_ci([1.0, 2.0], confidence=95)
    # Resampled means of several arrays draw the same episodes from each: a ratio stays paired.
    reference = np.random.default_rng(2).lognormal(0.0, 1.0, 50)
    top, bottom = paired.resampled_means(2.0 * reference, reference, samples=500)
    np.testing.assert_allclose(top, 2.0 * bottom, rtol=1e-12)


def test_paired_bootstrap_interval_covers_the_true_difference():
    from agents.compare import paired_difference

    rng = np.random.default_rng(3)
    true_difference, covered, runs = -0.4, 0, 200
    for k in range(runs):
        reference = rng.lognormal(0.5, 0.8, size=50)  # episode difficulty, shared by both
        values = reference + true_difference + rng.normal(0.0, 0.5, size=50)
        d = paired_difference(values, reference, samples=2000, seed=k)
        covered += d.low <= true_difference <= d.high
        assert d.low <= d.mean <= d.high
    assert 0.9 <= covered / runs <= 0.99
    with pytest.raises(ValueError, match="equal-length"):
        paired_difference([1.0, 2.0], [1.0])
    # One episode gives no interval: flagged NaN, not a point.
    one = paired_difference([1.0], [0.5])
    assert one.mean == 0.5 and np.isnan(one.low) and np.isnan(one.high)


def test_evaluation_prints_the_paired_comparison_with_scripted(tmp_path, capsys):
    evaluate.main(
        ["--env", "tactile_gym/HingeProbePrimitive-v1", "--policies", "random", "scripted",
         "--episodes", "2", "--env-kwargs", "max_primitives:3", "--out", str(tmp_path),
         "--no-plot"]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert "seeds 1000000..1000001" in out
    assert "| random | 2 |" in out and "95 % CI" in out


def test_selection_picks_the_lowest_mean_error_on_selection_episodes(monkeypatch, tmp_path):
    """The ranking alone, with agents.evaluate replaced by fixed scores: the lowest mean final
    position error wins, scripted is played but never chosen, the seeds are the selection
    range's."""
    from agents.seeds import SELECTION_SEED
    from agents.selection import select_model

    scores = {"scripted": 1.0, "a": 2.5, "b": 0.9, "c": 1.7}
    played = {}

    def fake_evaluate(policies, episodes, seed, out, plot, workers, trust_pickle):
        played.update(policies=policies, seeds=(seed, seed + episodes - 1))
        result = {
            "env_id": "tactile_gym/HingeProbePrimitive-v2",
            "policies": {f"label {p}": {"name": p} for p in policies},
            "summaries": {f"label {p}": {"position_mean_mm": scores[p]} for p in policies},
        }
        (tmp_path / "evaluation.json").write_text(json.dumps(result))

    monkeypatch.setattr(evaluate, "evaluate", fake_evaluate)
    record = select_model(["a", "b", "c"], episodes=50, out=tmp_path)
    assert played == {"policies": ["scripted", "a", "b", "c"],
                      "seeds": (SELECTION_SEED, SELECTION_SEED + 49)}  # fmt: skip
    assert record["selected"] == "b"
    assert list(record["scores"]) == ["b", "c", "a"]
    assert record["scripted"] == 1.0
    assert json.loads((tmp_path / "selection.json").read_text()) == record


def test_selection_refuses_test_seeds_and_empty_lists(tmp_path):
    from agents.seeds import SELECTION_SEED, TEST_SEED
    from agents.selection import select_model

    with pytest.raises(ValueError, match="selection range"):
        select_model(["m.zip"], episodes=10, seed=TEST_SEED, out=tmp_path)
    with pytest.raises(ValueError, match="selection range"):
        select_model(["m.zip"], episodes=100_001, seed=SELECTION_SEED, out=tmp_path)
    with pytest.raises(ValueError, match="at least one model"):
        select_model([], out=tmp_path)
    with pytest.raises(ValueError, match="reference"):
        select_model(["scripted"], out=tmp_path)


def test_selected_model_is_copied_ready_to_test(flat_ppo_run, tmp_path):
    """The copy holds the model, its statistics, its run config and the scores, and plays
    exactly what the original scored."""
    from agents.selection import select_model

    models = [flat_ppo_run / "best_model.zip", flat_ppo_run / "final_model.zip"]
    record = select_model(
        models, episodes=2, out=tmp_path / "sel", copy_to=tmp_path / "models"
    )  # fmt: skip
    assert set(record["scores"]) == {str(m) for m in models}
    copied = tmp_path / "models" / ("ppo_" + flat_ppo_run.name)
    assert record["copied_to"] == str(copied)
    chosen = copied / (record["selected"].rsplit("/", 1)[1])
    assert runs.statistics_path(chosen).exists() and (copied / "config.yml").exists()
    assert json.loads((copied / "selection.json").read_text()) == record
    spec = policies.resolve_policies([str(chosen)])[0]
    played = episodes.run_episodes(spec, [record["seeds"][0], record["seeds"][1]])
    replayed = episodes.summarize(played)["position_mean_mm"]
    assert replayed == pytest.approx(record["scores"][record["selected"]], rel=0, abs=1e-12)
