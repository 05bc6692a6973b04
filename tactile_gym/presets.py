"""The YAML presets that ship with tactile_gym, loaded by name.

The repository keeps them in its top-level ``configs/`` folder, which installs as the package
data ``tactile_gym.configs``, so a wheel carries them too. Each preset belongs to a kind (a
sub-folder): ``env`` (environment overrides), ``objects`` (hinged-object families),
``train`` (stable-baselines3 / rl_zoo3 hyperparameters) and ``sweeps`` (multi-run
benchmarks). A preset holds only what differs from the defaults in code.

    from tactile_gym.presets import load_preset

    load_preset("train", "ppo")             # configs/train/ppo.yml
    load_preset("train", "my_ppo.yml")      # a file of your own, by path
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

__all__ = ["KINDS", "load_preset", "load_yaml", "preset_names", "preset_path"]

KINDS = ("env", "objects", "train", "sweeps")


def _root() -> Path:
    """The presets' folder: inside the installed package (a wheel), or beside the package in
    a source checkout (an editable install), whichever holds the package imported."""
    package = Path(__file__).resolve().parent
    installed = package / "configs"
    return installed if installed.is_dir() else package.parent / "configs"


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")


def preset_names(kind: str) -> list[str]:
    """Names of the presets of a kind, sorted."""
    _check_kind(kind)
    return sorted(p.stem for p in (_root() / kind).glob("*.yml"))


def preset_path(kind: str, name: str | Path) -> Path:
    """The file of a preset: a shipped one by name, or any YAML file by path.

    Args:
        kind: one of ``KINDS``.
        name: a preset name (``"ppo"``), or a path to a ``.yml``/``.yaml`` file.

    Raises:
        ValueError: unknown kind, or no such preset (the message lists the shipped ones).
    """
    _check_kind(kind)
    path = Path(name)
    if path.suffix in (".yml", ".yaml"):
        if not path.is_file():
            raise ValueError(f"no {kind} preset file at {str(path)!r}")
        return path
    shipped = _root() / kind / f"{name}.yml"
    if not shipped.is_file():
        raise ValueError(f"unknown {kind} preset {name!r}; shipped: {preset_names(kind)}")
    return shipped


def load_yaml(path: str | Path) -> dict[str, Any]:
    """A YAML file whose top level is a mapping (an empty file gives ``{}``)."""
    with open(path) as fh:
        data = yaml.safe_load(fh) or {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return data


def load_preset(kind: str, name: str | Path) -> dict[str, Any]:
    """The mapping stored in a preset (see :func:`preset_path` for ``name``)."""
    return load_yaml(preset_path(kind, name))
