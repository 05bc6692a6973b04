"""Convert the model folders you trust to the format that loads without pickle.

    python -m agents.convert_models models/ppo_HingeProbePrimitive-v2_s3
    python -m agents.convert_models runs/ppo --remove-pickles

Earlier versions of this package, stable-baselines3 and rl_zoo3 save ``VecNormalize``
statistics as pickles (``vecnormalize.pkl``, ``best_model_vecnormalize.pkl``,
``rl_model_vecnormalize_<n>_steps.pkl``), which ``agents.evaluate`` and ``agents.selection``
read only with ``--trust-pickle`` (``docs/security.md``). This command reads every such
pickle under the folders given, **running whatever code it holds, so run it only on folders
you trust**, and writes the same statistics as JSON beside it (``agents.runs``); with
``--remove-pickles`` the pickle then goes. It then says of each model zip whether it now
loads without unpickling anything, and if not, why.
"""

from __future__ import annotations

import sys
from pathlib import Path

from .cli import check_env_id, make_env, make_parser, run_main
from .runs import convert_statistics, load_model, load_statistics, model_run, read_run

__all__ = ["convert_folder"]

#: The statistics pickles' names: stable-baselines3's, rl_zoo3's and agents.train's.
PICKLES = ("vecnormalize.pkl", "*_vecnormalize.pkl", "rl_model_vecnormalize_*_steps.pkl")


def convert_folder(folder: str | Path, remove_pickles: bool = False) -> dict[str, list]:
    """Convert every statistics pickle under ``folder`` to JSON (**unpickles them**) and
    check that each model zip under it loads without unpickling.

    Args:
        folder: a run folder, a model folder, or a folder of them.
        remove_pickles: delete each pickle once its JSON is written.

    Returns:
        ``converted``: (pickle, JSON) paths; ``safe``: the model zips that load without
        pickle; ``unsafe``: (zip, why not) for the others.

    Raises:
        ValueError: not a folder, or a pickle that is not VecNormalize statistics.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"folder must be an existing folder, got {str(folder)!r}")
    pickles = sorted({path for pattern in PICKLES for path in folder.rglob(pattern)})
    converted = []
    for pickled in pickles:
        converted.append((pickled, convert_statistics(pickled)))
        if remove_pickles:
            pickled.unlink()
    safe, unsafe = [], []
    for model in sorted(folder.rglob("*.zip")):
        try:
            _check_loads(model)
        except (ValueError, ImportError) as error:
            unsafe.append((model, str(error)))
        else:
            safe.append(model)
    return {"converted": converted, "safe": safe, "unsafe": unsafe}


def _check_loads(model: Path) -> None:
    """Load a model and its statistics the safe way, on the env of its run.

    Raises:
        ValueError: what loading it raises (``agents.runs``); a model whose run does not
            name its env cannot be checked.
    """
    from stable_baselines3.common.vec_env import DummyVecEnv

    run = read_run(model)
    if run.env_id is None:
        raise ValueError("no run config names its env, so it loads only on an env you name")
    check_env_id(f"the env_id of {model}'s run", run.env_id)
    saved = model_run(model)
    env = make_env(run.env_id, **run.env_kwargs)
    try:
        load_model(saved, env)
        load_statistics(saved, DummyVecEnv([lambda: env]))
    finally:
        env.close()


def main(argv: list[str] | None = None) -> dict[str, list]:
    parser = make_parser(__spec__.name if __spec__ else "agents.convert_models", __doc__)
    parser.add_argument(
        "folders", nargs="+", help="folders you trust: run folders, model folders, or their parents"
    )
    parser.add_argument(
        "--remove-pickles", action="store_true", help="delete each pickle once converted"
    )
    args = parser.parse_args(argv)
    results: dict[str, list] = {"converted": [], "safe": [], "unsafe": []}
    for folder in args.folders:
        for key, items in convert_folder(folder, args.remove_pickles).items():
            results[key].extend(items)
    for pickled, written in results["converted"]:
        removed = " (pickle removed)" if args.remove_pickles else ""
        print(f"{pickled} -> {written.name}{removed}")
    for model in results["safe"]:
        print(f"{model}: loads without unpickling")
    for model, why in results["unsafe"]:
        print(f"{model}: still needs --trust-pickle: {why}")
    if not any(results.values()):
        print("no statistics pickles and no models found")
    return results


if __name__ == "__main__":
    sys.exit(run_main(main))
