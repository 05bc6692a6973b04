"""The command lines as a newcomer meets them: each mistake is one line on stderr naming the
offending value, with exit status 2 and no traceback; help that explains every option; quiet
output. Most run a command's ``main`` through :func:`agents.cli.run_main`, as
``python -m agents.<name>`` does; a few run the module itself."""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import yaml

import tactile_gym
from agents import (
    aggregate,
    cli,
    convert_models,
    evaluate,
    policies,
    reproduce_paper,
    runs,
    selection,
    sweep,
    train,
)

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "models" / "ppo_HingeProbePrimitive-v1_s2" / "best_model.zip"
PRIMITIVE, PRIMITIVE_3D = (
    "tactile_gym/HingeProbePrimitive-v1",
    "tactile_gym/HingeProbe3DPrimitive-v1",
)


def _usage_error(capsys, main, argv: list[str], *expected: str) -> str:
    """Run ``main`` as its command does; check exit status 2, one message on stderr (a list
    of what is allowed may follow on further lines), no traceback, and that the message holds
    each ``expected`` text. Returns the message."""
    status = cli.run_main(main, argv)
    err = capsys.readouterr().err
    assert status == cli.USAGE_ERROR, err
    assert "Traceback" not in err
    assert err.startswith(f"python -m {main.__module__}: error: "), err
    assert err.count(": error: ") == 1, err
    for text in expected:
        assert text in err, err
    return err


# ---------------------------------------------------------------- errors (issue 19, item 2)
def test_a_hyperparameter_typo_is_caught_by_train_before_anything_runs(capsys, tmp_path):
    _usage_error(
        capsys,
        train.main,
        ["--hyperparams", "n_step:64", "--log-folder", str(tmp_path)],
        "'n_step'",
        "'n_steps'",
    )
    assert list(tmp_path.iterdir()) == []


def test_a_hyperparameter_typo_is_caught_by_the_sweeps_dry_run(capsys, tmp_path):
    path = tmp_path / "typo.yml"
    path.write_text(yaml.safe_dump({"env_ids": [PRIMITIVE], "overrides": {"ppo": {"n_step": 64}}}))
    _usage_error(capsys, sweep.main, [str(path), "--dry-run"], "'n_step'", "did you mean")


def test_a_bad_schedule_is_caught_by_the_sweeps_dry_run(capsys, tmp_path):
    path = tmp_path / "schedule.yml"
    overrides = {"sac": {"learning_rate": "exp_1e-3"}}
    path.write_text(
        yaml.safe_dump({"env_ids": [PRIMITIVE], "algos": ["sac"], "overrides": overrides})
    )
    _usage_error(capsys, sweep.main, [str(path), "--dry-run"], "learning_rate", "'exp_1e-3'")


def test_keys_that_train_sets_itself_are_refused(capsys):
    _usage_error(capsys, train.main, ["--hyperparams", "seed:3"], "'seed'", "--seed")


@pytest.mark.parametrize(
    "main, argv, expected",
    [
        (train.main, ["--env", "HingeProbe-v9"], ["'HingeProbe-v9'", tactile_gym.ENV_IDS[0]]),
        (train.main, ["--config", "nosuch"], ["'nosuch'", "ppo"]),
        (train.main, ["--config", "missing.yml"], ["missing.yml"]),
        (evaluate.main, ["--policies", "nosuch.zip"], ["'nosuch.zip'", "random", "scripted"]),
        (evaluate.main, ["--env", "Foo-v1", "--policies", "random"], ["'Foo-v1'"]),
        (evaluate.main, ["--policies", "random", "--episodes", "0"], ["episodes", "0"]),
        (sweep.main, ["nosuch", "--dry-run"], ["'nosuch'", "smoke"]),
        (aggregate.main, ["no/such/sweep"], ["'no/such/sweep'"]),
        (reproduce_paper.main, ["--variants", "mu_0.4"], ["--variants", "'mu_0.4'", "mu_0.3"]),
        (reproduce_paper.main, ["--schemes", "paper,narrow"], ["--schemes", "'paper,narrow'"]),
        (reproduce_paper.main, ["--trials", "0"], ["--trials 0"]),
    ],
)
def test_unknown_ids_files_and_values(capsys, main, argv, expected):
    _usage_error(capsys, main, argv, *expected)


def test_bad_config_files_and_keys(capsys, tmp_path):
    broken = tmp_path / "broken.yml"
    broken.write_text("default: [unclosed\n")
    _usage_error(capsys, train.main, ["--config", str(broken)], "broken.yml, line 2", "YAML")
    unknown = tmp_path / "unknown_key.yml"
    unknown.write_text(yaml.safe_dump({"env_ids": [PRIMITIVE], "seed": 3}))
    _usage_error(capsys, sweep.main, [str(unknown), "--dry-run"], "['seed']", "seeds")


def test_a_bad_env_keyword_is_caught_before_a_run_folder_exists(capsys, tmp_path):
    argv = ["--env-kwargs", "max_stepz:10", "--log-folder", str(tmp_path), "--n-timesteps", "8"]
    _usage_error(capsys, train.main, argv, "max_stepz")
    assert list(tmp_path.iterdir()) == []


def test_a_value_the_algorithm_rejects_leaves_no_run_folder(capsys, tmp_path):
    argv = ["--hyperparams", "batch_size:abc", "--log-folder", str(tmp_path), "--n-envs", "1"]
    _usage_error(capsys, train.main, argv, "'abc'", "batch_size")
    assert list(tmp_path.iterdir()) == []


def test_debug_shows_the_traceback():
    with pytest.raises(ValueError, match="n_step"):
        cli.run_main(train.main, ["--hyperparams", "n_step:64", "--debug"])


def test_a_missing_ray_names_both_installs(capsys, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # what "not installed" looks like to import
    message = _usage_error(capsys, sweep.main, ["smoke", "--log-folder", str(tmp_path)], "ray")
    assert 'pip install -e ".[train,sweep]"' in message  # a checkout
    assert 'pip install "tactile-gym[train,sweep]"' in message  # the wheel


def test_a_missing_yaml_space_after_a_colon_is_named(capsys):
    """``skin:{friction:0.3}`` is YAML for the key "friction:0.3" with no value: the error says
    what was meant, not "unknown skin field"."""
    with pytest.raises(SystemExit) as exit_info:
        train.main(["--env-kwargs", "skin:{friction:0.3}"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "'friction:0.3' as one key with no value" in err
    assert "YAML needs a space after a colon, as in 'skin:{friction: 0.3}'" in err
    parser = argparse.ArgumentParser()
    parser.add_argument("--env-kwargs", nargs="+", action=cli.KeyValue)
    args = parser.parse_args(["--env-kwargs", "skin:{friction: 0.3}", "max_steps:10"])
    assert args.env_kwargs == {"skin": {"friction": 0.3}, "max_steps": 10}


def test_key_value_arguments_explain_a_bad_pair(capsys):
    with pytest.raises(SystemExit) as exit_info:
        train.main(["--env-kwargs", "max_steps=10"])
    assert exit_info.value.code == 2
    assert "expected key:value, got 'max_steps=10'" in capsys.readouterr().err


# ------------------------------------------------------- model and env (issue 19, item 3)
def test_a_model_on_another_id_is_refused_naming_both(capsys, tmp_path):
    argv = ["--policies", str(MODEL), "--env", PRIMITIVE_3D, "--out", str(tmp_path)]
    _usage_error(capsys, evaluate.main, argv, PRIMITIVE, PRIMITIVE_3D, "--force")
    # --force lets it through (with a warning), and its own id and 6-D id need no force.
    specs = policies.resolve_policies([str(MODEL)], PRIMITIVE_3D, force=True)
    assert specs[0].env_id == PRIMITIVE_3D
    assert "trained on" in capsys.readouterr().err
    for env_id in (PRIMITIVE, "tactile_gym/HingeProbe-v1"):
        policies.resolve_policies([str(MODEL)], env_id)


def test_a_model_outside_its_run_folder_is_checked_by_its_spaces(capsys, tmp_path):
    lone = tmp_path / "model.zip"
    shutil.copy(MODEL, lone)
    argv = ["--policies", str(lone), "--env", "tactile_gym/HingeProbe3D-v1", "--out", str(tmp_path)]
    _usage_error(capsys, evaluate.main, argv, str(lone), "observation space", "primitive")


def test_the_algorithm_comes_from_the_models_zip(tmp_path):
    assert runs.saved_algo(MODEL) == "ppo"

    def model_zip(name: str, module: str):
        with zipfile.ZipFile(tmp_path / name, "w") as archive:
            archive.writestr("data", json.dumps({"policy_class": {"__module__": module}}))
            archive.writestr("policy.pth", b"")
        return tmp_path / name

    sac = model_zip("sac.zip", "stable_baselines3.sac.policies")
    assert runs.saved_algo(sac) == "sac"
    assert runs.model_run(sac).algo == "sac"  # no run config beside it
    assert runs.saved_algo(model_zip("td3.zip", "stable_baselines3.td3.policies")) == "td3"
    assert runs.saved_algo(model_zip("tqc.zip", "sb3_contrib.tqc.policies")) == "tqc"
    recurrent = model_zip("lstm.zip", "sb3_contrib.common.recurrent.policies")
    assert runs.saved_algo(recurrent) == "recurrent_ppo"
    with pytest.raises(ValueError, match="ppo, sac, recurrent_ppo, tqc"):
        runs.saved_algo(model_zip("other.zip", "sb3.dqn"))
    (tmp_path / "junk.zip").write_text("not a zip")
    with pytest.raises(ValueError, match="damaged or not a zip"):
        runs.saved_algo(tmp_path / "junk.zip")


# --------------------------------------------------------------- help (issue 19, item 5)
@pytest.mark.parametrize("module", [train, evaluate, sweep, aggregate, selection, convert_models])
def test_every_option_has_help_and_the_usage_names_the_module(module, monkeypatch, capsys):
    parsers = []

    def recording(*args, **kwargs):
        parsers.append(cli.make_parser(*args, **kwargs))
        return parsers[-1]

    monkeypatch.setattr(module, "make_parser", recording)
    with pytest.raises(SystemExit):
        module.main(["--help"])
    out = capsys.readouterr().out
    name = module.__name__
    assert out.startswith(f"usage: python -m {name}")
    (parser,) = parsers
    for action in parser._actions:
        assert action.help, f"{name}: {action.option_strings or action.dest} has no help"
        shows_default = action.default in (None, False, {}, argparse.SUPPRESS)
        shows_default = shows_default or "default" in action.help
        assert shows_default or "%(default)" in cli.HelpFormatter("x")._get_help_string(action)
    if module in (train, evaluate):
        assert "key:value" in out.lower() and "YAML" in out
    if module is evaluate:
        for policy in ("random", "scripted", "best_model.zip"):
            assert policy in out


# --------------------------------------------------------- output (issue 19, items 5, 9)
def test_a_closed_pipe_ends_quietly():
    """``--dry-run | head``: the reader goes away; no BrokenPipeError traceback."""
    process = subprocess.Popen(
        [sys.executable, "-m", "agents.sweep", "smoke", "--dry-run"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    process.stdout.close()  # before the first line: every write fails
    _, err = process.communicate(timeout=120)
    assert b"Traceback" not in err and b"BrokenPipe" not in err, err.decode()
    assert process.returncode == 0


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["agents.evaluate", "--policies", "random", "--episodes", "1", "--env-kwargs",
          "max_steps:3", "--no-plot"], "| random | 1 |"),
        # Two worker processes step the envs: their forkserver imports the simulator too.
        (["agents.train", "--env", PRIMITIVE.replace("v1", "v2"), "--n-envs", "2",
          "--env-workers", "2", "--n-timesteps", "16", "--eval-freq", "0",
          "--checkpoint-freq", "0", "--warm-start", "demos:0", "--no-progress-bar",
          "--hyperparams", "n_steps:8", "batch_size:8", "n_epochs:1",
          "--env-kwargs", "max_primitives:2"], "run saved in"),
    ],
    ids=["evaluate", "train-with-workers"],
)  # fmt: skip
def test_pybullets_start_up_lines_are_kept_out(tmp_path, argv, expected):
    where = (
        ["--out", str(tmp_path)]
        if argv[0] == "agents.evaluate"
        else ["--log-folder", str(tmp_path)]
    )
    command = [sys.executable, "-m", *argv, *where]
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    output = result.stdout + result.stderr
    assert "pybullet build time" not in output and "argv[0]=" not in output, output
    assert expected in result.stdout


def test_progress_lines_report_the_end_once(capsys):
    """SB3 runs its last rollout past the total; the log says so once, not every step."""
    from agents.progress import progress_lines

    callback = progress_lines(total_steps=10, interval=1e9)
    callback._on_training_start()
    for done in (2, 8, 10, 12, 14):
        callback.num_timesteps = done
        callback._on_step()
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 and lines[0].startswith("10/10 env steps (100 %)")
