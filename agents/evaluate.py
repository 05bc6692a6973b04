"""Evaluate policies on a tactile_gym env over seeded episodes.

    python -m agents.evaluate --policies random scripted --episodes 20
    python -m agents.evaluate --policies scripted runs/ppo/HingeProbe-v1_s0_.../best_model.zip
    python -m agents.evaluate --policies scripted --episodes 1000 --workers 8     # on Ray

A policy is ``random``, ``scripted`` or the path of a stable-baselines3 model saved by
``agents.train`` or by ``rl_zoo3.train``. A model runs on an env made with its run's
``env_kwargs`` (from the run's ``config.yml``, or rl_zoo3's ``args.yml``, updated by
``--env-kwargs``) and with the ``VecNormalize`` statistics saved with that model
(``agents.train.vecnormalize_path``; rl_zoo3 keeps its final model's in
``<env>/vecnormalize.pkl``, and none for its ``best_model``). Episode k of every policy uses seed
``seed + k`` for the env and the action space, so all policies meet the same objects and
every episode depends on its seed alone: ``--workers`` spreads episodes over Ray workers with
the same results as a serial run. The script prints a markdown table and writes
``evaluation.json`` (strict JSON: NaN is written as ``null``) and ``error_vs_step.png`` to
``--out``. The seeds default to the test range, which no training or selection step uses
(``agents.seeds``); with ``scripted`` among the policies the script also prints each other
policy's paired difference from it with a bootstrap interval (``agents.compare``).

A model runs only on the id it was trained on (a primitive model also on its 6-D id, whose
steps its primitives then drive) unless ``--force``; without a run config beside it, its
algorithm comes from its zip, and an env whose spaces differ from the model's is refused.
"""

from __future__ import annotations

import contextlib
import json
import math
import sys
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

from tactile_gym.envs.hinge_probe_primitive import PRIMITIVE_KEYWORDS
from tactile_gym.envs.skills import PrimitiveExecutor

from .cli import (
    KEY_VALUE_HELP,
    KNOWN_ENV_IDS,
    KeyValue,
    check_env_id,
    make_parser,
    progress_bar,
    run_main,
)
from .compare import REFERENCE, paired_table
from .plots import plot_errors
from .scripted import scripted_policy
from .seeds import TEST_SEED
from .train import DEFAULT_ENV_ID, algorithm_class, make_env, torch_threads, vecnormalize_path

#: Position error reported while there is no estimate, m (the task's E_max).
NO_ESTIMATE_ERROR = 0.1
#: The "steps to reach" threshold of the table, m.
REACH_THRESHOLD = 0.005
BUILTIN_POLICIES = ("random", "scripted")


class RandomPolicy:
    """Uniform random actions from the env's action space (seeded by ``run_episode``)."""

    def __init__(self, env: gym.Env) -> None:
        self.action_space = env.action_space

    def reset(self) -> None:
        pass

    def get_action(self, obs) -> np.ndarray:
        return self.action_space.sample()


class ModelPolicy:
    """A stable-baselines3 model saved by ``agents.train``, with its own observation scaling.

    Raises:
        ValueError: the run normalised observations but the statistics saved with this model
            are missing (another model's statistics would scale its inputs wrongly).
    """

    def __init__(self, path: str | Path, env: gym.Env) -> None:
        from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

        path = Path(path)
        run = model_run(path)
        self.model = algorithm_class(run["algo"]).load(path, device="cpu")
        env_id = env.spec.id if env.spec else "this env"
        for kind in ("observation", "action"):
            trained, given = getattr(self.model, f"{kind}_space"), getattr(env, f"{kind}_space")
            if trained != given:
                raise ValueError(
                    f"{path} was trained on {run['env_id'] or 'another id'}, whose {kind} "
                    f"space differs from {env_id}'s ({_space_text(trained)} against "
                    f"{_space_text(given)}); evaluate it on the id and env kwargs it was "
                    "trained with"
                )
        self.normalizer = None
        stats = run["vecnormalize"]
        if stats.exists():
            self.normalizer = VecNormalize.load(str(stats), DummyVecEnv([lambda: env]))
            self.normalizer.training = False
        elif run["normalize"]:
            raise ValueError(
                f"{path} was trained with VecNormalize but its statistics {stats} are missing; "
                "evaluate a model saved with its statistics (final_model, checkpoints, or a "
                "best_model from a run of this version)"
            )

    def reset(self) -> None:
        pass

    def get_action(self, obs) -> np.ndarray:
        if self.normalizer is not None:
            obs = self.normalizer.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=True)
        return action


class PrimitiveModelPolicy:
    """A model learned on a primitive id, driving the matching 6-D id: it chooses primitives
    and the same probing skills carry them out, one control step at a time (hierarchical).

    Args:
        path: the model, from a run on a ``...Primitive-v1`` id.
        env: the 6-D env to act on (dict observations).
    """

    def __init__(self, path: str | Path, env: gym.Env) -> None:
        run = model_run(Path(path))
        primitive_env = gym.make(run["env_id"], **run["env_kwargs"])
        self.inner = ModelPolicy(path, primitive_env)
        self.space = primitive_env.get_wrapper_attr("dict_observation_space")
        self.flat = primitive_env.unwrapped.control_env.config.observation_mode == "flat"
        primitive_env.close()
        self.executor = PrimitiveExecutor.for_env(env.unwrapped)

    def reset(self) -> None:
        self.executor.reset()

    def get_action(self, obs: dict) -> np.ndarray:
        action = self.executor.act(obs)
        while action is None:
            view = {**obs, "primitive": self.executor.summary.astype(np.float32)}
            if self.flat:
                view = gym.spaces.flatten(self.space, view)
            self.executor.start(self.inner.get_action(view), obs)
            action = self.executor.act(obs)
        return action.astype(np.float32)


def _space_text(space: gym.Space) -> str:
    """A space in a few words: its shape, or a Dict's keys and shapes."""
    if isinstance(space, gym.spaces.Dict):
        return "{" + ", ".join(f"{k}: {v.shape}" for k, v in space.spaces.items()) + "}"
    return f"{type(space).__name__}{space.shape}"


def is_primitive_model_on_6d(name: str, env_id: str) -> bool:
    """Whether a model learned on a primitive id is to act on its 6-D id (the same task
    with 6-D actions: ``HingeProbePrimitive-v1`` drives ``HingeProbe-v1``)."""
    trained_on = _run_record(Path(name))["env_id"] or ""
    return "Primitive" in trained_on and trained_on.replace("Primitive", "") == env_id


def check_model_env(name: str, trained_on: str | None, env_id: str, force: bool) -> None:
    """Refuse a model on an id other than the one it was trained on (or, for a primitive
    model, its 6-D id), naming both; ``force`` turns that into a warning on stderr.

    Raises:
        ValueError: the ids differ and ``force`` is false.
    """
    if trained_on is None or trained_on == env_id or is_primitive_model_on_6d(name, env_id):
        return
    allowed = [trained_on]
    if "Primitive" in trained_on:
        allowed.append(trained_on.replace("Primitive", ""))
    message = (
        f"{name} was trained on {trained_on}, not {env_id}; evaluate it on "
        f"{' or '.join(allowed)} (--env), or pass --force to run it on {env_id} anyway"
    )
    if not force:
        raise ValueError(message)
    print(f"warning: {message.split(';')[0]} (--force)", file=sys.stderr)


@dataclass
class EpisodeRecord:
    seed: int
    position_error: list[float]
    angle_error: list[float]
    success: bool
    n_measurements: int
    terminated: bool


@dataclass(frozen=True)
class PolicySpec:
    """Everything needed to rebuild a policy and its env, in this process or a worker.

    Attributes:
        label: the unique name in tables, plots and JSON.
        name: ``random``, ``scripted`` or a model path.
        env_id: the env to run on.
        env_kwargs: ``gym.make`` keywords.
    """

    label: str
    name: str
    env_id: str
    env_kwargs: dict = field(default_factory=dict)


def _load_zoo_yaml(path: Path) -> dict:
    """rl_zoo3's ``args.yml``/``config.yml``: an ``OrderedDict`` dumped with its Python tag."""

    class Loader(yaml.SafeLoader):
        pass

    def ordered_dict(loader, node):
        (pairs,) = loader.construct_sequence(node, deep=True)
        return dict(pairs)

    Loader.add_constructor(
        "tag:yaml.org,2002:python/object/apply:collections.OrderedDict", ordered_dict
    )
    return yaml.load(path.read_text(), Loader=Loader) or {}


def model_run(path: Path) -> dict[str, Any]:
    """What a model's run folder says about it: ``run_dir``, ``algo``, ``env_id``,
    ``env_kwargs``, ``normalize`` and the ``vecnormalize`` statistics saved with the model.

    Reads ``agents.train``'s ``config.yml``, or an rl_zoo3 run (``<env>.zip`` beside the
    ``<env>/`` folder of ``args.yml``, ``config.yml`` and ``vecnormalize.pkl``); with neither,
    the env id is unknown (``None``), there are no env kwargs and no normalisation, and the
    algorithm is the one the model's zip names (:func:`saved_algo`).
    """
    path = Path(path)
    run = _run_record(path)
    return {**run, "algo": run["algo"] or saved_algo(path)}


def saved_algo(path: Path) -> str:
    """The algorithm of a stable-baselines3 model, from the policy class its zip stores.

    Raises:
        ValueError: the file is not a stable-baselines3 model of PPO or SAC.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
        module = data["policy_class"]["__module__"]
    except (OSError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as error:
        raise ValueError(f"{str(path)!r} is not a stable-baselines3 model ({error})") from error
    if module.startswith("stable_baselines3.sac."):
        return "sac"
    if module in ("stable_baselines3.common.policies", "stable_baselines3.ppo.policies"):
        return "ppo"
    raise ValueError(
        f"{str(path)!r} holds a policy of {module}; agents.evaluate runs PPO and SAC models"
    )


def _run_record(path: Path) -> dict[str, Any]:
    """What the run folder says (``algo`` ``None`` without a run config); the model's file
    is not opened."""
    run_dir = path.parent.parent if path.parent.name == "checkpoints" else path.parent
    zoo = [d for d in run_dir.iterdir() if (d / "args.yml").is_file()] if run_dir.is_dir() else []
    if (run_dir / "config.yml").exists() or len(zoo) != 1:
        config_file = run_dir / "config.yml"
        record = yaml.safe_load(config_file.read_text()) if config_file.exists() else {}
        hyper = record.get("hyperparameters") or {}
        return {
            "run_dir": run_dir,
            "algo": record.get("algo"),
            "env_id": record.get("env_id"),
            "env_kwargs": dict(hyper.get("env_kwargs") or {}),
            "normalize": bool(hyper.get("normalize", False)),
            "vecnormalize": vecnormalize_path(path),
        }
    (params,) = zoo
    args = _load_zoo_yaml(params / "args.yml")
    hyper = _load_zoo_yaml(params / "config.yml") if (params / "config.yml").exists() else {}
    final = path.stem == params.name
    return {
        "run_dir": run_dir,
        "algo": args.get("algo"),
        "env_id": args.get("env"),
        "env_kwargs": dict(args.get("env_kwargs") or hyper.get("env_kwargs") or {}),
        "normalize": bool(hyper.get("normalize", False)),
        "vecnormalize": params / "vecnormalize.pkl" if final else vecnormalize_path(path),
    }


def policy_labels(names: list[str]) -> list[str]:
    """Unique labels: a built-in policy's name, or a model's run folder and file stem
    (``HingeProbe-v1_s0_.../final_model``), with more parent folders where two would clash.

    Raises:
        ValueError: the same policy is listed twice.
    """
    resolved = [str(Path(n).resolve()) if n not in BUILTIN_POLICIES else n for n in names]
    repeated = sorted({n for n in resolved if resolved.count(n) > 1})
    if repeated:
        raise ValueError(f"each policy may be listed once, got {repeated} more than once")

    def label(name: str, depth: int) -> str:
        if name in BUILTIN_POLICIES:
            return name
        path = Path(name)
        run_dir = _run_record(path)["run_dir"]
        inner = path.relative_to(run_dir).with_suffix("").as_posix()
        parents = run_dir.resolve().parts[-depth:]
        return "/".join([*parents, inner])

    depths = [1] * len(names)
    while True:
        labels = [label(n, d) for n, d in zip(names, depths)]
        clashes = {x for x in labels if labels.count(x) > 1}
        if not clashes:
            return labels
        grown = False
        for i, x in enumerate(labels):
            if x in clashes and depths[i] < len(Path(names[i]).resolve().parts):
                depths[i] += 1
                grown = True
        if not grown:
            raise ValueError(f"cannot give the policies unique labels: {labels}")


def resolve_policies(
    policies: list[str],
    env_id: str | None = None,
    env_kwargs: dict | None = None,
    force: bool = False,
) -> list[PolicySpec]:
    """Labels, env ids and env kwargs for each policy.

    Args:
        policies: ``random``, ``scripted`` or model paths.
        env_id: the env for all policies; ``None`` takes the models' own env id when they
            agree, else ``DEFAULT_ENV_ID``.
        env_kwargs: keywords that update each model's run ``env_kwargs`` (and are the only
            keywords of the built-in policies' env).
        force: run models on an id other than their own (:func:`check_model_env`).

    Raises:
        ValueError: an unknown policy or env id, a missing model, models trained on
            different ids with no ``env_id``, or a model on another id than its own.
    """
    for name in policies:
        if name not in BUILTIN_POLICIES and not Path(name).is_file():
            raise ValueError(
                f"policy must be one of {BUILTIN_POLICIES} or an existing model path, got "
                f"{name!r}" + (" (a folder)" if Path(name).is_dir() else " (no such file)")
            )
    runs = {name: model_run(Path(name)) for name in policies if name not in BUILTIN_POLICIES}
    if env_id is None:
        trained_on = {run["env_id"] for run in runs.values()} - {None}
        if len(trained_on) > 1:
            raise ValueError(
                f"the models were trained on different ids {sorted(trained_on)}; "
                "choose the env with --env"
            )
        env_id = trained_on.pop() if trained_on else DEFAULT_ENV_ID
    check_env_id("env_id", env_id)
    for name, run in runs.items():
        check_model_env(name, run["env_id"], env_id, force)
    specs = []
    for name, label in zip(policies, policy_labels(policies)):
        kwargs = dict(runs[name]["env_kwargs"]) if name in runs else {}
        if name in runs and is_primitive_model_on_6d(name, env_id):
            # The primitive env's own keywords do not apply to the 6-D env it drives.
            kwargs = {k: v for k, v in kwargs.items() if k not in PRIMITIVE_KEYWORDS}
        kwargs.update(env_kwargs or {})
        specs.append(PolicySpec(label, name, env_id, kwargs))
    return specs


def make_policy(name: str, env: gym.Env):
    """The policy called ``name``: ``random``, ``scripted`` or a model path."""
    if name == "random":
        return RandomPolicy(env)
    if name == "scripted":
        return scripted_policy(env)
    if Path(name).is_file():
        if is_primitive_model_on_6d(name, env.spec.id if env.spec else ""):
            return PrimitiveModelPolicy(name, env)
        return ModelPolicy(name, env)
    raise ValueError(
        f"policy must be one of {BUILTIN_POLICIES} or an existing model path, got {name!r}"
    )


def run_episode(env: gym.Env, policy, seed: int) -> EpisodeRecord:
    """One episode from ``seed`` alone (env and action space); errors are recorded after
    reset and after every step."""
    obs, info = env.reset(seed=seed)
    env.action_space.seed(seed)
    policy.reset()
    position, angle = [_finite(info["position_error"])], [float(info["angle_error"])]
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
        position.append(_finite(info["position_error"]))
        angle.append(float(info["angle_error"]))
    return EpisodeRecord(
        seed=seed,
        position_error=position,
        angle_error=angle,
        success=bool(info["is_success"]),
        n_measurements=int(info["n_measurements"]),
        terminated=bool(terminated),
    )


def run_episodes(spec: PolicySpec, seeds: list[int], progress=None) -> list[EpisodeRecord]:
    """Episodes of one policy on a fresh env (what a Ray worker runs for a chunk of seeds).

    Torch runs on one thread, so a model acts the same here and in any worker.

    Args:
        spec: the policy and its env.
        seeds: one episode per seed.
        progress: a progress bar whose ``update()`` is called after each episode.
    """
    env = make_env(spec.env_id, **spec.env_kwargs)
    try:
        policy = make_policy(spec.name, env)
        records = []
        with (
            torch_threads(1)
            if isinstance(policy, (ModelPolicy, PrimitiveModelPolicy))
            else (contextlib.nullcontext())
        ):
            for seed in seeds:
                records.append(run_episode(env, policy, seed))
                if progress is not None:
                    progress.update()
        return records
    finally:
        env.close()


def _finite(error: float) -> float:
    return float(min(error, NO_ESTIMATE_ERROR))


def chunks(seeds: list[int], n: int) -> list[list[int]]:
    """``seeds`` in at most ``n`` contiguous chunks of near-equal size."""
    n = max(1, min(n, len(seeds)))
    bounds = np.linspace(0, len(seeds), n + 1).round().astype(int)
    return [seeds[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def run_parallel(
    specs: list[PolicySpec],
    seeds: list[int],
    workers: int,
    address: str | None = None,
    progress=None,
) -> dict[str, list[EpisodeRecord]]:
    """Every policy's episodes spread over ``workers`` Ray tasks each (one CPU apiece),
    reassembled in seed order. Starts an embedded Ray unless one is running or ``address``
    names a cluster. ``progress.update(n)`` hears of each finished chunk of ``n`` episodes;
    a task's own error is raised as itself (a bad model is a ``ValueError``, as in a serial
    run)."""
    from ._ray import ray_session

    with ray_session(address=address) as ray:
        remote = ray.remote(num_cpus=1)(run_episodes)
        parts = {
            remote.remote(s, c): (s.label, k, len(c))
            for s in specs
            for k, c in enumerate(chunks(seeds, workers))
        }
        done: dict[tuple[str, int], list[EpisodeRecord]] = {}
        pending = list(parts)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            label, k, size = parts[ready[0]]
            try:
                done[label, k] = ray.get(ready[0])
            except ray.exceptions.RayTaskError as error:
                raise error.cause from None
            if progress is not None:
                progress.update(size)
        return {
            s.label: [r for k in range(len(chunks(seeds, workers))) for r in done[s.label, k]]
            for s in specs
        }


def summarize(records: list[EpisodeRecord]) -> dict[str, float]:
    """Table figures over episodes: errors in mm and degrees (NaN where undefined)."""
    final_pos = np.array([r.position_error[-1] for r in records]) * 1e3
    final_ang = np.degrees([r.angle_error[-1] for r in records])
    reach = [
        next((i for i, e in enumerate(r.position_error) if e < REACH_THRESHOLD), None)
        for r in records
    ]
    reached = [i for i in reach if i is not None]
    return {
        "episodes": len(records),
        "position_mean_mm": float(final_pos.mean()),
        "position_median_mm": float(np.median(final_pos)),
        "position_p90_mm": float(np.percentile(final_pos, 90)),
        "angle_mean_deg": float(final_ang.mean()),
        "angle_median_deg": float(np.median(final_ang)),
        "success_rate": float(np.mean([r.success for r in records])),
        "reached_5mm_rate": len(reached) / len(records),
        "steps_to_5mm_mean": float(np.mean(reached)) if reached else float("nan"),
        "measurements_mean": float(np.mean([r.n_measurements for r in records])),
        "failure_rate": float(np.mean([r.terminated for r in records])),
    }


def json_safe(value):
    """``value`` with every non-finite float replaced by ``None`` (JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def _fmt(value: float, spec: str) -> str:
    return "-" if value is None or not math.isfinite(value) else format(value, spec)


def markdown_table(summaries: dict[str, dict[str, float]]) -> str:
    header = (
        "| policy | episodes | final pos. error mean / median / P90 (mm) | final angle error"
        " mean / median (deg) | success | reached 5 mm | mean steps to 5 mm | measurements |"
        " failures |\n|---|---|---|---|---|---|---|---|---|"
    )
    rows = [
        f"| {name} | {s['episodes']} | {s['position_mean_mm']:.1f} / "
        f"{s['position_median_mm']:.1f} / {s['position_p90_mm']:.1f} | "
        f"{s['angle_mean_deg']:.2f} / {s['angle_median_deg']:.2f} | {s['success_rate']:.0%} | "
        f"{s['reached_5mm_rate']:.0%} | {_fmt(s['steps_to_5mm_mean'], '.0f')} | "
        f"{s['measurements_mean']:.1f} | {s['failure_rate']:.0%} |"
        for name, s in summaries.items()
    ]
    return "\n".join([header, *rows])


def evaluate(
    policies: list[str],
    env_id: str | None = None,
    episodes: int = 20,
    seed: int = TEST_SEED,
    out: str | Path = "results/evaluation",
    env_kwargs: dict | None = None,
    plot: bool = True,
    workers: int = 1,
    address: str | None = None,
    force: bool = False,
) -> dict[str, dict[str, float]]:
    """Evaluate each policy over the same seeded episodes; write JSON and a plot.

    Args:
        policies: ``random``, ``scripted`` or paths of models saved by ``agents.train``.
        env_id: the env; ``None`` takes the models' own when they agree (see
            :func:`resolve_policies`).
        episodes: episodes per policy, seeds ``seed .. seed + episodes - 1``.
        seed: the first episode's seed.
        out: folder of ``evaluation.json`` and ``error_vs_step.png``.
        env_kwargs: ``gym.make`` keywords over each model's run ``env_kwargs``.
        plot: write the error plot (needs matplotlib).
        workers: Ray tasks per policy; 1 runs everything in this process.
        address: a Ray cluster to join (``"auto"`` or ``host:port``); implies Ray.
        force: run models on an id other than the one they were trained on.

    Returns:
        The summary of each policy, by label.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    specs = resolve_policies(policies, env_id, env_kwargs, force)
    seeds = [seed + k for k in range(episodes)]
    bar = progress_bar(len(specs) * episodes, "episodes", "episode")
    try:
        if workers > 1 or address:
            records = run_parallel(specs, seeds, workers, address, bar)
        else:
            records = {spec.label: run_episodes(spec, seeds, bar) for spec in specs}
    finally:
        bar.close()
    summaries = {label: summarize(recs) for label, recs in records.items()}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    result = {
        "env_id": specs[0].env_id,
        "policies": {s.label: {"name": s.name, "env_kwargs": s.env_kwargs} for s in specs},
        "episodes": episodes,
        "seed": seed,
        "summaries": summaries,
        "episodes_detail": {name: [asdict(r) for r in recs] for name, recs in records.items()},
    }
    (out / "evaluation.json").write_text(json.dumps(json_safe(result), indent=1, allow_nan=False))
    if plot:
        # Models by algorithm too: a sweep's PPO and SAC runs share their folder names.
        names = {
            s.label: s.label
            if s.name in BUILTIN_POLICIES
            else f"{model_run(Path(s.name))['algo'].upper()} {s.label}"
            for s in specs
        }
        shown = {names[label]: recs for label, recs in records.items()}
        plot_errors(shown, out / "error_vs_step.png", specs[0].env_id, REACH_THRESHOLD)
    return summaries


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = make_parser(__spec__.name if __spec__ else "agents.evaluate", __doc__)
    parser.add_argument(
        "--policies",
        nargs="+",
        default=list(BUILTIN_POLICIES),
        metavar="POLICY",
        help="random (uniform actions), scripted (the scripted baseline) and/or paths of "
        "models saved by agents.train or rl_zoo3 (e.g. runs/ppo/<run>/best_model.zip)",
    )
    parser.add_argument(
        "--env",
        default=None,
        help=f"one of {', '.join(KNOWN_ENV_IDS)}; default: the models' own id, "
        f"else {DEFAULT_ENV_ID}",
    )
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        action=KeyValue,
        default={},
        metavar="KEY:VALUE",
        help="gym.make keywords over each model's run env_kwargs, e.g. max_steps:200; "
        + KEY_VALUE_HELP,
    )
    parser.add_argument("--episodes", type=int, default=20, help="episodes per policy")
    parser.add_argument(
        "--seed",
        type=int,
        default=TEST_SEED,
        help="seed of the first episode (then +1 each); the default starts the test range, "
        "which no training or model selection uses (agents.seeds)",
    )
    parser.add_argument(
        "--out", default="results/evaluation", help="folder of evaluation.json and the plot"
    )
    parser.add_argument(
        "--workers", type=int, default=1, help="Ray tasks per policy (needs the sweep extra)"
    )
    parser.add_argument("--address", default=None, help="a Ray cluster to join (auto or host:port)")
    parser.add_argument(
        "--force",
        action="store_true",
        help="run models on an id other than the one they were trained on",
    )
    parser.add_argument("--no-plot", action="store_true", help="skip error_vs_step.png")
    args = parser.parse_args(argv)
    summaries = evaluate(
        args.policies,
        args.env,
        args.episodes,
        args.seed,
        args.out,
        env_kwargs=args.env_kwargs,
        plot=not args.no_plot,
        workers=args.workers,
        address=args.address,
        force=args.force,
    )
    data = json.loads((Path(args.out) / "evaluation.json").read_text())
    last = args.seed + args.episodes - 1
    print(f"{data['env_id']}, {args.episodes} episodes, seeds {args.seed}..{last}")
    print(markdown_table(summaries))
    if REFERENCE in data["episodes_detail"] and len(data["episodes_detail"]) > 1:
        print(f"\n{paired_table(data['episodes_detail'])}")
    print(f"wrote {Path(args.out) / 'evaluation.json'}")
    return summaries


if __name__ == "__main__":
    sys.exit(run_main(main))
