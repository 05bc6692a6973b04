"""Training hyperparameters: rl-baselines3-zoo's YAML, resolved and checked for a run.

``configs/train/<algo>.yml`` holds a ``default`` entry and one entry per env id, in
rl-baselines3-zoo's format (the same file works with ``python -m rl_zoo3.train -conf``). A run's
config is the ``default`` entry updated by the env's own, then by the command's overrides
(:func:`resolve_config`); its keys are checked against the algorithm's constructor before
anything runs (:func:`check_hyperparameters`), and rl_zoo3's value forms (``"lin_<x>"``
schedules, ``train_freq`` lists) become what stable-baselines3 takes (:func:`algo_kwargs`).
The same reading rebuilds a saved model's schedules from its run's ``config.yml``
(``agents.runs``).
"""

from __future__ import annotations

import copy
import difflib
import inspect
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from tactile_gym.presets import load_yaml, preset_path

from .cli import require

__all__ = [
    "ALGOS",
    "CLASSES",
    "ZOO_NAMES",
    "algo_kwargs",
    "algorithm_class",
    "check_hyperparameters",
    "load_hyperparameters",
    "resolve_config",
    "TRUTH_FREE_TASK",
    "load_deadband",
    "truth_free_env_kwargs",
]

#: The algorithms ``agents.train`` runs: stable-baselines3's PPO and SAC, and sb3-contrib's
#: RecurrentPPO (an LSTM policy, for the 6-D ids: ``docs/design.md`` 12) and TQC.
ALGOS = ("ppo", "sac", "recurrent_ppo", "tqc")
#: Where rl-baselines3-zoo names an algorithm otherwise (``python -m rl_zoo3.train --algo``).
ZOO_NAMES = {"recurrent_ppo": "ppo_lstm"}
#: Each algorithm's class: (module, name).
CLASSES = {
    "ppo": ("stable_baselines3", "PPO"),
    "sac": ("stable_baselines3", "SAC"),
    "recurrent_ppo": ("sb3_contrib", "RecurrentPPO"),
    "tqc": ("sb3_contrib", "TQC"),
}
#: The task settings of a run trained without the truth (``agents.train --truth-free``): the
#: reward scores the estimator's predicted error, the workspace is centred on the start pose
#: (``tactile_gym.envs.task``), so no reward, termination or selection reads the truth.
TRUTH_FREE_TASK = {"reward_source": "predicted", "workspace_center": "start"}
#: Keys of a training config that are not constructor arguments of the algorithm.
RUN_KEYS = ("policy", "n_timesteps", "n_envs", "normalize", "env_kwargs")
#: rl_zoo3 keys that agents.train does not implement (it would pass them to the algorithm).
ZOO_ONLY_KEYS = (
    "frame_stack",
    "env_wrapper",
    "vec_env_wrapper",
    "callback",
    "monitor_kwargs",
    "noise_type",
    "noise_std",
)
#: Constructor arguments of the algorithm that agents.train sets from its own arguments.
SET_BY_TRAIN = ("env", "seed", "device", "tensorboard_log", "verbose", "_init_setup_model")
#: Hyperparameters that take rl_zoo3's ``"lin_<value>"`` linear schedules.
SCHEDULE_KEYS = ("learning_rate", "clip_range", "clip_range_vf")


def load_hyperparameters(algo: str, env_id: str, config_path: str | Path | None = None) -> dict:
    """The ``default`` entry of the algo's YAML, updated by the env's entry.

    The shipped files make every env entry complete with a YAML merge key, so this is also
    exactly the entry rl_zoo3 reads; an id without an entry gets ``default`` in both.
    """
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS}, got {algo!r}")
    path = preset_path("train", config_path or algo)
    table = load_yaml(path)
    if "default" not in table:
        raise ValueError(f"{path} has no 'default' entry")
    config = copy.deepcopy(table["default"])
    config.update(copy.deepcopy(table.get(env_id) or {}))
    return config


def resolve_config(
    algo: str,
    env_id: str,
    config_path: str | Path | None = None,
    hyperparams: Mapping[str, Any] | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    n_timesteps: int | None = None,
    n_envs: int | None = None,
) -> dict:
    """The run's hyperparameters: the YAML, then the overrides, checked.

    Args:
        algo: one of :data:`ALGOS`.
        env_id: a registered id.
        config_path: YAML of hyperparameters (name or path); defaults to the algo's.
        hyperparams: keys that replace the YAML's (like rl_zoo3's ``--hyperparams``).
        env_kwargs: keyword arguments of ``gym.make`` that update the YAML's ``env_kwargs``
            key by key.
        n_timesteps: total env steps, if given.
        n_envs: parallel envs, if given.

    Raises:
        ValueError: an unsupported key or value, naming it and what is allowed.
    """
    config = load_hyperparameters(algo, env_id, config_path)
    config.update(copy.deepcopy(dict(hyperparams or {})))
    if env_kwargs:
        config["env_kwargs"] = {**(config.get("env_kwargs") or {}), **env_kwargs}
    if n_timesteps is not None:
        config["n_timesteps"] = int(n_timesteps)
    if n_envs is not None:
        config["n_envs"] = int(n_envs)
    for key in ("policy", "n_timesteps"):
        if key not in config:
            raise ValueError(f"the {algo} config for {env_id} has no {key!r}")
    config.setdefault("n_envs", 1)
    for key in ("n_timesteps", "n_envs"):
        if not int(config[key]) >= 1:
            raise ValueError(f"{key} must be >= 1, got {config[key]!r}")
    unsupported = sorted(set(config) & set(ZOO_ONLY_KEYS))
    if unsupported:
        raise ValueError(
            f"agents.train does not implement the rl_zoo3 keys {unsupported}; "
            f"remove them or train with python -m rl_zoo3.train"
        )
    if not isinstance(config.get("normalize", False), (bool, dict)):
        raise ValueError(
            "normalize must be true, false or a mapping of VecNormalize arguments, "
            f"got {config['normalize']!r}"
        )
    for key in ("policy_kwargs", "env_kwargs"):
        if not isinstance(config.get(key) or {}, dict):
            raise ValueError(f"{key} must be a mapping, got {config[key]!r}")
    check_hyperparameters(algo, config)
    return config


def truth_free_env_kwargs(env_kwargs: Mapping[str, Any] | None) -> dict:
    """``env_kwargs`` with the ``task`` settings of :data:`TRUTH_FREE_TASK` merged into its
    ``task`` mapping (the other task settings, such as ``prior_error``, kept).

    Raises:
        ValueError: a ``task`` that sets one of those keys to another value.
    """
    env_kwargs = copy.deepcopy(dict(env_kwargs or {}))
    task = env_kwargs.get("task") or {}
    if not isinstance(task, dict):
        raise ValueError(f"env_kwargs task must be a mapping, got {task!r}")
    for key, value in TRUTH_FREE_TASK.items():
        if task.get(key, value) != value:
            raise ValueError(
                f"a truth-free run trains with task {key} {value!r}, got {task[key]!r}; "
                "drop the setting or train without --truth-free"
            )
    env_kwargs["task"] = {**task, **TRUTH_FREE_TASK}
    return env_kwargs


def load_deadband(config_file: str | Path, env_id: str, width: float | None = None) -> float:
    """The action deadband of ``env_id``: ``width`` if given, else the training config's
    ``action_deadband`` table (keyed by env id beside the entries rl_zoo3 reads, as
    ``warm_start``), else 0 (none). Action components smaller than it in magnitude are
    executed as 0 (``agents.policies.deadband``).

    Raises:
        ValueError: a table that is not a mapping of env ids to numbers, or a width outside
            [0, 1).
    """
    if width is None:
        table = load_yaml(config_file).get("action_deadband") or {}
        if not isinstance(table, dict):
            raise ValueError(
                f"action_deadband in {config_file} must map env ids to widths, got {table!r}"
            )
        width = table.get(env_id, 0.0)
    if isinstance(width, bool) or not isinstance(width, (int, float)) or not 0 <= width < 1:
        raise ValueError(f"action_deadband must be a number in [0, 1), got {width!r}")
    return float(width)


def algorithm_class(algo: str) -> type:
    """The stable-baselines3 class of ``algo``."""
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS}, got {algo!r}")
    module, name = CLASSES[algo]
    return getattr(require(module, "train"), name)


def check_hyperparameters(algo: str, config: Mapping[str, Any]) -> None:
    """Check the config's keys against the algorithm's constructor, before anything runs.

    Raises:
        ValueError: a key that is neither a run key (:data:`RUN_KEYS`) nor an argument of the
            algorithm, naming it, the closest allowed key and all of them; a key that
            ``agents.train`` sets from its own arguments (:data:`SET_BY_TRAIN`); or a
            schedule that is not ``lin_<number>``.
    """
    parameters = inspect.signature(algorithm_class(algo).__init__).parameters
    allowed = sorted((set(parameters) - {"self", "policy", *SET_BY_TRAIN}) | set(RUN_KEYS))
    for key in config:
        if key in SET_BY_TRAIN:
            raise ValueError(
                f"hyperparameter {key!r} is set by agents.train's own arguments "
                "(--seed, --device, --log-folder); remove it from the hyperparameters"
            )
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ValueError(
                f"unknown {algo} hyperparameter {key!r}{hint}; allowed: {', '.join(allowed)}"
            )
    algo_kwargs(config)  # checks the values of rl_zoo3's forms (schedules)


def _linear_schedule(initial: float):
    def schedule(progress_remaining: float) -> float:
        return progress_remaining * initial

    return schedule


def algo_kwargs(config: Mapping[str, Any]) -> dict:
    """The config's constructor arguments of the algorithm, with rl_zoo3's value forms:
    ``"lin_<x>"`` schedules and ``train_freq`` lists."""
    kwargs = {k: copy.deepcopy(v) for k, v in config.items() if k not in RUN_KEYS}
    for key in SCHEDULE_KEYS:
        value = kwargs.get(key)
        if isinstance(value, str):
            kind, _, initial = value.partition("_")
            if kind != "lin":
                raise ValueError(f"{key} must be a number or 'lin_<number>', got {value!r}")
            kwargs[key] = _linear_schedule(float(initial))
    if isinstance(kwargs.get("train_freq"), list):
        kwargs["train_freq"] = tuple(kwargs["train_freq"])
    return kwargs
