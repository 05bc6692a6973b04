"""Model selection on fixed episodes (``docs/design.md`` 12).

    python -m agents.selection runs/sweeps/v2_primitive/ppo/<id>_s*/*_model.zip --copy-to models
    python -m agents.selection runs/ppo/<run>/best_model.zip runs/ppo/<run>/final_model.zip

``agents.train``'s periodic evaluation picks ``best_model``. On episodes drawn afresh at each
evaluation, the difference between two evaluations is mostly the difference between their
episodes (the prior's error, which no policy sees, explains most of a return's variance).
:class:`FixedSeedVecEnv` makes every evaluation play the same episodes: each ``reset()``
starts over at the first seed of its list, and each episode that ends is followed by the next
seed's, so ``n`` episodes after a reset are always ``seeds[0] .. seeds[n - 1]``, the same
episodes ``agents.evaluate`` plays on those seeds.

After training, :func:`select_model` (the command above) picks among finished models, every
seed's ``best_model`` and ``final_model`` say, on more selection episodes than a periodic
evaluation can afford: 20-30 ranked the v2 primitive seeds unlike the test episodes did. Every
candidate and ``scripted`` play the same episodes from the selection range, never the test
range, and the lowest mean final position error wins; ``--copy-to`` copies the winner with
its ``VecNormalize`` statistics, its run's ``config.yml`` and the scores, ready to commit and
to test with ``agents.evaluate``.

Stable-Baselines3 is only in the ``[train]`` extra, so only ``agents`` imports this module.
"""

from __future__ import annotations

import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from .cli import make_parser, run_main
from .seeds import RANGE_SIZE, SELECTION_SEED

__all__ = [
    "FixedSeedVecEnv",
    "continue_evaluations",
    "copy_selected",
    "fixed_seed_evaluation",
    "select_model",
]

#: What :func:`select_model` ranks by, from ``agents.evaluate``'s summaries (lower wins).
SCORE = "position_mean_mm"


class FixedSeedVecEnv(VecEnvWrapper):
    """A one-env ``VecEnv`` whose episodes follow a fixed list of reset seeds (module
    docstring).

    Args:
        venv: a ``VecEnv`` of one env.
        seeds: the reset seeds, in order; the list repeats once exhausted.

    Raises:
        ValueError: a ``venv`` of more than one env, or no seeds.
    """

    def __init__(self, venv: VecEnv, seeds: Sequence[int]) -> None:
        if venv.num_envs != 1:
            raise ValueError(f"FixedSeedVecEnv needs a VecEnv of 1 env, got {venv.num_envs}")
        if len(seeds) == 0:
            raise ValueError("FixedSeedVecEnv needs at least one seed")
        super().__init__(venv)
        self.seeds = [int(s) for s in seeds]
        self.episode = 0

    def _reset_to(self, episode: int) -> np.ndarray:
        self.episode = episode
        self.venv.seed(self.seeds[episode % len(self.seeds)])
        return self.venv.reset()

    def reset(self):
        return self._reset_to(0)

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        if dones[0]:
            # The inner env has already reset itself unseeded: start the next seed instead
            # (the ended episode's last observation stays in the info).
            obs = self._reset_to(self.episode + 1)
        return obs, rewards, dones, infos


def fixed_seed_evaluation(
    eval_env, episodes: int, eval_freq: int, run_dir: Path, vecnormalize_file: Path | None
) -> EvalCallback:
    """SB3's ``EvalCallback`` on an env wrapped in :class:`FixedSeedVecEnv`: ``episodes``
    episodes every ``eval_freq`` calls, the best model saved in ``run_dir`` with, where given,
    its ``VecNormalize`` statistics in ``vecnormalize_file``."""
    return EvalCallback(
        eval_env,
        n_eval_episodes=episodes,
        eval_freq=eval_freq,
        best_model_save_path=str(run_dir),
        log_path=str(run_dir / "eval"),
        deterministic=True,
        callback_on_new_best=_SaveVecNormalize(vecnormalize_file) if vecnormalize_file else None,
    )


class _SaveVecNormalize(BaseCallback):
    """Saves the training statistics with a new best model (the ones its evaluation used)."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path

    def _on_step(self) -> bool:
        vec_normalize = self.model.get_vec_normalize_env()
        if vec_normalize is not None:
            vec_normalize.save(str(self.path))
        return True


def continue_evaluations(callback: EvalCallback, log: Path) -> None:
    """Give a resumed run's ``EvalCallback`` the evaluations made before the interruption,
    so that its log and its best model carry on rather than start again."""
    if not log.exists():
        return
    with np.load(log) as data:
        callback.evaluations_timesteps = data["timesteps"].tolist()
        callback.evaluations_results = data["results"].tolist()
        callback.evaluations_length = data["ep_lengths"].tolist()
    if callback.evaluations_results:
        callback.best_mean_reward = float(np.max(np.mean(callback.evaluations_results, axis=1)))


def select_model(
    models: Sequence[str | Path],
    episodes: int = 200,
    seed: int = SELECTION_SEED,
    out: str | Path = "results/selection",
    workers: int = 1,
    copy_to: str | Path | None = None,
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

    Returns:
        ``selection.json``'s content: ``env_id``, ``seeds``, ``score``, each model's score,
        ``selected`` (its path) and ``copied_to``.

    Raises:
        ValueError: no models, the scripted policy among them, or episodes outside the
            selection range.
    """
    from .evaluate import evaluate

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
    evaluate(
        ["scripted", *names], episodes=episodes, seed=seed, out=out, plot=False, workers=workers
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
    from .evaluate import model_run, vecnormalize_path

    selected = Path(record["selected"])
    run = model_run(selected)
    target = Path(copy_to) / f"{run['algo']}_{Path(run['run_dir']).name}"
    target.mkdir(parents=True, exist_ok=True)
    shutil.copy2(selected, target / selected.name)
    statistics = vecnormalize_path(selected)
    if statistics.exists():
        shutil.copy2(statistics, target / statistics.name)
    shutil.copy2(Path(run["run_dir"]) / "config.yml", target / "config.yml")
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
    args = parser.parse_args(argv)
    record = select_model(
        args.models, args.episodes, args.seed, args.out, args.workers, args.copy_to
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
