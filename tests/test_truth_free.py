"""Training without the truth (issue 29, item 3): nothing in a truth-free training loop reads
the truth.

The scene's truth accessors (those ``tests/test_ground_truth.py`` audits) are made to report a
different, wrong truth to every reader outside the scene: another hinge, another edge, another
joint angle and object, a scaled noise-free wrench; ``contact`` and ``object``, objects with no
simple wrong twin, refuse to be read at all. The physics is untouched: the scene's own methods
(the sensor model, the stepping) still see their state. A tiny warm-started run with
periodic selection and checkpoints, then its per-run pick, is made twice with the same seeds,
once as is and once under the wrong truth: truth-free, the weights, the selections and the
logged returns must be identical. The same pair trained on the truth must differ, so the
check can fail.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch
import yaml
from test_ground_truth import SCENE_FILE, TRUTH, _relative

import tactile_gym  # noqa: F401 - registers the envs
from agents import selection, train
from agents.callbacks import TRUTH_INFO
from agents.hyperparams import TRUTH_FREE_TASK, truth_free_env_kwargs
from tactile_gym.sim import ProbeScene

pytest.importorskip("stable_baselines3")
ENV_ID = "tactile_gym/HingeProbePrimitive-v2"
TURN = np.array([[np.cos(0.3), -np.sin(0.3), 0.0], [np.sin(0.3), np.cos(0.3), 0.0], [0, 0, 1.0]])
OFFSET = np.array([0.03, -0.02, 0.01])  # m


def _wrong(name: str, value):
    """A wrong version of the truth ``name`` (module docstring)."""
    if name in ("true_axis", "edge_line"):
        point, direction = value
        return point + OFFSET, TURN @ direction
    if name == "joint_angle":
        return value + 0.4
    if name == "true_wrench":
        return 2.0 * value + 1.0
    if name == "contact_centroid":
        return None if value is None else value + OFFSET
    if name == "object_config":
        moved = tuple(np.add(value.joint_position, OFFSET))
        return dataclasses.replace(value, joint_position=moved)
    raise AssertionError(f"the truth {name!r} was read")


@pytest.fixture
def wrong_truth(monkeypatch):
    """Make every truth accessor report a wrong truth outside the scene (module docstring)."""

    def wrap(name: str, prop: property) -> property:
        def getter(self):
            import sys

            value = prop.fget(self)
            if _relative(sys._getframe(1).f_code.co_filename) == SCENE_FILE:
                return value
            return _wrong(name, value)

        return property(getter)

    for name in TRUTH:
        monkeypatch.setattr(ProbeScene, name, wrap(name, getattr(ProbeScene, name)))


def _run(tmp_path, truth_free: bool) -> dict:
    """A tiny warm-started run with periodic selection and checkpoints, and its per-run pick
    on two selection episodes; what must not depend on the truth."""
    run = train.train(
        "ppo", ENV_ID, n_timesteps=32, n_envs=1, seed=3, log_folder=tmp_path, eval_freq=16,
        eval_episodes=2, checkpoint_freq=16, vec_env="dummy",
        env_kwargs={"max_primitives": 3, "task": {"prior_error": 0.01}},
        hyperparams={"n_steps": 16, "batch_size": 16, "n_epochs": 1},
        warm_start={"demos": 2, "bc_epochs": 2, "value_epochs": 2}, truth_free=truth_free,
    )  # fmt: skip
    pick = selection.select_per_run([run], episodes=2, test_episodes=0, out=tmp_path / "pick")
    with np.load(run / "eval" / "evaluations.npz") as log:
        returns = {k: log[k].tolist() for k in ("timesteps", "results")}
        logged = sorted(log.files)
    from stable_baselines3 import PPO

    weights = {
        name: PPO.load(run / name, device="cpu").policy.state_dict()
        for name in ("final_model.zip", "best_model.zip", "checkpoints/rl_model_16_steps.zip")
    }
    (selected,) = [r["selected"] for r in pick["runs"].values()]
    return {
        "run": run,
        "weights": weights,
        "returns": returns,
        "logged": logged,
        "scores": sorted(next(iter(pick["runs"].values()))["scores"].values()),
        "selected": selected.removeprefix(str(run)),
        "score": pick["score"],
        "warm_start": yaml.safe_load((run / "warm_start.yml").read_text())["bc_loss"],
    }


def _same_weights(a: dict, b: dict) -> bool:
    return all(
        a[model].keys() == b[model].keys()
        and all(torch.equal(a[model][k], b[model][k]) for k in a[model])
        for model in a
    )


@pytest.fixture(scope="module")
def truth_free_as_is(tmp_path_factory):
    """The truth-free run with the true truth (module scope: made before ``wrong_truth``)."""
    return _run(tmp_path_factory.mktemp("as_is"), truth_free=True)


@pytest.fixture(scope="module")
def truth_trained_as_is(tmp_path_factory):
    """The same run trained on the truth, with the true truth."""
    return _run(tmp_path_factory.mktemp("truth_as_is"), truth_free=False)


def test_a_truth_free_run_reads_no_truth(truth_free_as_is, wrong_truth, tmp_path):
    wrong = _run(tmp_path, truth_free=True)
    assert _same_weights(truth_free_as_is["weights"], wrong["weights"])
    for key in ("returns", "scores", "selected", "warm_start"):
        assert truth_free_as_is[key] == wrong[key], key
    # It ranks by the truth-free return, and its logs hold no success rate (the truth).
    assert wrong["score"] == "return_mean"
    assert "successes" not in wrong["logged"]
    record = yaml.safe_load((wrong["run"] / "config.yml").read_text())
    assert record["truth_free"] is True
    task = record["hyperparameters"]["env_kwargs"]["task"]
    assert task == {"prior_error": 0.01, **TRUTH_FREE_TASK}
    assert wrong["run"] != truth_free_as_is["run"]


def test_a_run_on_the_truth_does_read_it(truth_trained_as_is, wrong_truth, tmp_path):
    """The same pair trained on the truth differs: the check above can fail."""
    as_is = truth_trained_as_is
    assert as_is["score"] == "position_mean_mm"
    wrong = _run(tmp_path, truth_free=False)
    assert not _same_weights(as_is["weights"], wrong["weights"])
    assert as_is["returns"] != wrong["returns"]


def test_the_truth_free_task_is_merged_and_conflicts_are_refused():
    assert truth_free_env_kwargs({"task": {"prior_error": 0.01}, "max_primitives": 4}) == {
        "task": {"prior_error": 0.01, **TRUTH_FREE_TASK},
        "max_primitives": 4,
    }
    with pytest.raises(ValueError, match="reward_source"):
        truth_free_env_kwargs({"task": {"reward_source": "truth"}})
    with pytest.raises(ValueError, match="task must be a mapping"):
        truth_free_env_kwargs({"task": 3})


def test_the_infos_a_truth_free_run_sees_lack_the_truth():
    from stable_baselines3.common.env_util import make_vec_env

    from agents.callbacks import WithoutTruth

    env = WithoutTruth(make_vec_env(ENV_ID, n_envs=1, seed=0, env_kwargs={"max_primitives": 2}))
    env.reset()
    _, _, _, infos = env.step(np.zeros((1, 3), dtype=np.float32))
    assert not set(TRUTH_INFO) & set(infos[0])
    assert "n_measurements" in infos[0] and "predicted_error" in infos[0]
    env.close()
