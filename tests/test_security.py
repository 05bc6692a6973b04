"""Loading a model folder runs none of its code (issue 30, ``docs/security.md``).

A payload that would create a file is planted in a copy of a committed model folder: in the
statistics pickle, in the cloudpickled entries of the zip's ``data``, in a new entry of
``data`` and in the weights. ``agents.evaluate``, ``agents.selection`` and the Python API
are run on it: the file never appears, and a refusal is one line with exit status 2. Each
damaged or foreign folder gets one line with status 2 too.
"""

from __future__ import annotations

import base64
import io
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from test_cli import _usage_error

from agents import cli, evaluate, runs, selection
from agents.policies import ModelPolicy
from agents.seeds import SELECTION_SEED

pytest.importorskip("stable_baselines3")

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "models" / "ppo_HingeProbePrimitive-v2_s3"
COMMITTED_MODEL = str(COMMITTED / "final_model.zip")
#: Short episodes: what is checked here is the loading.
SHORT = ["--episodes", "1", "--env-kwargs", "max_steps:30", "--no-plot"]


class CreateFile:
    """Unpickled, creates the file at ``path`` (what a planted payload could do)."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def __reduce__(self):
        return (open, (self.path, "w"))


@pytest.fixture
def folder(tmp_path) -> Path:
    """A copy of a committed model folder: ``final_model.zip``, its statistics (JSON), the
    run's ``config.yml``."""
    copy = tmp_path / "ppo_run"
    shutil.copytree(COMMITTED, copy)
    return copy


@pytest.fixture
def marker(tmp_path) -> Path:
    return tmp_path / "payload_ran"


def rewrite_zip(path: Path, change) -> None:
    """Rewrite the zip at ``path`` with ``change(members)`` applied to its members (name to
    bytes), as an attacker with the file would."""
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    change(members)
    with zipfile.ZipFile(path, "w") as archive:
        for name, content in members.items():
            archive.writestr(name, content)


def plant_in_data(path: Path, marker: Path, new_entry: bool) -> None:
    """The payload as every cloudpickled entry of ``data`` (SB3's ``":serialized:"``), or as
    one more such entry."""
    payload = base64.b64encode(pickle.dumps(CreateFile(marker))).decode()

    def change(members):
        data = json.loads(members["data"])
        if new_entry:
            data["extra"] = {":type:": "<class 'object'>", ":serialized:": payload}
        for entry in data.values():
            if isinstance(entry, dict) and ":serialized:" in entry:
                entry[":serialized:"] = payload
        members["data"] = json.dumps(data).encode()

    rewrite_zip(path, change)


def plant_in_weights(path: Path, marker: Path) -> None:
    """The payload as the policy's weights, in torch's own file format."""
    import torch

    def change(members):
        buffer = io.BytesIO()
        torch.save(CreateFile(marker), buffer)
        members["policy.pth"] = buffer.getvalue()

    rewrite_zip(path, change)


def plant_statistics_pickle(folder: Path, marker: Path) -> None:
    """The payload as the statistics, pickled where SB3 saves them, the JSON file gone."""
    (folder / "vecnormalize.json").unlink()
    (folder / "vecnormalize.pkl").write_bytes(pickle.dumps(CreateFile(marker)))


def refused_everywhere(capsys, folder: Path, *expected: str, marker: Path | None = None) -> None:
    """``agents.evaluate``, ``agents.selection`` and the Python API refuse the folder's
    model in one line (holding each ``expected`` text) with status 2, and a planted payload
    never runs (its ``marker`` file never appears)."""
    model = str(folder / "final_model.zip")
    out = folder.parent / "out"
    for main, argv in (
        (evaluate.main, ["--policies", model, "--out", str(out), *SHORT]),
        (selection.main, [model, "--episodes", "1", "--out", str(out)]),
    ):
        err = _usage_error(capsys, main, argv, *expected)
        assert err.count("\n") == 1, err
        assert marker is None or not marker.exists()
    for call in (
        lambda: evaluate.evaluate([model], episodes=1, out=out, plot=False),
        lambda: selection.select_model([model], episodes=1, seed=SELECTION_SEED, out=out),
        lambda: ModelPolicy(model, cli.make_env("tactile_gym/HingeProbePrimitive-v2")),
    ):
        with pytest.raises(ValueError) as error:
            call()
        assert "\n" not in str(error.value) and all(text in str(error.value) for text in expected)
        assert marker is None or not marker.exists()


# ------------------------------------------------------------------------------ payloads
def test_a_payload_in_the_statistics_pickle_never_runs(capsys, folder, marker):
    plant_statistics_pickle(folder, marker)
    refused_everywhere(capsys, folder, "vecnormalize.pkl", "--trust-pickle", marker=marker)


def test_a_payload_in_the_zips_pickled_entries_never_runs(folder, marker, tmp_path):
    """Every entry SB3 would unpickle is rebuilt instead: the model plays as the committed
    one does, and the payloads lie unread."""
    plant_in_data(folder / "final_model.zip", marker, new_entry=False)
    kwargs = {"episodes": 1, "env_kwargs": {"max_steps": 30}, "plot": False}
    planted = evaluate.evaluate([str(folder / "final_model.zip")], out=tmp_path / "a", **kwargs)
    committed = evaluate.evaluate(
        [str(COMMITTED / "final_model.zip")], out=tmp_path / "b", **kwargs
    )
    assert list(planted.values()) == list(committed.values())
    selection.select_model([str(folder / "final_model.zip")], episodes=1, out=tmp_path / "c")
    assert not marker.exists()


def test_a_payload_in_a_new_pickled_entry_is_refused(capsys, folder, marker):
    plant_in_data(folder / "final_model.zip", marker, new_entry=True)
    refused_everywhere(capsys, folder, "'extra'", "--trust-pickle", marker=marker)


def test_a_payload_in_the_weights_is_refused(capsys, folder, marker):
    """SB3 reads the weights with ``torch.load(weights_only=True)``: tensors only."""
    plant_in_weights(folder / "final_model.zip", marker)
    expected = ("does not load as a PPO model", "Weights only")
    refused_everywhere(capsys, folder, *expected, marker=marker)


def test_the_loading_unpickles_nothing(monkeypatch, folder):
    """The committed folder loads with pickle's and cloudpickle's loaders made to fail."""
    import cloudpickle

    def refuse(*args, **kwargs):
        raise AssertionError("something was unpickled")

    env = cli.make_env("tactile_gym/HingeProbePrimitive-v2", max_steps=30)
    obs, _ = env.reset(seed=0)  # the simulator's compiled kernels, from numba's cache
    with monkeypatch.context() as patch:
        for module, name in ((pickle, "load"), (pickle, "loads"), (cloudpickle, "loads")):
            patch.setattr(module, name, refuse)
        policy = ModelPolicy(folder / "final_model.zip", env)
    assert env.action_space.contains(policy.get_action(obs))
    env.close()


# ---------------------------------------------------------------- what trust lets through
def test_an_old_statistics_pickle_loads_with_trust_and_converts(capsys, folder, tmp_path):
    """A genuine ``VecNormalize`` pickle, as earlier versions saved: refused without the
    flag, the same numbers with it, and the same again once converted to JSON."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.convert_models import main as convert

    env = cli.make_env("tactile_gym/HingeProbePrimitive-v2")
    runs.read_statistics(folder / "vecnormalize.json", DummyVecEnv([lambda: env])).save(
        str(folder / "vecnormalize.pkl")
    )
    (folder / "vecnormalize.json").unlink()
    model = str(folder / "final_model.zip")
    argv = ["--policies", model, "--out", str(tmp_path / "x"), *SHORT]
    _usage_error(capsys, evaluate.main, argv, "is a pickle", "agents.convert_models")
    kwargs = {"episodes": 2, "env_kwargs": {"max_steps": 60}, "plot": False}
    trusted = evaluate.evaluate([model], out=tmp_path / "t", trust_pickle=True, **kwargs)
    assert convert([str(folder), "--remove-pickles"])["safe"] == [folder / "final_model.zip"]
    assert "loads without unpickling" in capsys.readouterr().out
    assert not (folder / "vecnormalize.pkl").exists()
    converted = evaluate.evaluate([model], out=tmp_path / "c", **kwargs)
    committed = evaluate.evaluate(
        [str(COMMITTED / "final_model.zip")], out=tmp_path / "o", **kwargs
    )
    assert list(trusted.values()) == list(converted.values()) == list(committed.values())
    env.close()


def test_an_rl_zoo3_folder_and_another_algorithm_need_trust(tmp_path):
    """A TD3 model (an algorithm the safe load does not rebuild) and a model in an rl_zoo3
    run load only with trust_pickle."""
    from stable_baselines3 import TD3

    env = cli.make_env("tactile_gym/HingeProbePrimitive-v2", max_steps=20)
    TD3("MultiInputPolicy", env, learning_starts=10, buffer_size=100).save(tmp_path / "td3.zip")
    with pytest.raises(ValueError, match="TD3 model loads only by unpickling"):
        runs.load_model(tmp_path / "td3.zip", env)
    assert type(runs.load_model(tmp_path / "td3.zip", env, trust_pickle=True)).__name__ == "TD3"
    zoo = tmp_path / "zoo" / "tactile_gym-HingeProbePrimitive-v2"
    zoo.mkdir(parents=True)
    (zoo / "args.yml").write_text("algo: ppo\nenv: tactile_gym/HingeProbePrimitive-v2\n")
    shutil.copy(COMMITTED / "final_model.zip", zoo.parent / "best_model.zip")
    with pytest.raises(ValueError, match="rl_zoo3 run"):
        runs.load_model(zoo.parent / "best_model.zip", env)
    env.close()


# ------------------------------------------------------------- damaged or foreign folders
# Each through agents.evaluate, agents.selection and the Python API (refused_everywhere).
def test_a_truncated_zip(capsys, folder):
    model = folder / "final_model.zip"
    model.write_bytes(model.read_bytes()[: model.stat().st_size // 2])
    refused_everywhere(capsys, folder, "final_model.zip", "damaged or not a zip")


def test_statistics_of_the_wrong_shape(capsys, folder):
    path = folder / "vecnormalize.json"
    record = json.loads(path.read_text())
    for key in ("mean", "var"):
        record["obs_rms"]["contact"][key].pop()
    path.write_text(json.dumps(record))
    refused_everywhere(capsys, folder, "'contact' statistics have shape (11,)", "(12,)")


def test_statistics_of_another_observation_mode(capsys, folder):
    """Statistics of one flat array beside a model of dict observations."""
    path = folder / "vecnormalize.json"
    record = json.loads(path.read_text())
    record["obs_rms"], record["norm_obs_keys"] = {"mean": [0.0], "var": [1.0], "count": 1.0}, None
    path.write_text(json.dumps(record))
    refused_everywhere(capsys, folder, "vecnormalize.json", "one array", "Dict")


def test_missing_statistics_of_a_model_trained_with_them(capsys, folder):
    (folder / "vecnormalize.json").unlink()
    refused_everywhere(capsys, folder, "trained with VecNormalize", "vecnormalize.json")


def test_a_statistics_pickle_without_the_flag(capsys, folder):
    (folder / "vecnormalize.json").rename(folder / "vecnormalize.pkl")  # a pickle by its name
    refused_everywhere(capsys, folder, "vecnormalize.pkl", "is a pickle", "--trust-pickle")


def test_a_zip_that_is_not_a_model(capsys, folder):
    with zipfile.ZipFile(folder / "final_model.zip", "w") as archive:
        archive.writestr("notes.txt", "not a model")
    refused_everywhere(capsys, folder, "not a stable-baselines3 model", "notes.txt")


@pytest.mark.parametrize("folder", sorted(p.name for p in (ROOT / "models").iterdir()))
def test_every_committed_model_is_complete_and_plays_without_unpickling(folder):
    """Each committed folder holds one model, its statistics as JSON and its run's
    ``config.yml`` (the selected ones their ``selection.json``, naming this folder), and acts
    on its own id through the loader that unpickles nothing (the payload tests above)."""
    import gymnasium as gym

    path = ROOT / "models" / folder
    (model,) = path.glob("*.zip")
    assert runs.statistics_path(model).is_file()
    config = yaml.safe_load((path / "config.yml").read_text())
    if (path / "selection.json").exists():
        record = json.loads((path / "selection.json").read_text())
        assert record["copied_to"] == f"models/{folder}"
        assert record["env_id"] == config["env_id"]
        assert Path(record["selected"]).name == model.name
    env = gym.make(config["env_id"], **(config["arguments"]["env_kwargs"] or {}))
    obs, _ = env.reset(seed=SELECTION_SEED)
    policy = ModelPolicy(model, env)  # trust_pickle off: the loader's safe path
    policy.reset()
    for _ in range(3):
        obs, *_ = env.step(policy.get_action(obs))
    assert env.action_space.contains(np.asarray(policy.get_action(obs), dtype=np.float32))
    env.close()
