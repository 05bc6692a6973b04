"""The policies the commands play: random, scripted, and models saved by a run.

Every policy has ``get_action(obs)`` and ``reset()``. :func:`make_policy` makes one by name:
``random`` (:class:`RandomPolicy`), ``scripted`` (``agents.scripted.scripted_policy``) or the
path of a stable-baselines3 model (:class:`ModelPolicy`; a model learned on a primitive id
also drives its 6-D id, :class:`PrimitiveModelPolicy`). :func:`resolve_policies` turns the
names a command is given into :class:`PolicySpec`: the env each plays on, with its run's env
keywords, checked against the id it was trained on (:func:`check_model_env`). Models load
through ``agents.runs``, which unpickles nothing unless told to trust the folder.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import numpy as np

from tactile_gym.envs.hinge_probe_primitive import PRIMITIVE_KEYWORDS
from tactile_gym.envs.skills import PrimitiveExecutor

from .cli import DEFAULT_ENV_ID, check_env_id, make_env
from .runs import load_model, load_statistics, model_run, read_run
from .scripted import episode_started, scripted_policy

__all__ = [
    "BUILTIN_POLICIES",
    "ModelPolicy",
    "PolicySpec",
    "PrimitiveModelPolicy",
    "RandomPolicy",
    "check_model_env",
    "check_policies",
    "deadband",
    "is_primitive_model_on_6d",
    "make_policy",
    "policy_labels",
    "resolve_policies",
]

BUILTIN_POLICIES = ("random", "scripted")


def deadband(action: np.ndarray, width: float) -> np.ndarray:
    """``action`` with every component smaller than ``width`` in magnitude set to 0.

    A run trained with an action deadband (``agents.train --action-deadband``) acts through
    it in training and here alike: the gate counts a control step as still only below 1 % of
    a unit translation and 0.4 % of a unit rotation (``GateConfig.still_translation``,
    ``still_rotation``), which a Gaussian policy's mean, let alone its samples, does not hit
    by chance; the deadband makes holding still an action (``docs/design.md`` 12).
    """
    action = np.asarray(action)
    return np.where(np.abs(action) < width, np.zeros_like(action), action)


class RandomPolicy:
    """Uniform random actions from the env's action space (seeded by ``run_episode``)."""

    def __init__(self, env: gym.Env) -> None:
        self.action_space = env.action_space

    def reset(self) -> None:
        pass

    def get_action(self, obs) -> np.ndarray:
        return self.action_space.sample()


class ModelPolicy:
    """A stable-baselines3 model saved by ``agents.train``, with its own observation scaling
    and its run's action deadband (:func:`deadband`); a recurrent one (``recurrent_ppo``)
    carries its LSTM state from step to step, from zero at each :meth:`reset`.

    Args:
        path: the model's zip.
        env: the env it acts on.
        trust_pickle: let its files be unpickled (``agents.runs``).

    Raises:
        ValueError: a model that does not load for ``env`` (``agents.runs.load_model``), or
            whose statistics are missing or refused (``agents.runs.load_statistics``): another
            model's statistics would scale its inputs wrongly.
    """

    def __init__(self, path: str | Path, env: gym.Env, trust_pickle: bool = False) -> None:
        from stable_baselines3.common.vec_env import DummyVecEnv

        saved = model_run(Path(path))
        self.deadband = saved.action_deadband
        self.model = load_model(saved, env, trust_pickle=trust_pickle)
        self.normalizer = load_statistics(
            saved, DummyVecEnv([lambda: env]), trust_pickle=trust_pickle
        )
        self.reset()

    def reset(self) -> None:
        self.state = None
        self.episode_start = np.ones(1, dtype=bool)

    def get_action(self, obs) -> np.ndarray:
        if self.normalizer is not None:
            obs = self.normalizer.normalize_obs(obs)
        action, self.state = self.model.predict(
            obs, state=self.state, episode_start=self.episode_start, deterministic=True
        )
        self.episode_start = np.zeros(1, dtype=bool)
        return deadband(action, self.deadband) if self.deadband else action


class PrimitiveModelPolicy:
    """A model learned on a primitive id, driving the matching 6-D id: it chooses primitives
    and the same probing skills carry them out, one control step at a time (hierarchical).
    A new episode is noticed from its first observation, as the scripted policy does.

    Args:
        path: the model, from a run on a ``...Primitive-v1`` id.
        env: the 6-D env to act on (dict observations).
        trust_pickle: let the model's files be unpickled (``agents.runs``).
    """

    def __init__(self, path: str | Path, env: gym.Env, trust_pickle: bool = False) -> None:
        run = model_run(Path(path))
        check_env_id(f"the env_id of {path}'s run", run.env_id)
        primitive_env = make_env(run.env_id, **run.env_kwargs)
        try:
            self.inner = ModelPolicy(path, primitive_env, trust_pickle)
            self.space = primitive_env.get_wrapper_attr("dict_observation_space")
            self.flat = primitive_env.unwrapped.control_env.config.observation_mode == "flat"
        finally:
            primitive_env.close()
        self.executor = PrimitiveExecutor.for_env(env.unwrapped)

    def reset(self) -> None:
        self.executor.reset()
        self.inner.reset()

    def get_action(self, obs: dict) -> np.ndarray:
        if episode_started(obs):
            self.reset()
        action = self.executor.act(obs)
        while action is None:
            view = {**obs, "primitive": self.executor.summary.astype(np.float32)}
            if self.flat:
                view = gym.spaces.flatten(self.space, view)
            self.executor.start(self.inner.get_action(view), obs)
            action = self.executor.act(obs)
        return action.astype(np.float32)


def is_primitive_model_on_6d(name: str, env_id: str) -> bool:
    """Whether a model learned on a primitive id is to act on its 6-D id (the same task
    with 6-D actions: ``HingeProbePrimitive-v1`` drives ``HingeProbe-v1``)."""
    trained_on = read_run(Path(name)).env_id or ""
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


@dataclass(frozen=True)
class PolicySpec:
    """Everything needed to rebuild a policy and its env, in this process or a worker.

    Attributes:
        label: the unique name in tables, plots and JSON.
        name: ``random``, ``scripted`` or a model path.
        env_id: the env to run on.
        env_kwargs: ``gym.make`` keywords.
        trust_pickle: let the model's files be unpickled (``agents.runs``).
    """

    label: str
    name: str
    env_id: str
    env_kwargs: dict = field(default_factory=dict)
    trust_pickle: bool = False


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
        run_dir = read_run(path).run_dir
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
    trust_pickle: bool = False,
) -> list[PolicySpec]:
    """Labels, env ids and env kwargs for each policy.

    Args:
        policies: ``random``, ``scripted`` or model paths.
        env_id: the env for all policies; ``None`` takes the models' own env id when they
            agree, else ``DEFAULT_ENV_ID``.
        env_kwargs: keywords that update each model's run ``env_kwargs`` (and are the only
            keywords of the built-in policies' env).
        force: run models on an id other than their own (:func:`check_model_env`).
        trust_pickle: let the models' files be unpickled (``agents.runs``).

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
        trained_on = {run.env_id for run in runs.values()} - {None}
        if len(trained_on) > 1:
            raise ValueError(
                f"the models were trained on different ids {sorted(trained_on)}; "
                "choose the env with --env"
            )
        env_id = trained_on.pop() if trained_on else DEFAULT_ENV_ID
    check_env_id("env_id", env_id)
    for name, run in runs.items():
        check_model_env(name, run.env_id, env_id, force)
    specs = []
    for name, label in zip(policies, policy_labels(policies)):
        kwargs = dict(runs[name].env_kwargs) if name in runs else {}
        if name in runs and is_primitive_model_on_6d(name, env_id):
            # The primitive env's own keywords do not apply to the 6-D env it drives.
            kwargs = {k: v for k, v in kwargs.items() if k not in PRIMITIVE_KEYWORDS}
        kwargs.update(env_kwargs or {})
        specs.append(PolicySpec(label, name, env_id, kwargs, trust_pickle))
    return specs


def make_policy(name: str, env: gym.Env, trust_pickle: bool = False):
    """The policy called ``name``: ``random``, ``scripted`` or a model path (loaded with
    ``trust_pickle``, ``agents.runs``)."""
    if name == "random":
        return RandomPolicy(env)
    if name == "scripted":
        return scripted_policy(env)
    if Path(name).is_file():
        if is_primitive_model_on_6d(name, env.spec.id if env.spec else ""):
            return PrimitiveModelPolicy(name, env, trust_pickle)
        return ModelPolicy(name, env, trust_pickle)
    raise ValueError(
        f"policy must be one of {BUILTIN_POLICIES} or an existing model path, got {name!r}"
    )


def check_policies(specs: list[PolicySpec]) -> None:
    """Load every model of ``specs`` once, on its env, before any episode is played: a
    damaged, foreign or untrusted model fails at once, not after the other policies' episodes.

    Raises:
        ValueError: what loading the model raises (``agents.runs``).
    """
    for spec in specs:
        if spec.name in BUILTIN_POLICIES:
            continue
        env = make_env(spec.env_id, **spec.env_kwargs)
        try:
            make_policy(spec.name, env, spec.trust_pickle)
        finally:
            env.close()
