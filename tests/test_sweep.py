"""Sweeps: config checks, resume, aggregation across seeds, and (slow) a tiny sweep on Ray."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import tactile_gym
from agents import aggregate, cli, evaluate, sweep
from tactile_gym.presets import preset_names

ENV_ID = tactile_gym.ENV_IDS[0]


def test_describe_uses_sample_std_and_skips_missing_values():
    d = aggregate.describe([1.0, 2.0, 6.0, None, float("nan")])
    assert d["n"] == 3
    assert d["mean"] == pytest.approx(3.0)
    assert d["std"] == pytest.approx(math.sqrt(7.0))  # (4 + 1 + 9) / (3 - 1)
    assert 1.0 <= d["ci_low"] < 3.0 < d["ci_high"] <= 6.0


def _fake_run(
    root, algo, seed, position_mm, success, steps_to_5mm, env_id=ENV_ID, spec=None, joint=None
):
    run_dir = root / f"{algo}/{env_id.split('/')[-1]}_s{seed}"
    (run_dir / "evaluation").mkdir(parents=True)
    job = spec or {"env_id": env_id, "algo": algo, "seed": seed}
    (run_dir / "job.json").write_text(json.dumps({"spec": job, **job}))
    summary = {
        "episodes": 4,
        "position_mean_mm": position_mm,
        "success_rate": success,
        "steps_to_5mm_mean": steps_to_5mm,
        **(joint or {}),
    }
    evaluation = {"summaries": {f"{run_dir.name}/final_model": summary}}
    (run_dir / "evaluation" / "evaluation.json").write_text(json.dumps(cli.json_safe(evaluation)))
    eval_dir = run_dir / "eval"
    eval_dir.mkdir()
    results = np.array([[1.0, 3.0], [2.0, 4.0]]) + seed  # two evaluations of two episodes
    np.savez(eval_dir / "evaluations.npz", timesteps=np.array([100, 200]), results=results)
    return run_dir


def test_aggregate_shows_the_joint_ids_type_accuracy(tmp_path):
    env_id = tactile_gym.JOINT_ENV_IDS[2]
    for seed, accuracy in enumerate((0.9, 1.0)):
        joint = {
            "type_accuracy": accuracy,
            "revolute_position_mean_mm": 2.0 + seed,
            "prismatic_angle_mean_deg": 0.5,
        }
        _fake_run(tmp_path, "ppo", seed, 3.0, 0.8, 10.0, env_id=env_id, joint=joint)
    table = aggregate.aggregate(aggregate.load_runs(tmp_path))
    assert table[env_id]["ppo"]["type_accuracy"]["mean"] == pytest.approx(95.0)
    text = aggregate.markdown(table)
    assert "| type accuracy (%) | revolute axis error (mm) | prismatic direction" in text
    assert "| 95.0 +- 7.1 [" in text and "| 2.50 +- 0.71 [" in text


def test_aggregate_table_across_seeds(tmp_path):
    _fake_run(tmp_path, "ppo", 0, 10.0, 0.25, 40.0)
    _fake_run(tmp_path, "ppo", 1, 20.0, 0.75, float("nan"))  # no episode reached 5 mm
    _fake_run(tmp_path, "ppo", 2, 30.0, 0.50, 60.0)
    _fake_run(tmp_path, "sac", 0, 50.0, 0.0, float("nan"))
    (tmp_path / "ppo" / "unfinished").mkdir()  # no job.json: not a run

    runs = aggregate.load_runs(tmp_path)
    assert len(runs) == 4
    table = aggregate.aggregate(runs)
    ppo = table[ENV_ID]["ppo"]
    assert ppo["seeds"] == [0, 1, 2]
    assert ppo["position_mean_mm"]["mean"] == pytest.approx(20.0)
    assert ppo["position_mean_mm"]["std"] == pytest.approx(10.0)
    assert ppo["success_rate"]["mean"] == pytest.approx(50.0)  # in percent
    assert ppo["steps_to_5mm_mean"]["n"] == 2
    assert ppo["steps_to_5mm_mean"]["mean"] == pytest.approx(50.0)
    assert 10.0 <= ppo["position_mean_mm"]["ci_low"] < 20.0 < ppo["position_mean_mm"]["ci_high"]

    text = aggregate.markdown(table)
    assert f"**{ENV_ID}**" in text
    ci = ppo["position_mean_mm"]
    assert f"| ppo | 3 | 20.0 +- 10.0 [{ci['ci_low']:.1f}, {ci['ci_high']:.1f}] |" in text
    assert "50 +- 14 [40, 60] (2 of 3 seeds)" in text
    # One seed: the value alone; no seed reached 5 mm: "-".
    assert "| sac | 1 | 50.0 | 0 | - |" in text

    steps, mean, std = aggregate.learning_curve([r.run_dir for r in runs[:3]])
    np.testing.assert_array_equal(steps, [100, 200])
    np.testing.assert_allclose(mean, [3.0, 4.0])  # seed offsets 0, 1, 2 around 2 and 3
    np.testing.assert_allclose(std, [1.0, 1.0])

    assert "type accuracy" not in text  # the hinge ids have no joint columns

    written = aggregate.write_results(tmp_path)
    assert written == text
    assert json.loads((tmp_path / "results.json").read_text())[ENV_ID]["sac"]["seeds"] == [0]
    assert (tmp_path / f"learning_curve_{ENV_ID.split('/')[-1]}.png").exists()


def test_shipped_sweeps_load():
    assert {"smoke", "baseline"} <= set(preset_names("sweeps"))
    baseline = sweep.load_sweep("baseline")
    assert baseline["env_ids"] == list(tactile_gym.ENV_IDS)
    jobs = sweep.expand(baseline)
    assert len(jobs) == len(tactile_gym.ENV_IDS) * 2 * 5
    assert len({job.key for job in jobs}) == len(jobs)
    smoke = sweep.expand(sweep.load_sweep("smoke"))
    name = smoke[0].env_id.split("/")[-1]
    assert [job.key for job in smoke] == [f"ppo/{name}_s0", f"ppo/{name}_s1"]
    assert smoke[0].n_timesteps == 256
    assert smoke[0].hyperparams["n_steps"] == 64  # the sweep's override over the YAML
    for name in preset_names("sweeps"):  # every shipped sweep expands into distinct jobs
        jobs = sweep.expand(sweep.load_sweep(name))
        assert jobs and len({job.key for job in jobs}) == len(jobs), name


@pytest.mark.parametrize(
    "bad, match",
    [
        ({"algos": ["dqn"]}, "algos"),
        ({"env_ids": ["Pendulum-v1"]}, "env_ids"),
        ({"seeds": [0, 0]}, "seeds"),
        ({"budgets": {"sac": 10}}, "budgets"),
        ({"evaluation": {"model": "last"}}, "evaluation.model"),
        ({"train": {"n_timesteps": 10}}, "train keys"),
        ({"overrides": {"td3": {}}}, "overrides"),
        ({"seed": 0}, "unknown sweep keys"),
        ({"cpus_per_job": 0}, "cpus_per_job"),
    ],
)
def test_sweep_config_errors_name_the_value(bad, match):
    with pytest.raises(ValueError, match=match):
        sweep.load_sweep({"algos": ["ppo"], **bad})


def test_a_sweeps_warm_start_is_checked_before_any_job_and_reaches_the_jobs():
    config = {"env_ids": ["tactile_gym/HingeProbePrimitive-v2"], "algos": ["ppo"], "seeds": 1}
    with pytest.raises(ValueError, match="unknown warm_start keys.*demo"):
        sweep.expand(sweep.load_sweep({**config, "train": {"warm_start": {"demo": 0}}}))
    (job,) = sweep.expand(sweep.load_sweep({**config, "train": {"warm_start": {"demos": 0}}}))
    assert job.train["warm_start"] == {"demos": 0} and job.spec()["train"] == job.train


def test_finished_jobs_are_not_run_again(tmp_path, capsys):
    config = {"name": "resume", "log_folder": str(tmp_path), "env_ids": [ENV_ID],
              "algos": ["ppo"], "seeds": [0, 1], "budgets": 64}  # fmt: skip
    jobs = sweep.expand(sweep.load_sweep(config))
    sweep_dir = tmp_path / "resume"
    report = sweep.run_sweep(config, dry_run=True)
    assert report.skipped == []
    for job in jobs:
        _fake_run(sweep_dir, "ppo", job.seed, 10.0 + job.seed, 0.5, 30.0, spec=job.spec())
    # Everything finished: no job runs (Ray is never started) and the table is rebuilt.
    report = sweep.run_sweep(config, plot=False)
    assert report.skipped == [job.key for job in jobs]
    assert report.done == [] and report.failed == {}
    assert "| ppo | 2 | 10.5 +- 0.7" in report.markdown
    assert (sweep_dir / "results.md").exists()
    assert "10.5 +- 0.7" in capsys.readouterr().out
    # A finished run made with other settings is a conflict, not silently reused.
    with pytest.raises(ValueError, match="other settings"):
        sweep.run_sweep({**config, "budgets": 128}, dry_run=True)


def test_progress_prints_changes(capsys):
    import sys

    progress = sweep.Progress("demo", total=4, finished=1, out=sys.stdout)
    progress.update(running=2, queued=1)
    progress.update(running=2, queued=1)  # unchanged: not printed again
    progress.update(done=2, running=1, queued=0, failed=1)
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2
    assert lines[0].startswith("[sweep demo] 1/4 done, 2 running, 1 queued, 0 failed")
    assert lines[1].startswith("[sweep demo] 2/4 done, 1 running, 0 queued, 1 failed")


@pytest.mark.slow
def test_tiny_sweep_on_embedded_ray(tmp_path, capsys):
    pytest.importorskip("ray")
    config = sweep.load_sweep("smoke")
    config.update(log_folder=str(tmp_path), algos=["ppo", "sac"], budgets={"ppo": 256, "sac": 64})
    # SAC's jobs fail on a policy stable-baselines3 does not know, which only building the
    # model shows: bad input, so reported at once rather than retried.
    config["overrides"]["sac"] = {"policy": "NoSuchPolicy"}
    report = sweep.run_sweep(config, num_cpus=2)
    out = capsys.readouterr().out
    name = config["env_ids"][0].split("/")[-1]
    assert sorted(report.done) == [f"ppo/{name}_s0", f"ppo/{name}_s1"]
    assert sorted(report.failed) == [f"sac/{name}_s0", f"sac/{name}_s1"]
    assert out.count("retrying") == 0
    assert f"FAILED sac/{name}_s0" in out
    log = (report.sweep_dir / f"ppo/{name}_s0/job.log").read_text()
    assert "256/256 env steps (100 %)" in log and "evaluating final_model" in log
    assert (report.sweep_dir / f"sac/{name}_s0/error.txt").exists()
    assert "| ppo | 2 |" in report.markdown and "| sac" not in report.markdown
    assert (report.sweep_dir / f"learning_curve_{name}.png").exists()
    assert "2/4 done, 0 running, 0 queued, 2 failed" in out
    # Resuming: the PPO runs are finished, the SAC ones still to do.
    states = sweep.run_sweep(config, dry_run=True)
    assert sorted(states.skipped) == sorted(report.done)


@pytest.mark.slow
def test_parallel_evaluation_matches_serial(tmp_path):
    pytest.importorskip("ray")
    policies, kwargs = ["random", "scripted"], {"episodes": 4, "seed": 7, "plot": False}
    evaluate.evaluate(policies, out=tmp_path / "serial", **kwargs)
    evaluate.evaluate(policies, out=tmp_path / "ray", workers=3, **kwargs)
    serial = json.loads((tmp_path / "serial" / "evaluation.json").read_text())
    parallel = json.loads((tmp_path / "ray" / "evaluation.json").read_text())
    assert parallel["episodes_detail"] == serial["episodes_detail"]
    assert parallel["summaries"] == serial["summaries"]


def test_only_errors_that_may_pass_are_retried():
    class TaskError(Exception):  # what Ray raises: the job's own error as its cause
        def __init__(self, cause):
            super().__init__(str(cause))
            self.cause = cause

    assert not sweep.worth_retrying(TaskError(ValueError("unknown ppo hyperparameter")))
    assert not sweep.worth_retrying(TaskError(ImportError("ray is not installed")))
    assert sweep.worth_retrying(TaskError(RuntimeError("worker died")))
    assert sweep.worth_retrying(OSError("No space left on device"))


def test_an_interrupted_job_with_a_checkpoint_is_resumed(tmp_path, capsys):
    config = {"name": "cut", "log_folder": str(tmp_path), "env_ids": [ENV_ID],
              "algos": ["ppo"], "seeds": [0, 1, 2], "budgets": 64}  # fmt: skip
    jobs = sweep.expand(sweep.load_sweep(config))
    for job, checkpoint in zip(jobs, (True, False)):  # seed 2: never started
        run_dir = tmp_path / "cut" / job.key
        (run_dir / "checkpoints").mkdir(parents=True)
        (run_dir / "job.json").write_text(json.dumps({"spec": job.spec()}))
        if checkpoint:
            (run_dir / "checkpoints" / "rl_model_32_steps.zip").touch()
    states = [sweep.job_state(job, tmp_path / "cut" / job.key) for job in jobs]
    assert states == ["resume", "todo", "todo"]
    sweep.run_sweep(config, dry_run=True)
    assert "  resume  ppo/" in capsys.readouterr().out
