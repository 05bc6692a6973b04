"""Train a stable-baselines3 agent on a tactile_gym env.

    python -m agents.train --algo ppo --env tactile_gym/HingeProbe-v1
    python -m agents.train --algo sac --n-timesteps 20000 --env-kwargs observation_mode:flat \
        --hyperparams policy:MlpPolicy

Hyperparameters come from ``configs/train/<algo>.yml``, in rl-baselines3-zoo's format (the
same file works with ``python -m rl_zoo3.train -conf``): the ``default`` entry updated by the
env's own entry, then by ``--hyperparams``, ``--env-kwargs``, ``--n-timesteps`` and
``--n-envs``. Each run gets its own folder under ``--log-folder`` holding the resolved config,
the arguments and the command line (``config.yml``), TensorBoard logs, the periodic evaluations
(``eval/evaluations.npz``), checkpoints, the best model found by the periodic evaluation
(``best_model.zip``), the final model (``final_model.zip``) and, with normalisation, the
``VecNormalize`` statistics saved with each model (see :func:`vecnormalize_path`).

The hyperparameters are checked against the algorithm's constructor and the envs are made
before the run folder is (:func:`check_hyperparameters`): a typo fails at once and leaves
nothing behind. A run that fails later leaves no folder if it saved no model, else a
``failed.txt`` saying why; an interrupted run with checkpoints can continue from the latest
(``train(..., run_dir=..., resume=True)``, what ``agents.sweep`` does).

The envs run as the package's vector env (``gym.make_vec``, ``docs/design.md`` 7.9, through
:mod:`agents.vec_env`), in this process or in worker processes as :func:`choose_env_workers`
decides from the id and the cores; ``--env-workers`` and ``--vec-env`` override that.
"""

from __future__ import annotations

import contextlib
import copy
import difflib
import functools
import inspect
import os
import shlex
import shutil
import sys
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import yaml

import tactile_gym
from tactile_gym.presets import load_yaml, preset_path
from tactile_gym.validation import check_int

from .cli import (
    KEY_VALUE_HELP,
    KNOWN_ENV_IDS,
    KeyValue,
    check_env_id,
    make_parser,
    require,
    run_main,
)
from .progress import progress_lines
from .seeds import DEMO_SEED, SELECTION_SEED, seed_ranges

ALGOS = ("ppo", "sac")
VEC_ENVS = ("vector", "dummy", "subproc")
#: The env trained and evaluated when none is named.
DEFAULT_ENV_ID = tactile_gym.ENV_IDS[0]
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
#: Torch threads of the learner unless told otherwise. The networks are small (two layers of
#: 128-256 units, batches of 128-256): on 2 cores shared with other jobs PPO trained 2.9-3.8x
#: faster on one thread than on two, and 1.06x on 2 quiet cores (benchmarks/bench_train.py);
#: extra threads mostly wait on each other and on the envs.
DEFAULT_TORCH_THREADS = 1
#: Constructor arguments of the algorithm that agents.train sets from its own arguments.
SET_BY_TRAIN = ("env", "seed", "device", "tensorboard_log", "verbose", "_init_setup_model")
#: Hyperparameters that take rl_zoo3's ``"lin_<value>"`` linear schedules.
SCHEDULE_KEYS = ("learning_rate", "clip_range", "clip_range_vf")


def make_env(env_id: str, **env_kwargs):
    """``gym.make`` after importing tactile_gym, so that worker processes know the ids."""
    import tactile_gym  # noqa: F401 - registers the envs in this process

    return gym.make(env_id, **env_kwargs)


def available_cpus() -> int:
    """Cores this process may run on (its CPU affinity, not the machine's core count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS and Windows have no affinity call
        return os.cpu_count() or 1


def choose_env_workers(env_id: str, n_envs: int, n_cpus: int) -> int:
    """How many processes step the vector env's sub-envs (``workers``, ``docs/design.md``
    7.9): 1 is this process, beside the learner.

    A primitive id's step is a whole primitive, many control steps of env work for one round
    trip to a worker: one worker per env up to the cores, the learner (a small share of a
    core) sharing them. A 6-D id's step is one control step, about what a round trip costs:
    workers only when each gets a core of its own beside the learner, else in-process. The
    README ("Speed", ``benchmarks/bench_train.py``) has the measurements.

    Args:
        env_id: the id trained.
        n_envs: parallel envs.
        n_cpus: cores the run may use.
    """
    if env_id in tactile_gym.PRIMITIVE_ENV_IDS:
        return max(1, min(n_envs, n_cpus))
    return n_envs if n_envs > 1 and n_cpus >= n_envs + 1 else 1


@contextlib.contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run torch with ``n`` intra-op threads, restoring the previous number afterwards."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


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


def vecnormalize_path(model_path: str | Path) -> Path:
    """Where ``agents.train`` saves the ``VecNormalize`` statistics that go with a model.

    * ``final_model.zip``: ``vecnormalize.pkl`` beside it (rl_zoo3's name);
    * ``rl_model_<n>_steps.zip`` (checkpoints): ``rl_model_vecnormalize_<n>_steps.pkl`` beside
      it (``CheckpointCallback``'s name, also in rl_zoo3's runs);
    * any other ``<name>.zip`` (``best_model.zip``): ``<name>_vecnormalize.pkl`` beside it.
    """
    path = Path(model_path)
    if path.stem == "final_model":
        return path.with_name("vecnormalize.pkl")
    if path.stem.startswith("rl_model_") and path.stem.endswith("_steps"):
        return path.with_name(path.stem.replace("rl_model_", "rl_model_vecnormalize_", 1) + ".pkl")
    return path.with_name(f"{path.stem}_vecnormalize.pkl")


def make_run_dir(log_folder: Path, algo: str, env_id: str, seed: int) -> Path:
    """A fresh folder ``<log_folder>/<algo>/<env>_s<seed>_<time>``."""
    name = env_id.split("/")[-1]
    stamp = time.strftime("%Y%m%d-%H%M%S")
    run_dir = Path(log_folder) / algo / f"{name}_s{seed}_{stamp}"
    suffix = 1
    while run_dir.exists():
        run_dir = Path(log_folder) / algo / f"{name}_s{seed}_{stamp}_{suffix}"
        suffix += 1
    run_dir.mkdir(parents=True)
    return run_dir


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
        algo: ``"ppo"`` or ``"sac"``.
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


def algorithm_class(algo: str) -> type:
    """The stable-baselines3 class of ``algo``."""
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS}, got {algo!r}")
    sb3 = require("stable_baselines3", "train")
    return {"ppo": sb3.PPO, "sac": sb3.SAC}[algo]


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


def train(
    algo: str = "ppo",
    env_id: str = DEFAULT_ENV_ID,
    n_timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    log_folder: str | Path = "runs",
    config_path: str | Path | None = None,
    hyperparams: Mapping[str, Any] | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    eval_freq: int = 10_000,
    eval_episodes: int = 20,
    checkpoint_freq: int = 50_000,
    progress_bar: bool = False,
    vec_env: str = "vector",
    env_workers: int | None = None,
    n_cpus: int | None = None,
    n_threads: int | None = None,
    device: str = "cpu",
    run_dir: str | Path | None = None,
    command: str | None = None,
    resume: bool = False,
    warm_start: Mapping[str, Any] | None = None,
) -> Path:
    """Train one agent and return its run folder.

    Args:
        algo: ``"ppo"`` or ``"sac"``.
        env_id: a registered id from ``tactile_gym.ENV_IDS``.
        n_timesteps: total env steps; overrides the config.
        n_envs: parallel envs; overrides the config.
        seed: seeds the envs and the algorithm.
        log_folder: parent folder of the run folder.
        config_path: YAML of hyperparameters; defaults to ``configs/train/<algo>.yml``.
        hyperparams: hyperparameters that replace the config's.
        env_kwargs: ``gym.make`` keywords that update the config's ``env_kwargs``.
        eval_freq: env steps (summed over envs) between evaluations, capped at
            ``n_timesteps`` so that every run evaluates (and saves a best model) at least
            once; 0 disables them.
        eval_episodes: episodes per evaluation, the same every time: seeds
            ``SELECTION_SEED ..`` (``agents.seeds``, ``agents.selection``).
        checkpoint_freq: env steps (summed over envs) between checkpoints; 0 disables them.
        progress_bar: show a progress bar (needs tqdm and rich); without it, a line every
            30 s (:func:`progress_lines`).
        vec_env: ``"vector"`` (the package's vector env), ``"subproc"`` (SB3's, one process
            per env) or ``"dummy"`` (SB3's loop over single envs in this process).
        env_workers: with ``"vector"``, how many processes step the sub-envs (1: this
            process); defaults to :func:`choose_env_workers`'s choice.
        n_cpus: cores the run may use; defaults to this process's CPU affinity.
        n_threads: torch threads; defaults to ``DEFAULT_TORCH_THREADS``.
        device: torch device.
        run_dir: the run folder to use (created if absent; it must not hold a run already)
            instead of a fresh one under ``log_folder``.
        command: the command line to record; defaults to ``sys.argv``.
        resume: with a ``run_dir`` that holds an interrupted run, continue it from its
            latest checkpoint (:func:`latest_checkpoint`) instead of refusing.
        warm_start: keys over the config's ``warm_start`` recipe for the id
            (``agents.warmstart.WarmStart``): with demonstrations, PPO starts from a policy
            cloned from them and a critic fitted to their returns.

    A run that fails leaves no folder if it made no model, else a ``failed.txt`` in it.
    """
    require("stable_baselines3", "train")
    from stable_baselines3.common.callbacks import CheckpointCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import (
        DummyVecEnv,
        SubprocVecEnv,
        VecMonitor,
        VecNormalize,
    )

    from .selection import FixedSeedVecEnv, continue_evaluations, fixed_seed_evaluation
    from .vec_env import make_sb3_vec_env
    from .warmstart import load_recipe, run_recipe

    check_env_id("env_id", env_id)
    if vec_env not in VEC_ENVS:
        raise ValueError(f"vec_env must be one of {VEC_ENVS}, got {vec_env!r}")
    config = resolve_config(algo, env_id, config_path, hyperparams, env_kwargs, n_timesteps, n_envs)
    n_envs = int(config["n_envs"])
    total_steps = int(config["n_timesteps"])
    n_cpus = int(n_cpus or available_cpus())
    if n_cpus < 1:
        raise ValueError(f"n_cpus must be >= 1, got {n_cpus}")
    if vec_env == "vector":
        workers = choose_env_workers(env_id, n_envs, n_cpus) if env_workers is None else env_workers
        workers = check_int("env_workers", workers, 1, n_envs)
    elif env_workers is not None:
        raise ValueError(f"env_workers needs vec_env 'vector', got vec_env {vec_env!r}")
    n_threads = int(n_threads or DEFAULT_TORCH_THREADS)
    recipe = load_recipe(preset_path("train", config_path or algo), env_id, warm_start)
    if recipe.enabled and algo != "ppo":
        raise ValueError(f"warm_start runs with ppo only, got algo {algo!r}")

    run_env_kwargs = dict(config.get("env_kwargs") or {})
    factory = functools.partial(make_env, env_id, **run_env_kwargs)

    def make_envs(n: int, first_seed: int):
        """``n`` envs seeded ``first_seed + i``; the training and the evaluation envs are
        wrapped alike, as SB3's syncing of normalisation statistics requires."""
        if vec_env == "vector":
            # VecMonitor keeps the episode records that one Monitor per env would.
            envs = VecMonitor(make_sb3_vec_env(env_id, n, min(workers, n), **run_env_kwargs))
            envs.seed(first_seed)
            return envs
        vec_cls = SubprocVecEnv if vec_env == "subproc" and n > 1 else DummyVecEnv
        return make_vec_env(factory, n_envs=n, seed=first_seed, vec_env_cls=vec_cls)

    # The envs first: a bad env keyword fails here, before a run folder exists.
    selection_seeds = list(range(SELECTION_SEED, SELECTION_SEED + max(eval_episodes, 1)))
    eval_env = FixedSeedVecEnv(make_envs(1, SELECTION_SEED), selection_seeds)
    env = make_envs(n_envs, seed)

    checkpoint = None
    if run_dir is None:
        run_dir = make_run_dir(Path(log_folder), algo, env_id, seed)
        created = True
    else:
        run_dir = Path(run_dir)
        created = not run_dir.exists()
        if (run_dir / "config.yml").exists():
            checkpoint = latest_checkpoint(run_dir) if resume else None
            if checkpoint is None:
                env.close()
                eval_env.close()
                raise ValueError(f"run_dir {str(run_dir)!r} already holds a run (config.yml)")
        run_dir.mkdir(parents=True, exist_ok=True)
    record = {
        "algo": algo,
        "env_id": env_id,
        "seed": seed,
        "command": command or shlex.join(sys.argv),
        "arguments": {
            "n_timesteps": n_timesteps,
            "n_envs": n_envs,
            "hyperparams": dict(hyperparams or {}),
            "env_kwargs": dict(env_kwargs or {}),
            "eval_freq": eval_freq,
            "eval_episodes": eval_episodes,
            "checkpoint_freq": checkpoint_freq,
            "vec_env": vec_env,
            "config_path": str(config_path) if config_path else None,
        },
        "resources": {
            "n_cpus": n_cpus,
            "vec_env": vec_env,
            "env_workers": workers if vec_env == "vector" else None,
            "torch_threads": n_threads,
        },
        "hyperparameters": config,
        "warm_start": recipe.as_dict(),
        "seeds": {
            **seed_ranges(),
            "training": [seed, seed + n_envs - 1],
            "selection": [selection_seeds[0], selection_seeds[-1]],
        },
    }
    if recipe.enabled and isinstance(recipe.demos, int):
        record["seeds"]["demonstrations"] = [DEMO_SEED, DEMO_SEED + recipe.demos - 1]
    if checkpoint is not None:
        record["resumed_from"] = checkpoint.relative_to(run_dir).as_posix()
        (run_dir / "failed.txt").unlink(missing_ok=True)
    try:
        with open(run_dir / "config.yml", "w") as f:
            yaml.safe_dump(record, f, sort_keys=False)
        normalize = config.get("normalize", False)
        if normalize:
            normalize_kwargs = normalize if isinstance(normalize, dict) else {}
            normalize_kwargs = {"gamma": config.get("gamma", 0.99), **normalize_kwargs}
            if checkpoint is not None:
                env = VecNormalize.load(str(vecnormalize_path(checkpoint)), env)
            else:
                env = VecNormalize(env, **normalize_kwargs)
            eval_kwargs = {k: v for k, v in normalize_kwargs.items() if k != "norm_reward"}
            eval_env = VecNormalize(eval_env, training=False, norm_reward=False, **eval_kwargs)

        callbacks = [] if progress_bar else [progress_lines(total_steps)]
        if eval_freq > 0:
            evaluation = fixed_seed_evaluation(
                eval_env,
                eval_episodes,
                max(min(eval_freq, total_steps) // n_envs, 1),
                run_dir,
                vecnormalize_path(run_dir / "best_model.zip") if normalize else None,
            )
            if checkpoint is not None:
                continue_evaluations(evaluation, run_dir / "eval" / "evaluations.npz")
            callbacks.append(evaluation)
        if checkpoint_freq > 0:
            callbacks.append(
                CheckpointCallback(
                    save_freq=max(checkpoint_freq // n_envs, 1),
                    save_path=str(run_dir / "checkpoints"),
                    save_vecnormalize=True,
                )
            )
        with torch_threads(n_threads):
            if checkpoint is not None:
                model = algorithm_class(algo).load(checkpoint, env=env, device=device)
                print(f"resuming from {checkpoint} at {model.num_timesteps} env steps", flush=True)
            else:
                model = _construct(algo, config, env, seed, device, run_dir)
                if recipe.enabled:
                    run_recipe(model, recipe, env_id, run_env_kwargs, seed, run_dir)
            model.learn(
                total_timesteps=total_steps - model.num_timesteps,
                callback=callbacks,
                progress_bar=progress_bar,
                reset_num_timesteps=checkpoint is None,
            )
        model.save(run_dir / "final_model")
        if isinstance(env, VecNormalize):
            env.save(str(vecnormalize_path(run_dir / "final_model.zip")))
    except BaseException as error:
        _mark_failed(run_dir, created, error)
        raise
    finally:
        env.close()
        eval_env.close()
    return run_dir


def _construct(algo: str, config: Mapping[str, Any], env, seed: int, device: str, run_dir: Path):
    """The algorithm built from the config; a value it rejects is a ``ValueError`` naming the
    hyperparameters (stable-baselines3 checks values with ``assert`` and by using them)."""
    kwargs = algo_kwargs(config)
    try:
        return algorithm_class(algo)(
            config["policy"],
            env,
            seed=seed,
            device=device,
            tensorboard_log=str(run_dir / "tensorboard"),
            verbose=0,
            **kwargs,
        )
    except (TypeError, AssertionError, KeyError) as error:
        shown = {k: config[k] for k in kwargs}
        raise ValueError(
            f"{algo} rejected policy {config['policy']!r} with the hyperparameters {shown}: {error}"
        ) from error


def latest_checkpoint(run_dir: str | Path) -> Path | None:
    """The run's checkpoint with the most env steps (``checkpoints/rl_model_<n>_steps.zip``),
    or ``None``."""
    found = []
    for path in Path(run_dir).glob("checkpoints/rl_model_*_steps.zip"):
        steps = path.stem.removeprefix("rl_model_").removesuffix("_steps")
        if steps.isdigit():
            found.append((int(steps), path))
    return max(found)[1] if found else None


def _mark_failed(run_dir: Path, created: bool, error: BaseException) -> None:
    """A run folder this run made and that holds no model is removed; any other gets
    ``failed.txt``, saying why the run stopped."""
    if created and not any(run_dir.rglob("*.zip")):
        shutil.rmtree(run_dir, ignore_errors=True)
        with contextlib.suppress(OSError):  # the algo's folder, if this run was its first
            run_dir.parent.rmdir()
        return
    reason = "interrupted" if isinstance(error, KeyboardInterrupt) else repr(error)
    (run_dir / "failed.txt").write_text(f"{reason}\n")


def main(argv: list[str] | None = None) -> Path:
    parser = make_parser(__spec__.name if __spec__ else "agents.train", __doc__)
    parser.add_argument("--algo", choices=ALGOS, default="ppo", help="the algorithm")
    parser.add_argument("--env", default=DEFAULT_ENV_ID, help=f"one of {', '.join(KNOWN_ENV_IDS)}")
    parser.add_argument(
        "--n-timesteps",
        type=int,
        default=None,
        help="total env steps (primitives on the primitive ids, control steps on the others); "
        "default: the config's n_timesteps",
    )
    parser.add_argument(
        "--n-envs", type=int, default=None, help="parallel envs; default: the config's n_envs"
    )
    parser.add_argument("--seed", type=int, default=0, help="seeds the envs and the algorithm")
    parser.add_argument(
        "--log-folder",
        default="runs",
        help="the run goes to <log-folder>/<algo>/<env>_s<seed>_<time>",
    )
    parser.add_argument(
        "--config",
        default=None,
        help="hyperparameter YAML: a preset name of configs/train/ or a path; "
        "default: configs/train/<algo>.yml",
    )
    parser.add_argument(
        "--hyperparams",
        nargs="+",
        action=KeyValue,
        default={},
        metavar="KEY:VALUE",
        help="hyperparameters over the config's (arguments of the algorithm, or policy, "
        f"n_timesteps, n_envs, normalize), e.g. n_steps:256 learning_rate:1e-4; {KEY_VALUE_HELP}",
    )
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        action=KeyValue,
        default={},
        metavar="KEY:VALUE",
        help="gym.make keywords over the config's env_kwargs, e.g. observation_mode:flat "
        f"skin:{{friction: 0.3}}; {KEY_VALUE_HELP}",
    )
    parser.add_argument(
        "--eval-freq",
        type=int,
        default=10_000,
        help="env steps between periodic evaluations (they pick best_model.zip); 0: none",
    )
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=20,
        help="episodes per periodic evaluation, the same seeds every time (agents.seeds)",
    )
    parser.add_argument(
        "--warm-start",
        nargs="+",
        action=KeyValue,
        default={},
        metavar="KEY:VALUE",
        help="keys over the config's warm_start recipe, e.g. demos:80 bc_epochs:50 "
        f"(demos:0 turns it off; agents.warmstart.WarmStart); {KEY_VALUE_HELP}",
    )
    parser.add_argument(
        "--checkpoint-freq", type=int, default=50_000, help="env steps between checkpoints; 0: none"
    )
    parser.add_argument(
        "--vec-env",
        choices=VEC_ENVS,
        default="vector",
        help="vector: the package's vector env; subproc: SB3's, one process per env; dummy: "
        "SB3's loop over single envs in this process",
    )
    parser.add_argument(
        "--env-workers",
        type=int,
        default=None,
        help="with --vec-env vector, processes that step the envs (1: this process); default: "
        "one per env up to the cores for the primitive ids, and for the 6-D ids only when each "
        "gets a core beside the learner (agents.train.choose_env_workers)",
    )
    parser.add_argument(
        "--n-cpus", type=int, default=None, help="cores the run may use; default: all it may"
    )
    parser.add_argument(
        "--torch-threads",
        type=int,
        default=None,
        help=f"torch threads of the learner; default: {DEFAULT_TORCH_THREADS}",
    )
    parser.add_argument("--device", default="cpu", help="torch device (cpu, cuda, auto)")
    parser.add_argument(
        "--no-progress-bar",
        action="store_true",
        help="print a progress line every 30 s instead of a progress bar",
    )
    args = parser.parse_args(argv)
    run_dir = train(
        algo=args.algo,
        env_id=args.env,
        n_timesteps=args.n_timesteps,
        n_envs=args.n_envs,
        seed=args.seed,
        log_folder=args.log_folder,
        config_path=args.config,
        hyperparams=args.hyperparams,
        env_kwargs=args.env_kwargs,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        checkpoint_freq=args.checkpoint_freq,
        progress_bar=not args.no_progress_bar,
        vec_env=args.vec_env,
        env_workers=args.env_workers,
        n_cpus=args.n_cpus,
        n_threads=args.torch_threads,
        device=args.device,
        warm_start=args.warm_start,
        command=shlex.join(["python", "-m", parser.prog.split()[-1], *(argv or sys.argv[1:])]),
    )
    print(f"run saved in {run_dir}")
    return run_dir


if __name__ == "__main__":
    sys.exit(run_main(main))
