"""Model selection on fixed episodes (``docs/design.md`` 12).

    python -m agents.selection runs/sweeps/v2_primitive/ppo/<id>_s*/*_model.zip --copy-to models
    python -m agents.selection runs/ppo/<run>/best_model.zip runs/ppo/<run>/final_model.zip
    python -m agents.selection --per-run runs/sweeps/v2_primitive/ppo/<id>_s*

``agents.train``'s periodic evaluation picks ``best_model``, on the same episodes every time
(``agents.callbacks.FixedSeedVecEnv``).

After training, :func:`select_model` (the first two commands) picks among finished models,
every seed's ``best_model`` and ``final_model`` say, on more selection episodes than a
periodic evaluation can afford: 20-30 ranked the v2 primitive seeds unlike the test episodes
did. Every candidate and ``scripted`` play the same episodes from the selection range, never
the test range, and the best score wins: the lowest mean final position error, or, for runs
trained without the truth (``agents.train --truth-free``), the highest mean return, which
their reward makes truth-free (:data:`SCORES`). ``--copy-to`` copies the winner with its
``VecNormalize`` statistics, its run's ``config.yml`` and the scores, ready to commit and to
test with ``agents.evaluate``.

:func:`select_per_run` (``--per-run``) is the recipe's measure over seeds in one command: in
each run folder it picks among the checkpoints, ``best_model`` and ``final_model`` on the
selection episodes (one evaluation for all runs' candidates), then tests each run's pick
against ``scripted`` on the test episodes and reports the mean over the runs of their mean
final position errors, its ratio to scripted's, and a 95 % bootstrap interval across runs of
the mean paired difference from scripted.

The models load as ``agents.evaluate`` loads them: without unpickling anything unless
``--trust-pickle`` (``docs/security.md``).
"""

from __future__ import annotations

import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import evaluate
from .cli import make_parser, run_main
from .paired import bootstrap_ci
from .runs import model_run, read_run
from .seeds import RANGE_SIZE, SELECTION_SEED, TEST_SEED

__all__ = ["SCORES", "copy_selected", "run_candidates", "select_model", "select_per_run"]

#: What a selection can rank by, from ``agents.evaluate``'s summaries, and whether higher
#: wins: the mean final position error (the truth), or the mean return (truth-free for a
#: run trained with ``--truth-free``, whose env's reward scores the predicted error).
SCORES = {"position_mean_mm": False, "return_mean": True}


def _score_of(models: Sequence[str], score: str) -> str:
    """The score to rank ``models`` by: ``score``, or for ``"auto"`` the mean return if every
    model's run trained without the truth, else the mean final position error.

    Raises:
        ValueError: an unknown score, or ``"auto"`` over truth-free runs mixed with others.
    """
    if score != "auto":
        if score not in SCORES:
            raise ValueError(f"score must be 'auto' or one of {sorted(SCORES)}, got {score!r}")
        return score
    truth_free = {read_run(Path(m)).truth_free for m in models}
    if len(truth_free) > 1:
        raise ValueError(
            "the models mix runs trained with and without the truth; select them apart, or "
            f"name the score ({', '.join(SCORES)})"
        )
    return "return_mean" if truth_free.pop() else "position_mean_mm"


def _check_selection_seeds(seed: int, episodes: int) -> int:
    last = seed + episodes - 1
    if episodes < 1 or seed < SELECTION_SEED or last >= SELECTION_SEED + RANGE_SIZE:
        raise ValueError(
            f"selection episodes must lie in the selection range [{SELECTION_SEED}, "
            f"{SELECTION_SEED + RANGE_SIZE - 1}] (agents.seeds), got seeds {seed}..{last}"
        )
    return last


def _with_scripted(
    names: list[str], episodes: int, seed: int, out: Path, workers: int, trust_pickle: bool
) -> dict:
    """``agents.evaluate``'s result (``evaluation.json``) of ``scripted`` and the models on
    the episodes from ``seed``."""
    evaluate.evaluate(
        ["scripted", *names],
        episodes=episodes,
        seed=seed,
        out=out,
        plot=False,
        workers=workers,
        trust_pickle=trust_pickle,
    )
    return json.loads((out / "evaluation.json").read_text())


def _scores(
    names: list[str], episodes: int, seed: int, out: Path, workers: int, trust_pickle: bool,
    score: str,
) -> tuple[dict, dict[str, float], float]:  # fmt: skip
    """Play ``scripted`` and every model on the selection episodes; returns the evaluation,
    each model's score by its path, and scripted's."""
    result = _with_scripted(names, episodes, seed, out, workers, trust_pickle)
    scores = {
        spec["name"]: result["summaries"][label][score]
        for label, spec in result["policies"].items()
    }
    return result, scores, scores.pop("scripted")


def _best(scores: dict[str, float], score: str) -> str:
    pick = max if SCORES[score] else min
    return pick(scores, key=scores.get)


def _check_names(models: Sequence[str | Path]) -> list[str]:
    names = [str(m) for m in models]
    if not names:
        raise ValueError("select_model needs at least one model path, got none")
    if "scripted" in names:
        raise ValueError("models must be model paths; scripted is always played as the reference")
    return names


def select_model(
    models: Sequence[str | Path],
    episodes: int = 200,
    seed: int = SELECTION_SEED,
    out: str | Path = "results/selection",
    workers: int = 1,
    copy_to: str | Path | None = None,
    trust_pickle: bool = False,
    score: str = "auto",
) -> dict:
    """Play every model and ``scripted`` on the same selection episodes and pick the model
    with the best score (module docstring).

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
        score: ``"auto"`` or one of :data:`SCORES` (``"auto"``: the mean return for
            truth-free runs, else the mean final position error).

    Returns:
        ``selection.json``'s content: ``env_id``, ``seeds``, ``score``, each model's score,
        ``selected`` (its path) and ``copied_to``.

    Raises:
        ValueError: no models, the scripted policy among them, episodes outside the
            selection range, a bad score, or a model that does not load.
    """
    names = _check_names(models)
    last = _check_selection_seeds(seed, episodes)
    score = _score_of(names, score)
    out = Path(out)
    result, scores, scripted = _scores(names, episodes, seed, out, workers, trust_pickle, score)
    record = {
        "env_id": result["env_id"],
        "seeds": [seed, last],
        "score": score,
        "scripted": scripted,
        "scores": dict(sorted(scores.items(), key=lambda item: item[1], reverse=SCORES[score])),
        "selected": _best(scores, score),
        "copied_to": None,
    }
    if copy_to is not None:
        copy_selected(record, copy_to)
    (out / "selection.json").write_text(json.dumps(record, indent=1))
    return record


def run_candidates(run_dir: str | Path) -> list[Path]:
    """A run's models, the candidates of its pick: its checkpoints in step order, then
    ``best_model`` and ``final_model`` (those it has).

    Raises:
        ValueError: a folder that holds no model.
    """
    run_dir = Path(run_dir)
    checkpoints = sorted(
        run_dir.glob("checkpoints/rl_model_*_steps.zip"),
        key=lambda p: int(p.stem.removeprefix("rl_model_").removesuffix("_steps")),
    )
    found = [*checkpoints, *(run_dir / f"{m}.zip" for m in ("best_model", "final_model"))]
    found = [p for p in found if p.is_file()]
    if not found:
        raise ValueError(f"{str(run_dir)!r} holds no model (checkpoints, best_model, final_model)")
    return found


def select_per_run(
    run_dirs: Sequence[str | Path],
    episodes: int = 200,
    seed: int = SELECTION_SEED,
    test_episodes: int = 200,
    test_seed: int = TEST_SEED,
    out: str | Path = "results/selection",
    workers: int = 1,
    trust_pickle: bool = False,
    score: str = "auto",
) -> dict:
    """Each run's pick among its own models on the selection episodes, then every pick
    tested against ``scripted`` (module docstring).

    Args:
        run_dirs: run folders of ``agents.train`` (one per training seed), of one env id.
        episodes: selection episodes per candidate, from ``seed``, in the selection range.
        seed: the first selection seed.
        test_episodes: test episodes per pick, from ``test_seed``; 0: no test.
        test_seed: the first test seed.
        out: folder of ``selection/evaluation.json``, ``test/evaluation.json`` and
            ``per_run.json``.
        workers: Ray tasks per policy; 1 runs everything in this process.
        trust_pickle: let the models' files be unpickled (``agents.evaluate``).
        score: as :func:`select_model`'s.

    Returns:
        ``per_run.json``'s content: per run its scores and pick, and with a test the picks'
        and scripted's mean final errors (mm), the mean over runs, its ratio to scripted's,
        and the bootstrap interval across runs of the mean paired difference (mm).

    Raises:
        ValueError: no run folders, a folder without models, bad seeds or a bad score.
    """
    if not run_dirs:
        raise ValueError("select_per_run needs at least one run folder, got none")
    last = _check_selection_seeds(seed, episodes)
    candidates = {str(Path(r)): [str(p) for p in run_candidates(r)] for r in run_dirs}
    names = [n for group in candidates.values() for n in group]
    score = _score_of(names, score)
    out = Path(out)
    result, scores, scripted = _scores(
        names, episodes, seed, out / "selection", workers, trust_pickle, score
    )
    runs = {
        run: {"scores": {n: scores[n] for n in group}, "selected": _best(
            {n: scores[n] for n in group}, score)}
        for run, group in candidates.items()
    }  # fmt: skip
    record = {
        "env_id": result["env_id"],
        "seeds": [seed, last],
        "score": score,
        "scripted": scripted,
        "runs": runs,
        "test": None,
    }
    if test_episodes > 0:
        record["test"] = _test_picks(
            [r["selected"] for r in runs.values()], test_episodes, test_seed, out / "test",
            workers, trust_pickle,
        )  # fmt: skip
    (out / "per_run.json").write_text(json.dumps(record, indent=1))
    return record


def _test_picks(
    picks: list[str], episodes: int, seed: int, out: Path, workers: int, trust_pickle: bool
) -> dict:
    """The picks and ``scripted`` on the test episodes: each pick's mean final error and mean
    paired difference from scripted (mm), their mean over picks, the ratio to scripted's mean,
    and the 95 % bootstrap interval across picks of the mean paired difference."""
    result = _with_scripted(picks, episodes, seed, out, workers, trust_pickle)
    label_of = {spec["name"]: label for label, spec in result["policies"].items()}
    detail = result["episodes_detail"]

    def finals(label: str) -> np.ndarray:
        return 1e3 * np.array([e["position_error"][-1] for e in detail[label]])

    base = finals(label_of["scripted"])
    errors = {pick: float(finals(label_of[pick]).mean()) for pick in picks}
    differences = {pick: float((finals(label_of[pick]) - base).mean()) for pick in picks}
    low, high = bootstrap_ci(list(differences.values()))
    mean = float(np.mean(list(errors.values())))
    return {
        "seeds": [seed, seed + episodes - 1],
        "scripted_mm": float(base.mean()),
        "position_mean_mm": errors,
        "paired_difference_mm": differences,
        "mean_over_runs_mm": mean,
        "ratio_to_scripted": mean / float(base.mean()),
        "paired_difference_ci_mm": [low, high],
    }


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
    parser.add_argument(
        "models", nargs="+", help="model paths saved by agents.train (with --per-run: run folders)"
    )
    parser.add_argument(
        "--per-run",
        action="store_true",
        help="pick each run folder's model among its checkpoints, best_model and final_model, "
        "then test the picks against scripted",
    )
    parser.add_argument("--episodes", type=int, default=200, help="selection episodes per model")
    parser.add_argument(
        "--seed",
        type=int,
        default=SELECTION_SEED,
        help="seed of the first episode; all must lie in the selection range (agents.seeds)",
    )
    parser.add_argument(
        "--test-episodes",
        type=int,
        default=200,
        help="with --per-run, test episodes per pick (0: no test)",
    )
    parser.add_argument(
        "--score",
        default="auto",
        choices=["auto", *SCORES],
        help="what ranks the models: auto is return_mean for runs trained with --truth-free, "
        "else position_mean_mm",
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
    if args.per_run:
        if args.copy_to is not None:
            raise ValueError("--copy-to copies one winner; it does not go with --per-run")
        record = select_per_run(
            args.models, args.episodes, args.seed, args.test_episodes, TEST_SEED, args.out,
            args.workers, args.trust_pickle, args.score,
        )  # fmt: skip
        print(_per_run_table(record))
        return record
    record = select_model(
        args.models,
        args.episodes,
        args.seed,
        args.out,
        args.workers,
        args.copy_to,
        args.trust_pickle,
        args.score,
    )
    first, last = record["seeds"]
    print(f"{record['env_id']}, {args.episodes} selection episodes, seeds {first}..{last}")
    print(f"| model | {record['score']} |\n|---|---|")
    print(f"| scripted | {record['scripted']:.3f} |")
    for name, score in record["scores"].items():
        print(f"| {name}{' (selected)' if name == record['selected'] else ''} | {score:.3f} |")
    if record["copied_to"]:
        print(f"copied the selected model to {record['copied_to']}")
    return record


def _per_run_table(record: dict) -> str:
    """:func:`select_per_run`'s result in a few lines and a table."""
    first, last = record["seeds"]
    lines = [
        f"{record['env_id']}: each run's pick by {record['score']} on selection seeds "
        f"{first}..{last} (scripted {record['scripted']:.3f})"
    ]
    test = record["test"]
    if test is None:
        lines += [f"  {run}: {r['selected']}" for run, r in record["runs"].items()]
        return "\n".join(lines)
    t_first, t_last = test["seeds"]
    lines += [
        f"tested on seeds {t_first}..{t_last}",
        "| run's pick | final error (mm) | paired difference from scripted (mm) |",
        "|---|---|---|",
    ]
    for run in record["runs"].values():
        pick = run["selected"]
        lines.append(
            f"| {pick} | {test['position_mean_mm'][pick]:.2f} | "
            f"{test['paired_difference_mm'][pick]:+.2f} |"
        )
    low, high = test["paired_difference_ci_mm"]
    lines += [
        f"| scripted | {test['scripted_mm']:.2f} | - |",
        f"mean over {len(record['runs'])} runs: {test['mean_over_runs_mm']:.2f} mm, "
        f"{test['ratio_to_scripted']:.2f}x scripted's; mean paired difference, 95 % bootstrap "
        f"CI across runs: [{low:+.2f}, {high:+.2f}] mm",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(run_main(main))
