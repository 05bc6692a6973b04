"""Train a stable-baselines3 agent on a tactile_gym env.

    python -m agents.train --algo ppo --env tactile_gym/HingeProbe-v1
    python -m agents.train --algo sac --n-timesteps 20000 --env-kwargs observation_mode:flat \
        --hyperparams policy:MlpPolicy

Hyperparameters come from ``configs/train/<algo>.yml``, in rl-baselines3-zoo's format
(``agents.hyperparams``): the ``default`` entry updated by the env's own entry, then by
``--hyperparams``, ``--env-kwargs``, ``--n-timesteps`` and ``--n-envs``. Each run gets its own
folder under ``--log-folder`` (``agents.runs``) holding the resolved config, the arguments and
the command line (``config.yml``), TensorBoard logs, the periodic evaluations
(``eval/evaluations.npz``), checkpoints, the best model found by the periodic evaluation
(``best_model.zip``), the final model (``final_model.zip``) and, with normalisation, the
``VecNormalize`` statistics saved with each model as JSON (``agents.runs.statistics_path``).

A run is a few named steps over one :class:`Trainer`, as rl-baselines3-zoo's
``ExperimentManager`` is: :meth:`~Trainer.setup` (the envs, the run folder, the model),
:meth:`~Trainer.warm_start`, :meth:`~Trainer.learn` and :meth:`~Trainer.save`. The
hyperparameters are checked against the algorithm's constructor and the envs are made before
the run folder is: a typo fails at once and leaves nothing behind. A run that fails later
leaves no folder if it saved no model, else a ``failed.txt`` saying why; an interrupted run
with checkpoints can continue from the latest (``train(..., run_dir=..., resume=True)``, what
``agents.sweep`` does).

The envs run as the package's vector env (``gym.make_vec``, ``docs/design.md`` 7.9, through
:mod:`agents.vec_env`), in this process or in worker processes as
``agents.resources.choose_env_workers`` decides from the id and the cores; ``--env-workers``
and ``--vec-env`` override that.
"""

from __future__ import annotations

import contextlib
import functools
import shlex
import shutil
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tactile_gym.presets import preset_path
from tactile_gym.validation import check_int

from .cli import (
    DEFAULT_ENV_ID,
    KEY_VALUE_HELP,
    KNOWN_ENV_IDS,
    KeyValue,
    check_env_id,
    make_env,
    make_parser,
    require,
    run_main,
)
from .hyperparams import (
    ALGOS,
    algo_kwargs,
    algorithm_class,
    load_deadband,
    resolve_config,
    truth_free_env_kwargs,
)
from .progress import clock, progress_lines
from .resources import DEFAULT_TORCH_THREADS, available_cpus, choose_env_workers, torch_threads
from .runs import (
    latest_checkpoint,
    load_model,
    load_statistics,
    make_run_dir,
    read_run,
    save_statistics,
    statistics_path,
)
from .seeds import DEMO_SEED, SELECTION_SEED, seed_ranges
from .warmstart import load_recipe, run_recipe

__all__ = ["TrainArgs", "Trainer", "train"]

VEC_ENVS = ("vector", "dummy", "subproc")


@dataclass(frozen=True)
class TrainArgs:
    """The arguments of a run: :func:`train`'s keywords, ``python -m agents.train``'s options.

    Attributes:
        algo: one of ``agents.hyperparams.ALGOS``: ``"ppo"``, ``"sac"``, ``"recurrent_ppo"``
            (sb3-contrib's RecurrentPPO, an LSTM policy) or ``"tqc"`` (sb3-contrib's TQC).
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
            ``SELECTION_SEED ..`` (``agents.seeds``, ``agents.callbacks``).
        checkpoint_freq: env steps (summed over envs) between checkpoints; 0 disables them.
        progress_bar: show a progress bar (needs tqdm and rich); without it, a line every
            30 s (``agents.progress``).
        vec_env: ``"vector"`` (the package's vector env), ``"subproc"`` (SB3's, one process
            per env) or ``"dummy"`` (SB3's loop over single envs in this process).
        env_workers: with ``"vector"``, how many processes step the sub-envs (1: this
            process); defaults to ``agents.resources.choose_env_workers``'s choice.
        n_cpus: cores the run may use; defaults to this process's CPU affinity.
        n_threads: torch threads; defaults to ``DEFAULT_TORCH_THREADS``.
        device: torch device.
        run_dir: the run folder to use (created if absent; it must not hold a run already)
            instead of a fresh one under ``log_folder``.
        command: the command line to record; defaults to ``sys.argv``.
        resume: with a ``run_dir`` that holds an interrupted run, continue it from its
            latest checkpoint (``agents.runs.latest_checkpoint``) instead of refusing.
        warm_start: keys over the config's ``warm_start`` recipe for the id
            (``agents.warmstart.WarmStart``): with demonstrations, the model starts from a
            policy cloned from them and a critic fitted to their returns.
        truth_free: train without the truth: the ``task`` of
            ``agents.hyperparams.TRUTH_FREE_TASK`` (the reward scores the estimator's
            predicted error, the workspace is centred on the start pose), and the envs' infos
            stripped of the truth (``agents.callbacks.WithoutTruth``), so that the periodic
            selection ranks by the truth-free return and nothing of the loop reads the truth.
        action_deadband: execute action components smaller than this in magnitude as 0, in
            training and whenever the model acts (``agents.policies.deadband``); None: the
            config's ``action_deadband`` table for the id (``agents.hyperparams``), else 0.
    """

    algo: str = "ppo"
    env_id: str = DEFAULT_ENV_ID
    n_timesteps: int | None = None
    n_envs: int | None = None
    seed: int = 0
    log_folder: str | Path = "runs"
    config_path: str | Path | None = None
    hyperparams: Mapping[str, Any] | None = None
    env_kwargs: Mapping[str, Any] | None = None
    eval_freq: int = 10_000
    eval_episodes: int = 20
    checkpoint_freq: int = 50_000
    progress_bar: bool = False
    vec_env: str = "vector"
    env_workers: int | None = None
    n_cpus: int | None = None
    n_threads: int | None = None
    device: str = "cpu"
    run_dir: str | Path | None = None
    command: str | None = None
    resume: bool = False
    warm_start: Mapping[str, Any] | None = None
    truth_free: bool = False
    action_deadband: float | None = None


class Trainer:
    """One training run as named steps over its state, as rl-baselines3-zoo's
    ``ExperimentManager`` (module docstring): :meth:`run` calls :meth:`setup`,
    :meth:`warm_start`, :meth:`learn` and :meth:`save`, and cleans up after a failure.

    Making a trainer checks the arguments and resolves the config; nothing is made yet.

    Raises:
        ValueError: a bad argument, hyperparameter or recipe, naming it.
    """

    def __init__(self, args: TrainArgs) -> None:
        require("stable_baselines3", "train")
        check_env_id("env_id", args.env_id)
        if args.vec_env not in VEC_ENVS:
            raise ValueError(f"vec_env must be one of {VEC_ENVS}, got {args.vec_env!r}")
        self.args = args
        self.config = resolve_config(
            args.algo, args.env_id, args.config_path, args.hyperparams, args.env_kwargs,
            args.n_timesteps, args.n_envs,
        )  # fmt: skip
        if args.truth_free:
            self.config["env_kwargs"] = truth_free_env_kwargs(self.config.get("env_kwargs"))
        self.n_envs = int(self.config["n_envs"])
        self.total_steps = int(self.config["n_timesteps"])
        self.n_cpus = int(args.n_cpus or available_cpus())
        if self.n_cpus < 1:
            raise ValueError(f"n_cpus must be >= 1, got {self.n_cpus}")
        self.workers = None
        if args.vec_env == "vector":
            workers = args.env_workers
            if workers is None:
                workers = choose_env_workers(args.env_id, self.n_envs, self.n_cpus)
            self.workers = check_int("env_workers", workers, 1, self.n_envs)
        elif args.env_workers is not None:
            raise ValueError(f"env_workers needs vec_env 'vector', got vec_env {args.vec_env!r}")
        self.n_threads = int(args.n_threads or DEFAULT_TORCH_THREADS)
        config_file = preset_path("train", args.config_path or args.algo)
        self.recipe = load_recipe(config_file, args.env_id, args.warm_start)
        self.deadband = load_deadband(config_file, args.env_id, args.action_deadband)
        self.env_kwargs = dict(self.config.get("env_kwargs") or {})
        self.selection_seeds = list(
            range(SELECTION_SEED, SELECTION_SEED + max(args.eval_episodes, 1))
        )
        self.env = self.eval_env = self.evaluation = None
        self.run_dir: Path | None = None
        self.created = False
        self.checkpoint: Path | None = None
        self.callbacks: list = []
        self.start = time.monotonic()

    def run(self) -> Path:
        """The whole run; returns its folder. A run that fails leaves no folder if it made
        no model, else a ``failed.txt`` in it."""
        try:
            with torch_threads(self.n_threads):
                model = self.setup()
                self.warm_start(model)
                self.learn(model)
            return self.save(model)
        except BaseException as error:
            if self.run_dir is not None:
                _mark_failed(self.run_dir, self.created, error)
            raise
        finally:
            for env in (self.env, self.eval_env):
                if env is not None:
                    env.close()

    # ----------------------------------------------------------------------------- steps
    def setup(self):
        """The envs (a bad env keyword fails here, before a run folder exists), the run
        folder with its ``config.yml``, the normalisation, the callbacks, and the model: a
        new one, or the interrupted run's latest checkpoint with its statistics."""
        from .callbacks import FixedSeedVecEnv

        self.eval_env = FixedSeedVecEnv(self._make_envs(1, SELECTION_SEED), self.selection_seeds)
        self.env = self._make_envs(self.n_envs, self.args.seed)
        self._open_run_dir()
        with open(self.run_dir / "config.yml", "w") as f:
            yaml.safe_dump(self._record(), f, sort_keys=False)
        self._normalize()
        self.callbacks = self._callbacks()
        if self.checkpoint is not None:
            model = load_model(self.checkpoint, self.env, device=self.args.device, attach=True)
            print(f"resuming from {self.checkpoint} at {model.num_timesteps} env steps", flush=True)
            return model
        return self._construct()

    def warm_start(self, model) -> None:
        """A new model starts from the recipe's demonstrations (``agents.warmstart``); a
        resumed run, or a recipe without demonstrations, starts as it is. A recipe with
        ``anchor_epochs`` adds the demonstrations' anchor to the callbacks
        (``agents.callbacks.DemoAnchor``)."""
        if self.recipe.enabled and self.checkpoint is None:
            run_recipe(
                model, self.recipe, self.args.env_id, self.env_kwargs, self.args.seed, self.run_dir
            )
        if self.recipe.enabled and self.recipe.anchor_epochs:
            from .callbacks import DemoAnchor
            from .demonstrations import load_demos

            # The run's own recording (a resumed run's too), or the recipe's file.
            recorded = isinstance(self.recipe.demos, int)
            demos = load_demos(self.run_dir / "demos.npz" if recorded else self.recipe.demos)
            self.callbacks.append(DemoAnchor(demos, self.recipe, self.args.seed))

    def learn(self, model) -> None:
        """Learn up to the run's env steps (those of a resumed run included)."""
        model.learn(
            total_timesteps=self.total_steps - model.num_timesteps,
            callback=self.callbacks,
            progress_bar=self.args.progress_bar,
            reset_num_timesteps=self.checkpoint is None,
        )

    def save(self, model) -> Path:
        """The final model and its statistics; prints what the run made. Returns the run
        folder."""
        from stable_baselines3.common.vec_env import VecNormalize

        model.save(self.run_dir / "final_model")
        if isinstance(self.env, VecNormalize):
            save_statistics(self.env, statistics_path(self.run_dir / "final_model.zip"))
        print(self.summary(model), flush=True)
        return self.run_dir

    # --------------------------------------------------------------------------- helpers
    def _make_envs(self, n: int, first_seed: int):
        """``n`` envs seeded ``first_seed + i``; the training and the evaluation envs are
        wrapped alike, as SB3's syncing of normalisation statistics requires."""
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

        from .callbacks import ActionDeadband, WithoutTruth
        from .vec_env import make_sb3_vec_env

        if self.args.vec_env == "vector":
            # VecMonitor keeps the episode records that one Monitor per env would.
            envs = VecMonitor(
                make_sb3_vec_env(self.args.env_id, n, min(self.workers, n), **self.env_kwargs)
            )
            envs.seed(first_seed)
        else:
            factory = functools.partial(make_env, self.args.env_id, **self.env_kwargs)
            vec_cls = SubprocVecEnv if self.args.vec_env == "subproc" and n > 1 else DummyVecEnv
            envs = make_vec_env(factory, n_envs=n, seed=first_seed, vec_env_cls=vec_cls)
        if self.deadband:
            envs = ActionDeadband(envs, self.deadband)
        return WithoutTruth(envs) if self.args.truth_free else envs

    def _open_run_dir(self) -> None:
        """A fresh folder under ``log_folder``, or ``run_dir``: refused if it holds a run,
        unless resuming one that has a checkpoint."""
        args = self.args
        if args.run_dir is None:
            self.created = True
            self.run_dir = make_run_dir(Path(args.log_folder), args.algo, args.env_id, args.seed)
            return
        run_dir = Path(args.run_dir)
        created = not run_dir.exists()
        if (run_dir / "config.yml").exists():
            self.checkpoint = latest_checkpoint(run_dir) if args.resume else None
            if self.checkpoint is None:
                raise ValueError(f"run_dir {str(run_dir)!r} already holds a run (config.yml)")
        run_dir.mkdir(parents=True, exist_ok=True)
        self.run_dir, self.created = run_dir, created
        if self.checkpoint is not None:
            (run_dir / "failed.txt").unlink(missing_ok=True)

    def _record(self) -> dict[str, Any]:
        """What ``config.yml`` says: the run's arguments, resources, config and seeds."""
        args = self.args
        arguments = {
            "n_timesteps": args.n_timesteps,
            "n_envs": self.n_envs,
            "hyperparams": dict(args.hyperparams or {}),
            "env_kwargs": dict(args.env_kwargs or {}),
            "eval_freq": args.eval_freq,
            "eval_episodes": args.eval_episodes,
            "checkpoint_freq": args.checkpoint_freq,
            "vec_env": args.vec_env,
            "config_path": str(args.config_path) if args.config_path else None,
        }
        record = {
            "algo": args.algo,
            "env_id": args.env_id,
            "seed": args.seed,
            "truth_free": args.truth_free,
            "action_deadband": self.deadband,
            "command": args.command or shlex.join(sys.argv),
            "arguments": arguments,
            "resources": {
                "n_cpus": self.n_cpus,
                "vec_env": args.vec_env,
                "env_workers": self.workers,
                "torch_threads": self.n_threads,
            },
            "hyperparameters": self.config,
            "warm_start": self.recipe.as_dict(),
            "seeds": {
                **seed_ranges(),
                "training": [args.seed, args.seed + self.n_envs - 1],
                "selection": [self.selection_seeds[0], self.selection_seeds[-1]],
            },
        }
        if self.recipe.enabled and isinstance(self.recipe.demos, int):
            record["seeds"]["demonstrations"] = [DEMO_SEED, DEMO_SEED + self.recipe.demos - 1]
        if self.checkpoint is not None:
            record["resumed_from"] = self.checkpoint.relative_to(self.run_dir).as_posix()
        return record

    def _normalize(self) -> None:
        """``VecNormalize`` around the envs where the config asks for it: the training env's
        fresh, or a resumed run's from its checkpoint's statistics; the evaluation env's
        follow them (SB3 syncs them at each evaluation) and leave rewards alone."""
        from stable_baselines3.common.vec_env import VecNormalize

        normalize = self.config.get("normalize", False)
        if not normalize:
            return
        kwargs = normalize if isinstance(normalize, dict) else {}
        kwargs = {"gamma": self.config.get("gamma", 0.99), **kwargs}
        if self.checkpoint is not None:
            training = not (self.recipe.enabled and self.recipe.freeze_statistics)
            self.env = load_statistics(read_run(self.checkpoint), self.env, training=training)
        else:
            self.env = VecNormalize(self.env, **kwargs)
        eval_kwargs = {k: v for k, v in kwargs.items() if k != "norm_reward"}
        self.eval_env = VecNormalize(
            self.eval_env, training=False, norm_reward=False, **eval_kwargs
        )

    def _callbacks(self) -> list:
        """Progress lines (without a progress bar), the fixed-seed evaluation that saves the
        best model with its statistics, and checkpoints with theirs."""
        from .callbacks import Checkpoints, continue_evaluations, fixed_seed_evaluation

        args = self.args
        callbacks = [] if args.progress_bar else [progress_lines(self.total_steps)]
        if args.eval_freq > 0:
            normalize = self.config.get("normalize", False)
            self.evaluation = fixed_seed_evaluation(
                self.eval_env,
                args.eval_episodes,
                max(min(args.eval_freq, self.total_steps) // self.n_envs, 1),
                self.run_dir,
                statistics_path(self.run_dir / "best_model.zip") if normalize else None,
            )
            if self.checkpoint is not None:
                continue_evaluations(self.evaluation, self.run_dir / "eval" / "evaluations.npz")
            callbacks.append(self.evaluation)
        if args.checkpoint_freq > 0:
            callbacks.append(
                Checkpoints(
                    max(args.checkpoint_freq // self.n_envs, 1), self.run_dir / "checkpoints"
                )
            )
        return callbacks

    def _construct(self):
        """The algorithm built from the config; a value it rejects is a ``ValueError``
        naming the hyperparameters (stable-baselines3 checks values with ``assert`` and by
        using them)."""
        args, config = self.args, self.config
        kwargs = algo_kwargs(config)
        try:
            return algorithm_class(args.algo)(
                config["policy"],
                self.env,
                seed=args.seed,
                device=args.device,
                tensorboard_log=str(self.run_dir / "tensorboard"),
                verbose=0,
                **kwargs,
            )
        except (TypeError, AssertionError, KeyError) as error:
            shown = {k: config[k] for k in kwargs}
            raise ValueError(
                f"{args.algo} rejected policy {config['policy']!r} with the hyperparameters "
                f"{shown}: {error}"
            ) from error

    def summary(self, model) -> str:
        """What the run made, in a few lines: steps and time, the best model's evaluation,
        the files."""
        args = self.args
        lines = [
            f"trained {args.algo} on {args.env_id} (seed {args.seed}): "
            f"{model.num_timesteps} env steps in {clock(time.monotonic() - self.start)}"
        ]
        evaluation = self.evaluation
        if evaluation is not None and evaluation.evaluations_results:
            means = [sum(r) / len(r) for r in evaluation.evaluations_results]
            best = max(range(len(means)), key=means.__getitem__)
            lines.append(
                f"  best_model.zip: mean reward {means[best]:.3f} on the {args.eval_episodes} "
                f"selection episodes, at {evaluation.evaluations_timesteps[best]} env steps "
                f"(best of {len(means)} evaluations)"
            )
        statistics = statistics_path(self.run_dir / "final_model.zip")
        with_statistics = f", with {statistics.name}" if statistics.exists() else ""
        lines.append(f"  final_model.zip: at {model.num_timesteps} env steps{with_statistics}")
        lines.append(f"run saved in {self.run_dir}")
        return "\n".join(lines)


def train(*args: Any, **kwargs: Any) -> Path:
    """Train one agent and return its run folder: ``Trainer(TrainArgs(...)).run()``.

    Args:
        *args: the first fields of :class:`TrainArgs`, in order (``algo``, ``env_id``, ...).
        **kwargs: its fields by name.

    Raises:
        ValueError: a bad argument, hyperparameter, recipe or env keyword, before a run
            folder exists.
    """
    return Trainer(TrainArgs(*args, **kwargs)).run()


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
        "--truth-free",
        action="store_true",
        help="train without the truth: the reward scores the estimator's predicted error, the "
        "workspace is centred on the start pose, the infos lose the truth, so selection ranks "
        "by the truth-free return (agents.hyperparams.TRUTH_FREE_TASK)",
    )
    parser.add_argument(
        "--action-deadband",
        type=float,
        default=None,
        help="action components smaller than this act as 0, in training and after "
        "(agents.policies.deadband); default: the config's action_deadband table, else 0",
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
    return train(
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
        truth_free=args.truth_free,
        action_deadband=args.action_deadband,
        command=shlex.join(["python", "-m", parser.prog.split()[-1], *(argv or sys.argv[1:])]),
    )


if __name__ == "__main__":
    sys.exit(run_main(main))
