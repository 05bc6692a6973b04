"""A run folder and the models saved in it; loading them runs none of their code.

A run of ``agents.train`` is one folder (:func:`make_run_dir`)::

    config.yml                      the resolved config, the arguments and the command
    final_model.zip                 the model at the end ...
    vecnormalize.json               ... and its VecNormalize statistics, with normalisation
    best_model.zip                  the best model of the periodic evaluation ...
    best_model_vecnormalize.json    ... and the statistics it was evaluated with
    checkpoints/rl_model_<n>_steps.zip, checkpoints/rl_model_vecnormalize_<n>_steps.json
    eval/evaluations.npz, tensorboard/, demos.npz, warm_start.yml, failed.txt

rl_zoo3's runs are read too: ``<env>.zip`` beside an ``<env>/`` folder of ``args.yml``,
``config.yml`` and ``vecnormalize.pkl`` (:func:`model_run`).

**What loading trusts** (``docs/security.md``). A model folder may come from anyone, so
loading it must not run code from it:

* The statistics are JSON (:func:`save_statistics`, :func:`read_statistics`): numbers and
  names, checked against the env's observation space. A ``VecNormalize`` pickle
  (``*.pkl``, what stable-baselines3 and earlier versions of this package save) is read
  only with ``trust_pickle`` (``--trust-pickle``): unpickling runs whatever the file says.
  ``python -m agents.convert_models`` turns a trusted folder's pickles into JSON.
* A model is stable-baselines3's zip: a JSON ``data`` file and the weights. SB3 cloudpickles
  some of ``data``'s entries (the spaces, the policy class, schedules, buffers, training
  state); :func:`load_model` gives SB3 every such entry itself (``custom_objects``, rebuilt
  from the env, the run's ``config.yml`` and fixed values, :data:`FRESH`), so SB3 unpickles
  none, and refuses a model with an entry it cannot rebuild. SB3 (>= 2.8) reads the weights
  with ``torch.load(weights_only=True)``: tensors only.
* An rl_zoo3 run, and an algorithm other than those ``agents.train`` runs (PPO, SAC,
  RecurrentPPO, TQC: ``agents.hyperparams.ALGOS``), load only with ``trust_pickle``.

A damaged or foreign file (a truncated zip, a zip that is not a model, statistics of the
wrong shape or missing) is a ``ValueError`` in one line, which the commands print as such.
"""

from __future__ import annotations

import inspect
import json
import pickle
import re
import time
import zipfile
import zlib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

from .hyperparams import ALGOS, ZOO_NAMES, algo_kwargs, algorithm_class

__all__ = [
    "FRESH",
    "SavedModel",
    "convert_statistics",
    "latest_checkpoint",
    "load_model",
    "load_statistics",
    "make_run_dir",
    "model_run",
    "read_model_data",
    "read_statistics",
    "saved_algo",
    "save_statistics",
    "statistics_path",
]

#: What a statistics file says it is (``"format"``), so that no other JSON passes for one.
STATISTICS_FORMAT = "tactile_gym VecNormalize statistics 1"
#: The cloudpickled entries of a model's ``data`` that are training state: SB3 makes them
#: afresh when learning starts (``_setup_learn``: the last observations, episode buffers) or
#: from the spaces and ``learning_rate`` (``_setup_model``: the buffer classes,
#: ``lr_schedule``), so the safe load gives ``None``.
FRESH = (
    "_last_obs",
    "_last_original_obs",
    "_last_episode_starts",
    "ep_info_buffer",
    "ep_success_buffer",
    "rollout_buffer_class",
    "replay_buffer_class",
    "lr_schedule",
)
#: Hyperparameters SB3 cloudpickles when they are objects: rebuilt from the run's config
#: (``agents.hyperparams.algo_kwargs``), else from the constant SB3 writes beside the pickle,
#: else the algorithm's default (the last two only change training, not a model's actions).
#: (TQC's ``target_entropy`` too: ``_target_entropy``.)
REBUILT_HYPERPARAMETERS = ("learning_rate", "clip_range", "clip_range_vf", "train_freq")
#: stable-baselines3's algorithms; those of ``ALGOS`` load without pickle, the others with
#: trust.
SB3_ALGOS = ("a2c", "ddpg", "dqn", "ppo", "sac", "td3")
#: The module of a saved policy class (in the zip's JSON) -> the algorithm that saved it.
POLICY_MODULES = {
    "stable_baselines3.common.policies": "ppo",  # shared by PPO and A2C: taken for PPO
    "stable_baselines3.ppo.policies": "ppo",
    "sb3_contrib.common.recurrent.policies": "recurrent_ppo",
    "sb3_contrib.ppo_recurrent.policies": "recurrent_ppo",
    "sb3_contrib.tqc.policies": "tqc",
}
#: The first stable-baselines3 release that reads weights with ``weights_only=True``.
SAFE_SB3 = (2, 8)
#: What the refusals tell the user to do.
TRUST_HINT = (
    "load it with --trust-pickle (trust_pickle=True) only if you trust where it came from "
    "(docs/security.md)"
)


# ------------------------------------------------------------------------ the run folder
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


def latest_checkpoint(run_dir: str | Path) -> Path | None:
    """The run's checkpoint with the most env steps (``checkpoints/rl_model_<n>_steps.zip``),
    or ``None``."""
    found = []
    for path in Path(run_dir).glob("checkpoints/rl_model_*_steps.zip"):
        steps = path.stem.removeprefix("rl_model_").removesuffix("_steps")
        if steps.isdigit():
            found.append((int(steps), path))
    return max(found)[1] if found else None


def statistics_path(model_path: str | Path, suffix: str = ".json") -> Path:
    """Where ``agents.train`` saves the ``VecNormalize`` statistics that go with a model
    (``suffix=".pkl"``: where earlier versions saved them as a pickle).

    * ``final_model.zip``: ``vecnormalize.json`` beside it (rl_zoo3's name);
    * ``rl_model_<n>_steps.zip`` (checkpoints): ``rl_model_vecnormalize_<n>_steps.json``
      beside it (``CheckpointCallback``'s name, also in rl_zoo3's runs);
    * any other ``<name>.zip`` (``best_model.zip``): ``<name>_vecnormalize.json`` beside it.
    """
    path = Path(model_path)
    if path.stem == "final_model":
        return path.with_name("vecnormalize" + suffix)
    if path.stem.startswith("rl_model_") and path.stem.endswith("_steps"):
        return path.with_name(path.stem.replace("rl_model_", "rl_model_vecnormalize_", 1) + suffix)
    return path.with_name(f"{path.stem}_vecnormalize{suffix}")


@dataclass(frozen=True)
class SavedModel:
    """What a model's run folder says about it (:func:`model_run`).

    Attributes:
        path: the model's zip.
        run_dir: its run folder.
        algo: ``"ppo"``, ``"sac"``, ...: from the run config, else from the zip.
        env_id: the id it was trained on (``None``: no run config).
        env_kwargs: the run's ``gym.make`` keywords.
        normalize: whether the run normalised with ``VecNormalize``.
        statistics: the JSON statistics saved with the model.
        pickled_statistics: where a pickle of them would be (rl_zoo3's, or older runs').
        hyperparameters: the run's resolved config (``agents.train``'s runs only).
        layout: ``"agents.train"``, ``"rl_zoo3"`` or ``"none"`` (a lone zip).
        truth_free: the run trained without the truth (``agents.train --truth-free``).
        action_deadband: the run's action deadband (``agents.policies.deadband``; 0: none).
    """

    path: Path
    run_dir: Path
    algo: str | None
    env_id: str | None
    env_kwargs: dict = field(default_factory=dict)
    normalize: bool = False
    statistics: Path | None = None
    pickled_statistics: Path | None = None
    hyperparameters: dict = field(default_factory=dict)
    layout: str = "none"
    truth_free: bool = False
    action_deadband: float = 0.0


def model_run(path: str | Path) -> SavedModel:
    """What a model's run folder says about it, the algorithm read from the zip where the
    folder does not say (:func:`saved_algo`).

    Reads ``agents.train``'s ``config.yml``, or an rl_zoo3 run (``<env>.zip`` beside the
    ``<env>/`` folder of ``args.yml``, ``config.yml`` and ``vecnormalize.pkl``); with neither,
    the env id is unknown (``None``), there are no env kwargs and no normalisation.

    Raises:
        ValueError: no run config names the algorithm and the zip is not a model.
    """
    run = read_run(path)
    if run.algo is None:
        return replace(run, algo=saved_algo(run.path))
    return run


def read_run(path: str | Path) -> SavedModel:
    """What the run folder says (``algo`` ``None`` without a run config); the model's file
    is not opened. Its YAML is read as data: no Python tags but rl_zoo3's ``OrderedDict``."""
    path = Path(path)
    run_dir = path.parent.parent if path.parent.name == "checkpoints" else path.parent
    zoo = [d for d in run_dir.iterdir() if (d / "args.yml").is_file()] if run_dir.is_dir() else []
    if (run_dir / "config.yml").exists() or len(zoo) != 1:
        config_file = run_dir / "config.yml"
        record = yaml.safe_load(config_file.read_text()) if config_file.exists() else {}
        hyper = record.get("hyperparameters") or {}
        return SavedModel(
            path=path,
            run_dir=run_dir,
            algo=record.get("algo"),
            env_id=record.get("env_id"),
            env_kwargs=dict(hyper.get("env_kwargs") or {}),
            normalize=bool(hyper.get("normalize", False)),
            statistics=statistics_path(path),
            pickled_statistics=statistics_path(path, ".pkl"),
            hyperparameters=dict(hyper),
            layout="agents.train" if config_file.exists() else "none",
            truth_free=bool(record.get("truth_free", False)),
            action_deadband=float(record.get("action_deadband", 0.0)),
        )
    (params,) = zoo
    args = _load_zoo_yaml(params / "args.yml")
    hyper = _load_zoo_yaml(params / "config.yml") if (params / "config.yml").exists() else {}
    final = path.stem == params.name
    return SavedModel(
        path=path,
        run_dir=run_dir,
        algo={zoo: ours for ours, zoo in ZOO_NAMES.items()}.get(args.get("algo"), args.get("algo")),
        env_id=args.get("env"),
        env_kwargs=dict(args.get("env_kwargs") or hyper.get("env_kwargs") or {}),
        normalize=bool(hyper.get("normalize", False)),
        statistics=params / "vecnormalize.json" if final else statistics_path(path),
        pickled_statistics=params / "vecnormalize.pkl" if final else statistics_path(path, ".pkl"),
        layout="rl_zoo3",
    )


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


# ----------------------------------------------------------------------------- the model
def read_model_data(path: str | Path) -> dict[str, Any]:
    """The JSON ``data`` of a stable-baselines3 zip, every member's checksum verified; no
    entry is unpickled.

    Raises:
        ValueError: the file is damaged (a truncated zip, a bad checksum) or is not an SB3
            model (no ``data`` or ``policy.pth``, ``data`` not JSON).
    """
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            damaged = archive.testzip()
            if damaged is not None:
                raise ValueError(f"its member {damaged} fails its checksum")
            if "data" not in names or "policy.pth" not in names:
                raise ValueError(f"it holds {sorted(names)}, not data and policy.pth")
            data = json.loads(archive.read("data"))
        if not isinstance(data, dict):
            raise ValueError("its data is not a JSON object")
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error, UnicodeDecodeError) as error:
        raise ValueError(
            f"{str(path)!r} is damaged or not a zip (a truncated download?): {error}"
        ) from error
    except ValueError as error:
        raise ValueError(f"{str(path)!r} is not a stable-baselines3 model: {error}") from error
    return data


def saved_algo(path: str | Path) -> str:
    """The algorithm of a stable-baselines3 (or sb3-contrib) model, from the module of the
    policy class its zip names in JSON beside the pickle (:data:`POLICY_MODULES`;
    ``common.policies``, shared by PPO and A2C, is taken for PPO).

    Raises:
        ValueError: the file is not a stable-baselines3 model.
    """
    data = read_model_data(path)
    module = str((data.get("policy_class") or {}).get("__module__", ""))
    if module in POLICY_MODULES:
        return POLICY_MODULES[module]
    match = re.fullmatch(r"stable_baselines3\.(\w+)\.policies", module)
    if match and match.group(1) in SB3_ALGOS:
        return match.group(1)
    raise ValueError(
        f"{str(path)!r} holds a policy of {module or 'no known module'}; agents.evaluate runs "
        f"the models of {', '.join(ALGOS)}, and stable-baselines3's other algorithms with "
        "--trust-pickle"
    )


def model_class(algo: str, trust_pickle: bool) -> type:
    """The stable-baselines3 class that loads a model of ``algo``.

    Raises:
        ValueError: an algorithm SB3 does not have, or one outside ``ALGOS`` without
            ``trust_pickle`` (the safe load knows the entries of their zips only).
    """
    if algo in ALGOS:
        return algorithm_class(algo)
    if algo not in SB3_ALGOS:
        known = (*ALGOS, *(a for a in SB3_ALGOS if a not in ALGOS))
        raise ValueError(f"algo must be one of {known}, got {algo!r}")
    if not trust_pickle:
        raise ValueError(
            f"a {algo.upper()} model loads only by unpickling it (the package rebuilds the "
            f"entries of {', '.join(ALGOS)} models only); {TRUST_HINT}"
        )
    import stable_baselines3

    return getattr(stable_baselines3, algo.upper())


def load_model(
    model: SavedModel | str | Path,
    env: gym.Env | Any,
    *,
    trust_pickle: bool = False,
    device: str = "cpu",
    attach: bool = False,
):
    """A stable-baselines3 model from its zip, for ``env``, unpickling nothing (module
    docstring) unless ``trust_pickle``.

    Args:
        model: the model (its :func:`model_run`, or its path).
        env: the env (or VecEnv) it is to act on: its spaces replace the saved ones, once
            checked against the shapes the zip states in JSON.
        trust_pickle: let SB3 unpickle the zip's entries (an rl_zoo3 run, an algorithm outside
            ``ALGOS``, an entry the package cannot rebuild).
        device: torch device.
        attach: give ``env`` to the model (to continue training it).

    Raises:
        ValueError: a damaged or foreign zip, spaces other than ``env``'s, an rl_zoo3 run or
            an entry that needs unpickling without ``trust_pickle``; in one line.
    """
    import stable_baselines3

    saved = model if isinstance(model, SavedModel) else model_run(model)
    path = saved.path
    data = read_model_data(path)
    cls = model_class(saved.algo, trust_pickle)
    objects: dict[str, Any] | None = None
    if not trust_pickle:
        if saved.layout == "rl_zoo3":
            raise ValueError(
                f"{str(path)!r} is from an rl_zoo3 run, whose files hold pickles (its statistics, "
                f"schedules and policy options); {TRUST_HINT}"
            )
        if _version(stable_baselines3.__version__) < SAFE_SB3:
            raise ImportError(
                f"loading a model without unpickling needs stable-baselines3 >= "
                f"{'.'.join(map(str, SAFE_SB3))} (it reads weights as tensors only), found "
                f"{stable_baselines3.__version__}: pip install -U stable-baselines3, or "
                f"{TRUST_HINT}"
            )
        for kind in ("observation", "action"):
            _check_saved_space(saved, data.get(f"{kind}_space"), kind, env)
        objects = _rebuilt_objects(saved, data, cls, env)
    try:
        loaded = cls.load(path, env=env if attach else None, device=device, custom_objects=objects)
    except (
        RuntimeError,
        KeyError,
        TypeError,
        AssertionError,
        ValueError,
        AttributeError,
        EOFError,
        pickle.UnpicklingError,
        zipfile.BadZipFile,
    ) as error:
        reason = (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise ValueError(
            f"{str(path)!r} does not load as a {saved.algo.upper()} model for this env: {reason}"
        ) from error
    for kind in ("observation", "action"):
        trained, given = getattr(loaded, f"{kind}_space"), getattr(env, f"{kind}_space")
        if trained != given:  # what an unpickled (trusted) zip can still say
            raise ValueError(_space_message(saved, kind, space_text(trained), env))
    return loaded


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", text)[:2])


def _rebuilt_objects(saved: SavedModel, data: dict, cls: type, env) -> dict[str, Any]:
    """Every cloudpickled entry of the zip's ``data``, rebuilt (module docstring).

    Raises:
        ValueError: an entry the package cannot rebuild, or a policy class other than the
            one the run config (or the observation space) says.
    """
    config = saved.hyperparameters
    given = algo_kwargs(config) if config else {}
    defaults = {
        name: p.default
        for name, p in inspect.signature(cls.__init__).parameters.items()
        if p.default is not inspect.Parameter.empty
    }
    pickled = sorted(k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v)
    objects: dict[str, Any] = {
        # SB3 never saves an env; a planted one would be used as the model's env.
        "env": None,
        "observation_space": env.observation_space,
        "action_space": env.action_space,
    }
    for key in pickled:
        if key in FRESH:
            objects[key] = None
        elif key == "policy_class":
            objects[key] = _policy_class(saved, data[key], cls, env.observation_space)
        elif key == "target_entropy":
            objects[key] = _target_entropy(given.get(key, "auto"), env.action_space)
        elif key in REBUILT_HYPERPARAMETERS and key in defaults:
            readable = _saved_constant(data[key])
            objects[key] = given.get(key, readable if readable is not None else defaults[key])
        elif key not in objects:
            raise ValueError(
                f"{str(saved.path)!r} holds a pickled {key!r} that tactile_gym cannot rebuild "
                f"(a custom object?); {TRUST_HINT}"
            )
    return objects


def _target_entropy(value: Any, action_space) -> np.float32:
    """An entropy-tuning target (TQC pickles the number it made of ``"auto"``): the config's
    number, else ``-dim(actions)``, what ``"auto"`` means (it only steers training)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.float32(value)
    return np.float32(-np.prod(action_space.shape))


def _policy_class(saved: SavedModel, entry: dict, cls: type, observation_space) -> type:
    """The policy class the run config names (``policy``), else the algorithm's one for the
    observation space (``MultiInput...`` for a Dict, ``Mlp...``; ``...LstmPolicy`` for a
    recurrent algorithm); it must be the class whose module and ``__init__`` the zip names in
    JSON."""
    name = saved.hyperparameters.get("policy")
    if not name:
        prefix = "MultiInput" if isinstance(observation_space, gym.spaces.Dict) else "Mlp"
        name = next(
            (n for n in (f"{prefix}Policy", f"{prefix}LstmPolicy") if n in cls.policy_aliases),
            f"{prefix}Policy",
        )
    policy_class = cls.policy_aliases.get(name) if isinstance(name, str) else None
    if policy_class is None:
        raise ValueError(
            f"{str(saved.path)!r} uses the policy {name!r}, not one of "
            f"{cls.__name__}'s {sorted(cls.policy_aliases)}; {TRUST_HINT}"
        )
    init = re.match(r"<function ([\w.]+)\.__init__ ", str(entry.get("__init__", "")))
    ours = policy_class.__init__.__qualname__.removesuffix(".__init__")
    if entry.get("__module__") != policy_class.__module__ or (init and init.group(1) != ours):
        theirs = f"{entry.get('__module__')}.{init.group(1) if init else '?'}"
        raise ValueError(
            f"{str(saved.path)!r} holds a {theirs} policy, not the "
            f"{policy_class.__module__}.{ours} of {name!r}; {TRUST_HINT}"
        )
    return policy_class


def _saved_constant(entry: dict) -> float | None:
    """The value of a constant schedule from what SB3 writes beside its pickle
    (``FloatSchedule(ConstantSchedule(val=0.2))`` is ``{"value_schedule":
    "ConstantSchedule(val=0.2)"}``), else ``None``."""
    match = re.fullmatch(r"ConstantSchedule\(val=([-+0-9.eE]+)\)", str(entry.get("value_schedule")))
    return float(match.group(1)) if match else None


def _saved_space(entry: Any) -> tuple | None:
    """The shapes of a space from what SB3 writes beside its pickle: ``("Box", shape)`` or
    ``("Dict", ((key, shape), ...))``; ``None`` where it does not say."""
    if not isinstance(entry, dict):
        return None
    kind = str(entry.get(":type:", ""))
    if kind.endswith("box.Box'>") and isinstance(entry.get("_shape"), list):
        return ("Box", tuple(int(n) for n in entry["_shape"]))
    if kind.endswith("dict.Dict'>") and isinstance(entry.get("spaces"), str):
        boxes = re.findall(r"'([^']+)': Box\([^()]*\(([\d, ]*)\), \w+\)", entry["spaces"])
        if boxes:
            return (
                "Dict",
                tuple((k, tuple(int(n) for n in s.split(",") if n.strip())) for k, s in boxes),
            )
    return None


def _space_shapes(space: gym.Space) -> tuple:
    """``_saved_space``'s description of a space."""
    if isinstance(space, gym.spaces.Dict):
        return ("Dict", tuple((k, tuple(s.shape)) for k, s in space.spaces.items()))
    return (type(space).__name__, tuple(space.shape or ()))


def space_text(space: gym.Space | tuple) -> str:
    """A space (or its ``_saved_space`` description) in a few words: its shape, or a Dict's
    keys and shapes."""
    kind, shapes = space if isinstance(space, tuple) else _space_shapes(space)
    if kind == "Dict":
        return "{" + ", ".join(f"{k}: {shape}" for k, shape in shapes) + "}"
    return f"{kind}{shapes}"


def _check_saved_space(saved: SavedModel, entry: Any, kind: str, env) -> None:
    """Refuse an env whose ``kind`` space differs from the shapes the zip states."""
    shapes = _saved_space(entry)
    if shapes is None:
        raise ValueError(
            f"{str(saved.path)!r} does not state its {kind} space in a form tactile_gym reads "
            f"(Box or Dict of Box); {TRUST_HINT}"
        )
    if shapes != _space_shapes(getattr(env, f"{kind}_space")):
        raise ValueError(_space_message(saved, kind, space_text(shapes), env))


def _space_message(saved: SavedModel, kind: str, trained: str, env) -> str:
    spec = getattr(env, "spec", None)
    env_id = spec.id if spec is not None else "this env"
    return (
        f"{saved.path} was trained on {saved.env_id or 'another id'}, whose {kind} space "
        f"differs from {env_id}'s ({trained} against "
        f"{space_text(getattr(env, f'{kind}_space'))}); evaluate it on the id and env kwargs "
        "it was trained with"
    )


# ------------------------------------------------------------------------ the statistics
def save_statistics(vec_normalize: Any, path: str | Path) -> Path:
    """Write a ``VecNormalize``'s statistics and settings as JSON (every float exactly: JSON
    numbers are written and read as the shortest repr that round-trips)."""

    def moments(rms) -> dict:
        return {
            "mean": np.asarray(rms.mean, dtype=np.float64).tolist(),
            "var": np.asarray(rms.var, dtype=np.float64).tolist(),
            "count": float(rms.count),
        }

    obs_rms = getattr(vec_normalize, "obs_rms", None) if vec_normalize.norm_obs else None
    record = {
        "format": STATISTICS_FORMAT,
        "norm_obs": bool(vec_normalize.norm_obs),
        "norm_reward": bool(vec_normalize.norm_reward),
        "norm_obs_keys": list(vec_normalize.norm_obs_keys or []) or None,
        "clip_obs": float(vec_normalize.clip_obs),
        "clip_reward": float(vec_normalize.clip_reward),
        "gamma": float(vec_normalize.gamma),
        "epsilon": float(vec_normalize.epsilon),
        "obs_rms": (
            {key: moments(rms) for key, rms in obs_rms.items()}
            if isinstance(obs_rms, dict)
            else moments(obs_rms)
            if obs_rms is not None
            else None
        ),
        "ret_rms": moments(vec_normalize.ret_rms),
    }
    path = Path(path)
    path.write_text(json.dumps(record, indent=1) + "\n")
    return path


def read_statistics(path: str | Path, venv, training: bool = False):
    """A ``VecNormalize`` around ``venv`` with the statistics of a JSON file
    (:func:`save_statistics`); nothing in the file is executed.

    Raises:
        ValueError: not a statistics file, or statistics for other observations than
            ``venv``'s (other keys or shapes).
    """
    from stable_baselines3.common.vec_env import VecNormalize

    path = Path(path)
    try:
        record = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as error:
        raise ValueError(f"{str(path)!r} is not a statistics file: {error}") from error
    if not isinstance(record, dict) or record.get("format") != STATISTICS_FORMAT:
        raise ValueError(f"{str(path)!r} is not a statistics file (no {STATISTICS_FORMAT!r})")
    space = venv.observation_space
    try:
        settings = {
            key: record[key]
            for key in ("norm_obs", "norm_reward", "clip_obs", "clip_reward", "gamma", "epsilon")
        }
        obs_rms = record["obs_rms"]
        keys = record["norm_obs_keys"]
        if isinstance(space, gym.spaces.Dict) and settings["norm_obs"]:
            if not isinstance(obs_rms, dict) or "mean" in obs_rms:
                raise ValueError("they are for one array, the env observes a Dict")
            keys = list(keys or obs_rms)
            unknown = sorted(set(keys) - set(space.spaces) | set(keys) ^ set(obs_rms))
            if unknown:
                raise ValueError(f"their keys {unknown} are not the env's {sorted(space.spaces)}")
            expected = {key: space.spaces[key].shape for key in keys}
        else:
            if settings["norm_obs"] and (not isinstance(obs_rms, dict) or "mean" not in obs_rms):
                raise ValueError("they are for a Dict of arrays, the env observes one array")
            expected = {None: space.shape}
            obs_rms = {None: obs_rms} if settings["norm_obs"] else {}
        vec_normalize = VecNormalize(
            venv, training=training, norm_obs_keys=keys if keys else None, **settings
        )
        targets = vec_normalize.obs_rms if isinstance(space, gym.spaces.Dict) else None
        for key, moments in obs_rms.items():
            target = targets[key] if targets is not None else vec_normalize.obs_rms
            _set_moments(target, moments, expected[key], key)
        _set_moments(vec_normalize.ret_rms, record["ret_rms"], (), "return")
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{str(path)!r} does not fit this env's observations: {error}") from error
    return vec_normalize


def _set_moments(rms, moments: dict, shape: tuple, key: str | None) -> None:
    mean = np.asarray(moments["mean"], dtype=np.float64)
    var = np.asarray(moments["var"], dtype=np.float64)
    name = "the observation" if key is None else repr(key)
    if mean.shape != tuple(shape) or var.shape != tuple(shape):
        raise ValueError(
            f"{name} statistics have shape {mean.shape}, the env's {tuple(shape)} (statistics "
            "of another env?)"
        )
    if not (np.isfinite(mean).all() and np.isfinite(var).all() and (var >= 0).all()):
        raise ValueError(f"{name} statistics hold non-finite or negative variances")
    rms.mean, rms.var, rms.count = mean, var, float(moments["count"])


def load_statistics(saved: SavedModel, venv, *, trust_pickle: bool = False, training=False):
    """The ``VecNormalize`` statistics saved with a model, around ``venv``: its JSON file,
    else its pickle if ``trust_pickle``; ``None`` for a model trained without them.

    Raises:
        ValueError: the statistics are a pickle and ``trust_pickle`` is false, or they are
            missing for a model trained with them, or do not fit ``venv``.
    """
    if saved.statistics is not None and saved.statistics.exists():
        return read_statistics(saved.statistics, venv, training)
    pickled = saved.pickled_statistics
    if pickled is not None and pickled.exists():
        if not trust_pickle:
            raise ValueError(
                f"{str(pickled)!r} is a pickle, which runs code when read: refused. If you trust "
                f"where it came from, convert it once (python -m agents.convert_models "
                f"{saved.run_dir}) or pass --trust-pickle (trust_pickle=True)"
            )
        from stable_baselines3.common.vec_env import VecNormalize

        vec_normalize = VecNormalize.load(str(pickled), venv)
        vec_normalize.training = training
        return vec_normalize
    if saved.normalize:
        raise ValueError(
            f"{saved.path} was trained with VecNormalize but its statistics "
            f"{saved.statistics} are missing; evaluate a model saved with its statistics "
            "(final_model, checkpoints, or a best_model from a run of this version)"
        )
    return None


def convert_statistics(pickled: str | Path) -> Path:
    """Unpickle a ``VecNormalize`` file (**runs its code**: trusted files only) and write its
    statistics as JSON beside it (:func:`statistics_path`'s name for its model)."""
    from stable_baselines3.common.vec_env import VecNormalize

    pickled = Path(pickled)
    with open(pickled, "rb") as file:
        vec_normalize = pickle.load(file)
    if not isinstance(vec_normalize, VecNormalize):
        raise ValueError(
            f"{str(pickled)!r} holds a {type(vec_normalize).__name__}, not VecNormalize"
        )
    return save_statistics(vec_normalize, pickled.with_suffix(".json"))
