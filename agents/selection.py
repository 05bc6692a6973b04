"""Model selection on fixed episodes (``docs/design.md`` 12).

    python -m agents.selection runs/sweeps/v2_primitive/ppo/<id>_s*/*_model.zip --copy-to models
    python -m agents.selection runs/ppo/<run>/best_model.zip runs/ppo/<run>/final_model.zip

``agents.train``'s periodic evaluation picks ``best_model``, on the same episodes every time
(``agents.callbacks.FixedSeedVecEnv``).

After training, :func:`select_model` (the command above) picks among finished models, every
seed's ``best_model`` and ``final_model`` say, on more selection episodes than a periodic
evaluation can afford: 20-30 ranked the v2 primitive seeds unlike the test episodes did. Every
candidate and ``scripted`` play the same episodes from the selection range, never the test
range, and the lowest mean final position error wins; ``--copy-to`` copies the winner with
its ``VecNormalize`` statistics, its run's ``config.yml`` and the scores, ready to commit and
to test with ``agents.evaluate``. The models load as ``agents.evaluate`` loads them: without
unpickling anything unless ``--trust-pickle`` (``docs/security.md``).
"""

from __future__ import annotations

import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from . import evaluate
from .cli import make_parser, run_main
from .runs import model_run
from .seeds import RANGE_SIZE, SELECTION_SEED

__all__ = ["copy_selected", "select_model"]

#: What :func:`select_model` ranks by, from ``agents.evaluate``'s summaries (lower wins).
SCORE = "position_mean_mm"


def select_model(
    models: Sequence[str | Path],
    episodes: int = 200,
    seed: int = SELECTION_SEED,
    out: str | Path = "results/selection",
    workers: int = 1,
    copy_to: str | Path | None = None,
    trust_pickle: bool = False,
) -> dict:
    """Play every model and ``scripted`` on the same selection episodes and pick the model
    with the lowest mean final position error (module docstring).

    Args:
        models: paths of models saved by ``agents.train``, all of one env id.
        episodes: episodes per model, seeds ``seed .. seed + episodes - 1``.
        seed: the first seed; the episodes must lie in the selection range
            (``agents.seeds``), so that the test episodes stay unseen.
        out: folder of ``evaluation.json`` (``agents.evaluate``'s) and ``selection.json``.
        workers: Ray tasks per policy; 1 runs everything in this process.
        copy_to: where a copy of the winner goes, in ``<copy_to>/<algo>_<run folder>/``: the
            model, its ``VecNormalize`` statistics, the run's ``config.yml`` and
            ``selection.json``. None: no copy.
        trust_pickle: let the models' files be unpickled (``agents.evaluate``).

    Returns:
        ``selection.json``'s content: ``env_id``, ``seeds``, ``score``, each model's score,
        ``selected`` (its path) and ``copied_to``.

    Raises:
        ValueError: no models, the scripted policy among them, episodes outside the
            selection range, or a model that does not load.
    """
    names = [str(m) for m in models]
    if not names:
        raise ValueError("select_model needs at least one model path, got none")
    if "scripted" in names:
        raise ValueError("models must be model paths; scripted is always played as the reference")
    last = seed + episodes - 1
    if episodes < 1 or seed < SELECTION_SEED or last >= SELECTION_SEED + RANGE_SIZE:
        raise ValueError(
            f"selection episodes must lie in the selection range [{SELECTION_SEED}, "
            f"{SELECTION_SEED + RANGE_SIZE - 1}] (agents.seeds), got seeds {seed}..{last}"
        )
    out = Path(out)
    evaluate.evaluate(
        ["scripted", *names],
        episodes=episodes,
        seed=seed,
        out=out,
        plot=False,
        workers=workers,
        trust_pickle=trust_pickle,
    )
    result = json.loads((out / "evaluation.json").read_text())
    scores = {
        spec["name"]: result["summaries"][label][SCORE]
        for label, spec in result["policies"].items()
    }
    scripted = scores.pop("scripted")
    selected = min(scores, key=scores.get)
    record = {
        "env_id": result["env_id"],
        "seeds": [seed, last],
        "score": SCORE,
        "scripted": scripted,
        "scores": dict(sorted(scores.items(), key=lambda item: item[1])),
        "selected": selected,
        "copied_to": None,
    }
    if copy_to is not None:
        copy_selected(record, copy_to)
    (out / "selection.json").write_text(json.dumps(record, indent=1))
    return record


def copy_selected(record: dict, copy_to: str | Path) -> Path:
    """Copy ``record["selected"]`` (a :func:`select_model` result) into
    ``<copy_to>/<algo>_<run folder>/`` with its ``VecNormalize`` statistics, its run's
    ``config.yml`` and the record as ``selection.json``; sets ``record["copied_to"]``.

    Returns:
        The folder of the copy.
    """
    selected = Path(record["selected"])
    run = model_run(selected)
    target = Path(copy_to) / f"{run.algo}_{run.run_dir.name}"
    target.mkdir(parents=True, exist_ok=True)
    shutil.copy2(selected, target / selected.name)
    # The statistics the evaluation used: the JSON file, else a pickle it was trusted with.
    for statistics in (run.statistics, run.pickled_statistics):
        if statistics.exists():
            shutil.copy2(statistics, target / statistics.name)
            break
    shutil.copy2(run.run_dir / "config.yml", target / "config.yml")
    record["copied_to"] = str(target)
    (target / "selection.json").write_text(json.dumps(record, indent=1))
    return target


def main(argv: list[str] | None = None) -> dict:
    parser = make_parser(__spec__.name if __spec__ else "agents.selection", __doc__)
    parser.add_argument("models", nargs="+", help="model paths saved by agents.train")
    parser.add_argument("--episodes", type=int, default=200, help="selection episodes per model")
    parser.add_argument(
        "--seed",
        type=int,
        default=SELECTION_SEED,
        help="seed of the first episode; all must lie in the selection range (agents.seeds)",
    )
    parser.add_argument("--out", default="results/selection", help="folder of selection.json")
    parser.add_argument("--workers", type=int, default=1, help="Ray tasks per policy")
    parser.add_argument("--copy-to", default=None, help="copy the winner into a folder here")
    parser.add_argument(
        "--trust-pickle",
        action="store_true",
        help="let the models' files be unpickled, which can run code they hold: only for "
        "folders you trust (as agents.evaluate --trust-pickle)",
    )
    args = parser.parse_args(argv)
    record = select_model(
        args.models,
        args.episodes,
        args.seed,
        args.out,
        args.workers,
        args.copy_to,
        args.trust_pickle,
    )
    first, last = record["seeds"]
    print(f"{record['env_id']}, {args.episodes} selection episodes, seeds {first}..{last}")
    print("| model | mean final position error (mm) |\n|---|---|")
    print(f"| scripted | {record['scripted']:.3f} |")
    for name, score in record["scores"].items():
        print(f"| {name}{' (selected)' if name == record['selected'] else ''} | {score:.3f} |")
    if record["copied_to"]:
        print(f"copied the selected model to {record['copied_to']}")
    return record


if __name__ == "__main__":
    sys.exit(run_main(main))
