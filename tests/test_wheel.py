"""The wheel, installed in a clean virtualenv and used from outside the checkout.

Builds the wheel from a copy of the working tree (``pip wheel --no-deps``), installs it with
``[train]`` into a fresh virtualenv (the CPU build of torch first), and from an empty folder
elsewhere: makes and steps every id, checks that the agents and presets come from inside the
package and that no top-level ``agents`` module is installed, trains PPO for a few steps and
runs the main command on a reduced budget. Needs pip to reach a package index; it takes a few
minutes, hence ``slow``. The wheel's and the virtualenv's sizes are printed (``-s``).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

import tactile_gym

ROOT = Path(__file__).resolve().parents[1]
TORCH = "torch==2.13.0"  # the CPU build; stable-baselines3 would otherwise pull CUDA's

pytestmark = pytest.mark.slow


def _run(command: list[str], cwd: Path, timeout: float = 900) -> subprocess.CompletedProcess:
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, f"{' '.join(map(str, command))}:\n{result.stderr[-4000:]}"
    return result


def _size(path: Path) -> int:
    """Bytes under ``path`` (symlinks not followed)."""
    return sum(f.lstat().st_size for f in path.rglob("*") if f.is_file() and not f.is_symlink())


def _source_copy(target: Path) -> Path:
    """The files git would commit (tracked, and untracked but not ignored), copied: a wheel
    built in place would also pack whatever a stale ``build/`` holds."""
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split("\0")
    for name in filter(None, listed):
        source = ROOT / name
        if source.is_file():
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target / name)
    return target


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(python of the virtualenv, an empty folder outside the checkout, the wheel)."""
    base = tmp_path_factory.mktemp("wheel")
    source = _source_copy(base / "source")
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(base / "dist"), "."], source)
    (wheel,) = (base / "dist").glob("tactile_gym-*.whl")
    venv.create(base / "venv", with_pip=True)
    python = base / "venv" / "bin" / "python"
    _run([python, "-m", "pip", "install", TORCH], base)
    _run([python, "-m", "pip", "install", f"{wheel}[train]"], base)
    outside = base / "outside"
    outside.mkdir()
    print(
        f"\nwheel {wheel.name}: {wheel.stat().st_size / 1e3:.0f} kB;"
        f" virtualenv with [train]: {_size(base / 'venv') / 1e6:.0f} MB"
    )
    return python, outside, wheel


def test_the_wheel_holds_the_package_its_agents_presets_and_types(installed):
    *_, wheel = installed
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"tactile_gym"}
    for kind in ("env", "objects", "train", "sweeps"):
        assert any(n.startswith(f"tactile_gym/configs/{kind}/") for n in names), kind
    assert "tactile_gym/agents/reproduce_paper.py" in names
    # PEP 561: type checkers read the package's annotations; the licence travels with it.
    assert "tactile_gym/py.typed" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), names


CHECK = """
import importlib.metadata, importlib.util
from pathlib import Path

import gymnasium as gym
import numpy as np

import tactile_gym
from tactile_gym.presets import KINDS, load_preset, preset_names
from tactile_gym.sim import ObjectConfig
from tactile_gym.sim.config import FAMILIES

site = Path(tactile_gym.__file__).resolve().parents[1]
assert site.name == "site-packages", tactile_gym.__file__
assert importlib.metadata.version("tactile-gym") == tactile_gym.__version__
assert importlib.util.find_spec("agents") is None, "a top-level agents module is installed"
assert importlib.util.find_spec("configs") is None, "a top-level configs module is installed"
import tactile_gym.agents.train, tactile_gym.agents.scripted
assert Path(tactile_gym.agents.train.__file__).resolve().is_relative_to(site)
for kind in KINDS:
    assert preset_names(kind), kind
assert "default" in load_preset("train", "ppo")
for family in FAMILIES:
    ObjectConfig.family_default(family)
for env_id in tactile_gym.ENV_IDS + tactile_gym.JOINT_ENV_IDS:
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs, reward, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs) and np.isfinite(reward)
    env.close()
    print(env_id, "ok")
"""


def test_envs_agents_and_presets_from_outside(installed):
    python, outside, _ = installed
    result = _run([python, "-c", CHECK], outside)
    assert result.stdout.count(" ok") == len(tactile_gym.ENV_IDS) + len(tactile_gym.JOINT_ENV_IDS)


def test_ppo_trains_a_few_steps(installed):
    python, outside, _ = installed
    command = [
        python, "-m", "tactile_gym.agents.train", "--algo", "ppo", "--n-timesteps", "64",
        "--n-envs", "1", "--eval-freq", "0", "--checkpoint-freq", "0", "--no-progress-bar",
        "--log-folder", "runs", "--hyperparams", "n_steps:32", "batch_size:32", "n_epochs:1",
    ]  # fmt: skip
    _run(command, outside)
    (model,) = (outside / "runs").rglob("final_model.zip")
    assert (model.parent / "config.yml").exists()
    # The usage names the module as a wheel's user runs it; a mistake is one line, status 2.
    usage = _run([python, "-m", "tactile_gym.agents.train", "--help"], outside).stdout
    assert usage.startswith("usage: python -m tactile_gym.agents.train")
    typo = [python, "-m", "tactile_gym.agents.train", "--hyperparams", "n_step:64"]
    result = subprocess.run(typo, cwd=outside, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2 and "'n_step'" in result.stderr
    assert "Traceback" not in result.stderr


def test_main_command_on_one_trial(installed):
    python, outside, _ = installed
    out = outside / "paper"
    command = [
        python, "-m", "tactile_gym.agents.reproduce_paper", "--trials", "1", "--schemes",
        "paper", "--out", str(out),
    ]  # fmt: skip
    result = _run(command, outside)
    assert (out / "table1.md").read_text() in result.stdout + "\n"
    # The plots need matplotlib, which [train] brings.
    assert sorted(p.name for p in out.glob("*.png")) == ["fig_fixed.png", "fig_slides.png"]
