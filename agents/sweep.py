"""Run a sweep of train + evaluate jobs on Ray and aggregate it across seeds.

    python -m agents.sweep configs/sweeps/smoke.yml               # embedded Ray, this machine
    python -m agents.sweep baseline --address auto                # join a running cluster
    python -m agents.sweep configs/sweeps/baseline.yml --dry-run  # list the jobs

A sweep file (``configs/sweeps/*.yml``) names the env ids (or ``all``), the algorithms, the
seeds, the training budgets, the held-out evaluation (seed, episodes, which model), the
``agents.train`` arguments, hyperparameter overrides by algorithm and ``env_kwargs``. Every
(env id, algo, seed) is one job: ``agents.train`` then ``agents.evaluate`` in one Ray task that
declares ``cpus_per_job`` CPUs (``agents.train`` sizes its vec env and torch threads to them).

Jobs write to ``<log_folder>/<sweep name>/<algo>/<env>_s<seed>/``: ``job.json`` (the job's
settings), ``job.log`` (its output as it goes: env steps and ETA every 30 s), the run
(``config.yml``, models, ``eval/``, TensorBoard logs) and ``evaluation/evaluation.json``. A job
whose folder holds an evaluation made with the same settings is finished and is not run again,
so rerunning a sweep resumes it; a job interrupted after a checkpoint (``checkpoint_freq``)
continues from it (SAC with an empty replay buffer: checkpoints do not keep it). The
hyperparameters and env kwargs are checked before anything starts (``--dry-run`` too). A job
that fails is retried once unless it failed on bad input (a ``ValueError``: it would fail the
same way again), then reported with its error (``error.txt`` in its folder); the sweep goes on
with the others and exits with status 1. The sweep folder gets ``results.md``
and ``results.json`` (:mod:`agents.aggregate`) and ``learning_curve_<env>.png``.

With ``--address`` from a repository checkout, the ``agents`` package is shipped to the
cluster's workers; every node needs ``tactile_gym`` with the ``[train,sweep]`` extras
installed, and on more than one node the log folder must be on a shared filesystem (the
driver reads the runs' folders to resume, to show which jobs run and to aggregate).
"""

from __future__ import annotations

import contextlib
import json
import shutil
import sys
import time
import traceback
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

import tactile_gym
from tactile_gym.presets import load_yaml, preset_path

from .cli import EXPECTED_ERRORS, check_env_id, make_env, make_parser, run_main
from .hyperparams import (
    ALGOS,
    check_hyperparameters,
    load_deadband,
    load_hyperparameters,
    truth_free_env_kwargs,
)
from .runs import latest_checkpoint
from .seeds import TEST_SEED
from .warmstart import load_recipe

SWEEP_KEYS = {
    "name": "folder name of the sweep (default: the file's stem)",
    "log_folder": "parent folder of the sweep folder (default: runs/sweeps)",
    "env_ids": "list of env ids, or 'all' for tactile_gym.ENV_IDS",
    "algos": f"list of algorithms from {ALGOS}",
    "seeds": "list of training seeds, or a count n for 0..n-1",
    "budgets": "env steps: one number, a mapping algo -> number, or null for the train YAML's",
    "evaluation": "mapping: episodes, seed (first held-out seed), model (final_model|best_model)",
    "train": "mapping of agents.train arguments: n_envs, eval_freq, eval_episodes, "
    "checkpoint_freq, config_path, warm_start (keys over the recipe, e.g. {demos: 0}), "
    "truth_free (true: train without the truth), action_deadband",
    "overrides": "mapping algo -> hyperparameters over configs/train/<algo>.yml",
    "env_kwargs": "gym.make keywords for every job",
    "cpus_per_job": "CPUs each job declares to Ray (default 1)",
}
TRAIN_ARGS = (
    "n_envs",
    "eval_freq",
    "eval_episodes",
    "checkpoint_freq",
    "config_path",
    "warm_start",
    "truth_free",
    "action_deadband",
)
EVALUATION_DEFAULTS = {"episodes": 20, "seed": TEST_SEED, "model": "final_model"}
MODELS = ("final_model", "best_model")


@dataclass(frozen=True)
class Job:
    """One train + evaluate run of a sweep."""

    env_id: str
    algo: str
    seed: int
    n_timesteps: int
    hyperparams: dict = field(default_factory=dict)
    env_kwargs: dict = field(default_factory=dict)
    train: dict = field(default_factory=dict)
    evaluation: dict = field(default_factory=dict)
    cpus: float = 1

    @property
    def key(self) -> str:
        """``<algo>/<env name>_s<seed>``: the job's folder inside the sweep folder."""
        return f"{self.algo}/{self.env_id.split('/')[-1]}_s{self.seed}"

    def spec(self) -> dict[str, Any]:
        """The settings that define the job's results (compared when resuming)."""
        return {
            "env_id": self.env_id,
            "algo": self.algo,
            "seed": self.seed,
            "n_timesteps": self.n_timesteps,
            "hyperparams": self.hyperparams,
            "env_kwargs": self.env_kwargs,
            "train": self.train,
            "evaluation": self.evaluation,
        }


def load_sweep(sweep: str | Path | dict) -> dict[str, Any]:
    """A sweep config from a preset name, a YAML path or a mapping, checked, with defaults.

    Raises:
        ValueError: an unknown key or a bad value, naming it and what is allowed.
    """
    if isinstance(sweep, dict):
        config = dict(sweep)
        config.setdefault("name", "sweep")
    else:
        path = preset_path("sweeps", sweep)
        config = load_yaml(path)
        config.setdefault("name", path.stem)
    unknown = sorted(set(config) - set(SWEEP_KEYS))
    if unknown:
        allowed = "\n".join(f"  {k}: {v}" for k, v in SWEEP_KEYS.items())
        raise ValueError(f"unknown sweep keys {unknown}; allowed:\n{allowed}")
    config.setdefault("log_folder", "runs/sweeps")
    env_ids = config.get("env_ids", "all")
    config["env_ids"] = list(tactile_gym.ENV_IDS) if env_ids == "all" else list(env_ids)
    for env_id in config["env_ids"]:
        check_env_id("env_ids: each", env_id)
    config["algos"] = list(config.get("algos") or ["ppo"])
    for algo in config["algos"]:
        if algo not in ALGOS:
            raise ValueError(f"algos: each must be one of {ALGOS}, got {algo!r}")
    seeds = config.get("seeds", 1)
    config["seeds"] = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not config["seeds"] or len(set(config["seeds"])) != len(config["seeds"]):
        raise ValueError(f"seeds must be a count >= 1 or distinct integers, got {seeds!r}")
    budgets = config.get("budgets")
    if isinstance(budgets, dict):
        missing = sorted(set(config["algos"]) - set(budgets))
        if missing:
            raise ValueError(f"budgets has no entry for {missing}; give one per algo or a number")
    elif budgets is not None and not (isinstance(budgets, int) and budgets >= 1):
        raise ValueError(f"budgets must be null, an integer >= 1 or a mapping, got {budgets!r}")
    evaluation = {**EVALUATION_DEFAULTS, **(config.get("evaluation") or {})}
    if set(evaluation) - set(EVALUATION_DEFAULTS):
        raise ValueError(
            f"evaluation keys must be among {sorted(EVALUATION_DEFAULTS)}, got {sorted(evaluation)}"
        )
    if evaluation["model"] not in MODELS:
        raise ValueError(f"evaluation.model must be one of {MODELS}, got {evaluation['model']!r}")
    config["evaluation"] = evaluation
    train = dict(config.get("train") or {})
    if set(train) - set(TRAIN_ARGS):
        raise ValueError(f"train keys must be among {TRAIN_ARGS}, got {sorted(train)}")
    if not isinstance(train.get("truth_free", False), bool):
        raise ValueError(f"train.truth_free must be true or false, got {train['truth_free']!r}")
    config["train"] = train
    overrides = dict(config.get("overrides") or {})
    if set(overrides) - set(ALGOS):
        raise ValueError(f"overrides must be keyed by algo {ALGOS}, got {sorted(overrides)}")
    config["overrides"] = overrides
    config["env_kwargs"] = dict(config.get("env_kwargs") or {})
    config["cpus_per_job"] = config.get("cpus_per_job", 1)
    if not config["cpus_per_job"] > 0:
        raise ValueError(f"cpus_per_job must be > 0, got {config['cpus_per_job']!r}")
    return config


def expand(config: dict[str, Any]) -> list[Job]:
    """The sweep's jobs, env id by algo by seed.

    Each job carries its complete hyperparameters (the training YAML read here, then the
    sweep's overrides), so that workers do not depend on their own copy of the YAML and a
    changed YAML shows up as changed settings when a sweep resumes. The hyperparameters and
    env kwargs are checked here, so that ``--dry-run`` catches a typo before any job starts.

    Raises:
        ValueError: an unknown hyperparameter or env keyword, naming it.
    """
    jobs = []
    config_path = config["train"].get("config_path")
    if config["train"].get("truth_free"):
        truth_free_env_kwargs(config["env_kwargs"])
    for env_id in config["env_ids"]:
        check_env_kwargs(env_id, config["env_kwargs"])
        for algo in config["algos"]:
            hyperparams = load_hyperparameters(algo, env_id, config_path)
            load_deadband(
                preset_path("train", config_path or algo), env_id, config["train"].get(
                    "action_deadband")
            )  # fmt: skip
            hyperparams.update(config["overrides"].get(algo) or {})
            check_hyperparameters(algo, hyperparams)
            if "warm_start" in config["train"]:
                load_recipe(
                    preset_path("train", config_path or algo), env_id, config["train"]["warm_start"]
                )
            budget = config.get("budgets")
            budget = budget.get(algo) if isinstance(budget, dict) else budget
            for seed in config["seeds"]:
                jobs.append(
                    Job(
                        env_id=env_id,
                        algo=algo,
                        seed=seed,
                        n_timesteps=int(budget or hyperparams["n_timesteps"]),
                        hyperparams=dict(hyperparams),
                        env_kwargs=dict(config["env_kwargs"]),
                        train=dict(config["train"]),
                        evaluation=dict(config["evaluation"]),
                        cpus=config["cpus_per_job"],
                    )
                )
    return jobs


def check_env_kwargs(env_id: str, env_kwargs: dict) -> None:
    """Make and close the env once: a bad keyword raises its ``ValueError`` here."""
    make_env(env_id, **env_kwargs).close()


def job_state(job: Job, run_dir: Path) -> str:
    """``"finished"`` (an evaluation made with these settings), ``"conflict"`` (an
    evaluation made with other settings), ``"resume"`` (an interrupted attempt at this job,
    with a checkpoint) or ``"todo"``."""
    try:
        record = json.loads((run_dir / "job.json").read_text())
        json.loads((run_dir / "evaluation" / "evaluation.json").read_text())
    except (OSError, ValueError):
        return "resume" if _same_job(job, run_dir) and latest_checkpoint(run_dir) else "todo"
    return "finished" if record.get("spec") == _jsonable(job.spec()) else "conflict"


def _jsonable(value):
    return json.loads(json.dumps(value))


def run_job(job: Job, run_dir: str, token: str) -> dict:
    """Train and evaluate one job in ``run_dir``; what each Ray task runs.

    A folder left by an interrupted attempt at the same job resumes from its latest
    checkpoint (:func:`agents.runs.latest_checkpoint`); any other is emptied first. The
    output goes to ``job.log`` line by line: a progress line every 30 s while training.

    Returns:
        The evaluation summary of the job's model.
    """
    from .evaluate import evaluate
    from .train import train

    run_dir = Path(run_dir)
    resume = _same_job(job, run_dir) and latest_checkpoint(run_dir) is not None
    if run_dir.exists() and not resume:
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    record = {"spec": job.spec(), "token": token, "started": time.time(), **job.spec()}
    (run_dir / "job.json").write_text(json.dumps(record, indent=1))
    (run_dir / "error.txt").unlink(missing_ok=True)
    train_args = {k: v for k, v in job.train.items() if k != "config_path"}  # in hyperparams
    with (
        open(run_dir / "job.log", "a" if resume else "w", buffering=1) as log,
        contextlib.redirect_stdout(log),
        contextlib.redirect_stderr(log),
    ):
        print(f"job {job.key}: {job.algo} on {job.env_id}, seed {job.seed}", flush=True)
        train(
            algo=job.algo,
            env_id=job.env_id,
            n_timesteps=job.n_timesteps,
            seed=job.seed,
            hyperparams=job.hyperparams,
            env_kwargs=job.env_kwargs,
            n_cpus=max(1, int(job.cpus)),
            run_dir=run_dir,
            command=f"python -m agents.sweep (job {job.key})",
            resume=resume,
            **train_args,
        )
        evaluation = job.evaluation
        print(f"evaluating {evaluation['model']} on {evaluation['episodes']} episodes", flush=True)
        summaries = evaluate(
            [str(run_dir / f"{evaluation['model']}.zip")],
            env_id=job.env_id,
            episodes=int(evaluation["episodes"]),
            seed=int(evaluation["seed"]),
            out=run_dir / "evaluation",
        )
        print("done", flush=True)
    (summary,) = summaries.values()
    return summary


def _same_job(job: Job, run_dir: Path) -> bool:
    try:
        record = json.loads((run_dir / "job.json").read_text())
    except (OSError, ValueError):
        return False
    return record.get("spec") == _jsonable(job.spec())


class Progress:
    """Counts of the sweep's jobs, printed as one line when they change; every ``interval``
    seconds, also each running job's last line of ``job.log`` (its env steps and ETA)."""

    def __init__(self, name: str, total: int, finished: int, interval: float = 30.0, out=None):
        self.name, self.total, self.interval = name, total, interval
        self.counts = {"done": finished, "running": 0, "queued": 0, "failed": 0}
        self.out = out or sys.stdout
        self.start = time.monotonic()
        self._last_line, self._last_time = None, time.monotonic()

    def update(self, jobs: dict[str, Path] | None = None, **counts) -> None:
        """New counts; ``jobs`` maps each running job to its folder."""
        self.counts.update(counts)
        c = self.counts
        line = (
            f"[sweep {self.name}] {c['done']}/{self.total} done, {c['running']} running, "
            f"{c['queued']} queued, {c['failed']} failed"
        )
        now = time.monotonic()
        periodic = now - self._last_time >= self.interval
        if line != self._last_line or periodic:
            elapsed = int(now - self.start)
            print(f"{line} ({elapsed // 60:02d}:{elapsed % 60:02d})", file=self.out, flush=True)
            self._last_line, self._last_time = line, now
            if periodic:
                for key, run_dir in (jobs or {}).items():
                    print(f"  {key}: {_last_line(run_dir / 'job.log')}", file=self.out, flush=True)


def _last_line(path: Path) -> str:
    try:
        lines = path.read_text().strip().splitlines()
    except OSError:
        return "starting"
    return lines[-1] if lines else "starting"


def worth_retrying(error: BaseException) -> bool:
    """Whether a job's error (Ray's wrapper, with the job's own error as ``cause``) may go
    away on a second attempt: bad input (:data:`agents.cli.EXPECTED_ERRORS`) fails the same
    way every time; a worker's death, a full disk or a race may not."""
    cause = getattr(error, "cause", None) or error
    return not isinstance(cause, EXPECTED_ERRORS)


def _error_text(error: BaseException) -> tuple[str, str]:
    """A one-line summary of a job's error and its full text."""
    cause = getattr(error, "cause", None) or error
    lines = str(cause).strip().splitlines() or [""]
    full = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    return f"{type(cause).__name__}: {lines[-1]}", full


@dataclass
class SweepReport:
    """What a sweep did: its folder, the jobs done before and now, the failed ones with
    their errors, and the aggregated markdown."""

    sweep_dir: Path
    skipped: list[str]
    done: list[str]
    failed: dict[str, str]
    markdown: str


def run_sweep(
    sweep: str | Path | dict,
    address: str | None = None,
    num_cpus: int | None = None,
    log_folder: str | Path | None = None,
    retries: int = 1,
    dry_run: bool = False,
    plot: bool = True,
    out=None,
) -> SweepReport:
    """Run the sweep's unfinished jobs on Ray, then aggregate every finished one.

    Args:
        sweep: a preset name, a sweep YAML path or a mapping (see :data:`SWEEP_KEYS`).
        address: a Ray cluster to join; ``None`` starts Ray embedded in this process.
        num_cpus: CPUs of the embedded Ray (default: all of this machine's).
        log_folder: overrides the sweep's ``log_folder``.
        retries: further attempts of a failed job.
        dry_run: list the jobs and their state, run nothing.
        plot: write the learning curves.
        out: where progress goes (default stdout).

    Raises:
        ValueError: finished runs in the sweep folder were made with other settings.
    """
    out = out or sys.stdout
    config = load_sweep(sweep)
    if log_folder is not None:
        config["log_folder"] = str(log_folder)
    sweep_dir = Path(config["log_folder"]) / config["name"]
    jobs = expand(config)
    states = {job.key: job_state(job, sweep_dir / job.key) for job in jobs}
    conflicts = sorted(k for k, s in states.items() if s == "conflict")
    if conflicts:
        raise ValueError(
            f"{sweep_dir} holds finished runs made with other settings: {conflicts}; "
            "give the sweep another name (or log_folder), or delete those runs"
        )
    skipped = [j.key for j in jobs if states[j.key] == "finished"]
    todo = [j for j in jobs if states[j.key] in ("todo", "resume")]
    if dry_run:
        for job in jobs:
            print(f"{states[job.key]:>8}  {job.key}  ({job.n_timesteps} steps)", file=out)
        return SweepReport(sweep_dir, skipped, [], {}, "")
    sweep_dir.mkdir(parents=True, exist_ok=True)
    (sweep_dir / "sweep.yml").write_text(yaml.safe_dump(config, sort_keys=False))

    done, failed = [], {}
    if todo:
        progress = Progress(config["name"], len(jobs), len(skipped), out=out)
        done, failed = _run_jobs(todo, sweep_dir, config, address, num_cpus, retries, progress)
    from .aggregate import write_results

    text = write_results(sweep_dir, plot=plot)
    for key, error in failed.items():
        print(f"FAILED {key}: {error}  (see {sweep_dir / key / 'error.txt'})", file=out)
    print(text, file=out)
    return SweepReport(sweep_dir, skipped, done, failed, text)


def _run_jobs(todo, sweep_dir, config, address, num_cpus, retries, progress):
    from ._ray import ray_session

    out = progress.out
    token = uuid.uuid4().hex
    finished_before = progress.counts["done"]
    done: list[str] = []
    failed: dict[str, str] = {}
    attempts = {job.key: 0 for job in todo}
    with ray_session(address=address, num_cpus=num_cpus) as ray:
        capacity = ray.cluster_resources().get("CPU", 0)
        if config["cpus_per_job"] > capacity:
            raise ValueError(
                f"cpus_per_job is {config['cpus_per_job']} but the Ray cluster has "
                f"{capacity:g} CPUs; lower cpus_per_job or give Ray more CPUs (--num-cpus)"
            )
        task = ray.remote(run_job).options(num_cpus=config["cpus_per_job"], max_retries=0)

        def submit(job):
            attempts[job.key] += 1
            return task.remote(job, str(sweep_dir / job.key), token)

        pending = {submit(job): job for job in todo}
        try:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
                for ref in ready:
                    job = pending.pop(ref)
                    try:
                        ray.get(ref)
                        done.append(job.key)
                    except Exception as error:  # a job's own error, or its worker's death
                        line, full = _error_text(error)
                        if attempts[job.key] <= retries and worth_retrying(error):
                            print(f"job {job.key} failed ({line}); retrying", file=out)
                            pending[submit(job)] = job
                        else:
                            failed[job.key] = line
                            run_dir = sweep_dir / job.key
                            run_dir.mkdir(parents=True, exist_ok=True)
                            (run_dir / "error.txt").write_text(full)
                running = {
                    j.key: sweep_dir / j.key
                    for j in pending.values()
                    if _started(sweep_dir / j.key, token)
                }
                progress.update(
                    running,  # the jobs
                    done=finished_before + len(done),
                    running=len(running),
                    queued=len(pending) - len(running),
                    failed=len(failed),
                )
        except KeyboardInterrupt:
            print(
                f"interrupted: {len(done)} jobs done, {len(pending)} unfinished; "
                "run the same command again to resume",
                file=out,
            )
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
    return done, failed


def _started(run_dir: Path, token: str) -> bool:
    try:
        return json.loads((run_dir / "job.json").read_text()).get("token") == token
    except (OSError, ValueError):
        return False


def main(argv: list[str] | None = None) -> int:
    parser = make_parser(__spec__.name if __spec__ else "agents.sweep", __doc__)
    parser.add_argument(
        "sweep",
        help="a sweep YAML path or the name of one in configs/sweeps/ (e.g. smoke)",
    )
    parser.add_argument(
        "--address",
        default=None,
        help="a Ray cluster to join (auto or host:port); default: an embedded Ray",
    )
    parser.add_argument(
        "--num-cpus",
        type=int,
        default=None,
        help="CPUs of the embedded Ray; default: all of this machine's",
    )
    parser.add_argument(
        "--log-folder", default=None, help="parent of the sweep folder; default: the file's"
    )
    parser.add_argument(
        "--retries",
        type=int,
        default=1,
        help="further attempts of a job that failed for another reason than bad input",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="check the file and list the jobs with their state; run nothing (no Ray needed)",
    )
    args = parser.parse_args(argv)
    report = run_sweep(
        args.sweep,
        address=args.address,
        num_cpus=args.num_cpus,
        log_folder=args.log_folder,
        retries=args.retries,
        dry_run=args.dry_run,
    )
    return 1 if report.failed else 0


if __name__ == "__main__":
    sys.exit(run_main(main))
