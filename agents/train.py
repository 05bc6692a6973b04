"""Train a stable-baselines3 agent on a tactile_gym env.

    python -m agents.train --algo ppo --env tactile_gym/HingeProbe-v0
    python -m agents.train --algo sac --env tactile_gym/HingeProbe-v0 --n-timesteps 20000

Hyperparameters come from ``configs/train/<algo>.yml``: the ``default`` entry updated by the
env's own entry, then by ``--n-timesteps``/``--n-envs``. Each run gets its own folder under
``--log-folder`` holding the resolved config, the arguments and the command line
(``config.yml``), TensorBoard logs, checkpoints, the best model found by the periodic
evaluation, the final model (``final_model.zip``) and, with normalisation, the
``VecNormalize`` statistics (``vecnormalize.pkl``).
"""

from __future__ import annotations

import argparse
import copy
import functools
import shlex
import sys
import time
from pathlib import Path

import yaml

from tactile_gym.presets import load_yaml, preset_path

ALGOS = ("ppo", "sac")
#: Keys of a training config that are not constructor arguments of the algorithm.
RUN_KEYS = ("policy", "n_timesteps", "n_envs", "normalize", "env_kwargs")


def make_env(env_id: str, **env_kwargs):
    """``gym.make`` after importing tactile_gym, so that worker processes know the ids."""
    import gymnasium as gym

    import tactile_gym  # noqa: F401 - registers the envs in this process

    return gym.make(env_id, **env_kwargs)


def load_hyperparameters(algo: str, env_id: str, config_path: Path | None = None) -> dict:
    """The ``default`` entry of the algo's YAML, updated by the env's entry."""
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS}, got {algo!r}")
    path = preset_path("train", config_path or algo)
    table = load_yaml(path)
    if "default" not in table:
        raise ValueError(f"{path} has no 'default' entry")
    config = copy.deepcopy(table["default"])
    config.update(copy.deepcopy(table.get(env_id) or {}))
    return config


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


def train(
    algo: str = "ppo",
    env_id: str = "tactile_gym/HingeProbe-v0",
    n_timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    log_folder: str | Path = "runs",
    config_path: Path | None = None,
    eval_freq: int = 10_000,
    eval_episodes: int = 5,
    checkpoint_freq: int = 50_000,
    progress_bar: bool = False,
    vec_env: str = "subproc",
    device: str = "cpu",
    command: str | None = None,
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
        eval_freq: env steps (summed over envs) between evaluations; 0 disables them.
        eval_episodes: episodes per evaluation.
        checkpoint_freq: env steps (summed over envs) between checkpoints; 0 disables them.
        progress_bar: show a progress bar (needs tqdm and rich).
        vec_env: ``"subproc"`` (one process per env) or ``"dummy"`` (all in this process).
        device: torch device.
        command: the command line to record; defaults to ``sys.argv``.
    """
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import CheckpointCallback, EvalCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

    import tactile_gym

    if env_id not in tactile_gym.ENV_IDS:
        raise ValueError(f"env_id must be one of {tactile_gym.ENV_IDS}, got {env_id!r}")
    if vec_env not in ("subproc", "dummy"):
        raise ValueError(f"vec_env must be 'subproc' or 'dummy', got {vec_env!r}")
    config = load_hyperparameters(algo, env_id, config_path)
    if n_timesteps is not None:
        config["n_timesteps"] = int(n_timesteps)
    if n_envs is not None:
        config["n_envs"] = int(n_envs)
    for key in ("n_timesteps", "n_envs"):
        if not int(config[key]) >= 1:
            raise ValueError(f"{key} must be >= 1, got {config[key]!r}")

    run_dir = make_run_dir(Path(log_folder), algo, env_id, seed)
    record = {
        "algo": algo,
        "env_id": env_id,
        "seed": seed,
        "command": command or shlex.join(sys.argv),
        "arguments": {
            "n_timesteps": n_timesteps,
            "n_envs": n_envs,
            "eval_freq": eval_freq,
            "eval_episodes": eval_episodes,
            "checkpoint_freq": checkpoint_freq,
            "vec_env": vec_env,
            "config_path": str(config_path) if config_path else None,
        },
        "hyperparameters": config,
    }
    with open(run_dir / "config.yml", "w") as f:
        yaml.safe_dump(record, f, sort_keys=False)

    env_kwargs = dict(config.get("env_kwargs") or {})
    vec_cls = SubprocVecEnv if vec_env == "subproc" and config["n_envs"] > 1 else DummyVecEnv
    factory = functools.partial(make_env, env_id, **env_kwargs)
    env = make_vec_env(factory, n_envs=config["n_envs"], seed=seed, vec_env_cls=vec_cls)
    eval_env = make_vec_env(factory, n_envs=1, seed=seed + 10_000)
    if config.get("normalize"):
        env = VecNormalize(env, gamma=config.get("gamma", 0.99))
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False)

    algo_kwargs = {k: v for k, v in config.items() if k not in RUN_KEYS}
    algo_cls = {"ppo": PPO, "sac": SAC}[algo]
    model = algo_cls(
        config["policy"],
        env,
        seed=seed,
        device=device,
        tensorboard_log=str(run_dir / "tensorboard"),
        verbose=0,
        **algo_kwargs,
    )

    callbacks = []
    per_env = max(config["n_envs"], 1)
    if eval_freq > 0:
        callbacks.append(
            EvalCallback(
                eval_env,
                n_eval_episodes=eval_episodes,
                eval_freq=max(eval_freq // per_env, 1),
                best_model_save_path=str(run_dir),
                log_path=str(run_dir / "eval"),
                deterministic=True,
            )
        )
    if checkpoint_freq > 0:
        callbacks.append(
            CheckpointCallback(
                save_freq=max(checkpoint_freq // per_env, 1),
                save_path=str(run_dir / "checkpoints"),
                save_vecnormalize=True,
            )
        )
    try:
        model.learn(
            total_timesteps=int(config["n_timesteps"]),
            callback=callbacks,
            progress_bar=progress_bar,
        )
        model.save(run_dir / "final_model")
        if isinstance(env, VecNormalize):
            env.save(str(run_dir / "vecnormalize.pkl"))
    finally:
        env.close()
        eval_env.close()
    return run_dir


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", choices=ALGOS, default="ppo")
    parser.add_argument("--env", default="tactile_gym/HingeProbe-v0")
    parser.add_argument("--n-timesteps", type=int, default=None)
    parser.add_argument("--n-envs", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--log-folder", default="runs")
    parser.add_argument("--config", type=Path, default=None)
    parser.add_argument("--eval-freq", type=int, default=10_000)
    parser.add_argument("--eval-episodes", type=int, default=5)
    parser.add_argument("--checkpoint-freq", type=int, default=50_000)
    parser.add_argument("--vec-env", choices=("subproc", "dummy"), default="subproc")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--no-progress-bar", action="store_true")
    args = parser.parse_args(argv)
    run_dir = train(
        algo=args.algo,
        env_id=args.env,
        n_timesteps=args.n_timesteps,
        n_envs=args.n_envs,
        seed=args.seed,
        log_folder=args.log_folder,
        config_path=args.config,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        checkpoint_freq=args.checkpoint_freq,
        progress_bar=not args.no_progress_bar,
        vec_env=args.vec_env,
        device=args.device,
        command=shlex.join(["python", "-m", "agents.train", *(argv or sys.argv[1:])]),
    )
    print(f"run saved in {run_dir}")
    return run_dir


if __name__ == "__main__":
    main()
