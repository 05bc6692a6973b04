"""Evaluate policies on a tactile_gym env over seeded episodes.

    python -m agents.evaluate --policies random scripted --episodes 20
    python -m agents.evaluate --policies scripted runs/ppo/HingeProbe-v1_s0_.../best_model.zip
    python -m agents.evaluate --policies scripted --episodes 1000 --workers 8     # on Ray
    python -m agents.evaluate --policies scripted models/<run>/final_model.zip --video videos

A policy is ``random``, ``scripted`` or the path of a stable-baselines3 model saved by
``agents.train`` or by ``rl_zoo3.train`` (``agents.policies``). A model runs on an env made
with its run's ``env_kwargs`` (from the run's ``config.yml``, or rl_zoo3's ``args.yml``,
updated by ``--env-kwargs``) and with the ``VecNormalize`` statistics saved with that model
(``agents.runs``). Loading a model runs none of its folder's code: old pickled statistics,
rl_zoo3 runs and algorithms other than those agents.train runs need ``--trust-pickle``
(``docs/security.md``). Episode k of every policy uses seed ``seed + k`` for the env and the
action space, so all policies meet the same objects and every episode depends on its seed
alone: ``--workers`` spreads episodes over Ray workers with the same results as a serial
run. The script prints a markdown table and writes ``evaluation.json`` (strict JSON: NaN is
written as ``null``) and ``error_vs_step.png`` to ``--out``, and with ``--video DIR`` an MP4
per policy of its first episodes, at real time. The seeds default to the test range, which
no training or selection step uses (``agents.seeds``); with ``scripted`` among the policies
the script also prints each other policy's paired difference from it with a bootstrap
interval (``agents.compare``).

A model runs only on the id it was trained on (a primitive model also on its 6-D id, whose
steps its primitives then drive) unless ``--force``; without a run config beside it, its
algorithm comes from its zip, and an env whose spaces differ from the model's is refused.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np

from .cli import (
    DEFAULT_ENV_ID,
    KEY_VALUE_HELP,
    KNOWN_ENV_IDS,
    KeyValue,
    json_safe,
    make_parser,
    progress_bar,
    run_main,
)
from .compare import REFERENCE, paired_table
from .episodes import REACH_THRESHOLD, EpisodeRecord, record_video, run_episodes, summarize
from .plots import plot_errors
from .policies import BUILTIN_POLICIES, PolicySpec, check_policies, resolve_policies
from .runs import model_run
from .seeds import TEST_SEED

__all__ = ["evaluate"]


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
    return "\n".join([header, *rows, *_joint_table(summaries)])


def _joint_table(summaries: dict[str, dict[str, float]]) -> list[str]:
    """The joint ids' figures (``agents.episodes.joint_figures``) as a second table."""
    if any("type_accuracy" not in s for s in summaries.values()):
        return []
    rows = [
        f"| {name} | {s['type_accuracy']:.1%} | {_fmt(s['revolute_position_mean_mm'], '.2f')} | "
        f"{_fmt(s['prismatic_angle_mean_deg'], '.2f')} |"
        for name, s in summaries.items()
    ]
    header = (
        "| policy | type accuracy | revolute: final axis position error mean (mm) |"
        " prismatic: final direction error mean (deg) |\n|---|---|---|---|"
    )
    return ["", header, *rows]


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
    trust_pickle: bool = False,
    video: str | Path | None = None,
    video_episodes: int = 1,
) -> dict[str, dict[str, float]]:
    """Evaluate each policy over the same seeded episodes; write JSON, a plot and videos.

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
        trust_pickle: let the models' files be unpickled (old statistics, rl_zoo3 runs,
            other algorithms): only for folders you trust (``docs/security.md``).
        video: a folder for one MP4 per policy of its first episodes (``<label>.mp4``, the
            label's ``/`` as ``_``); ``None``: no videos.
        video_episodes: episodes in each video, the evaluation's first.

    Returns:
        The summary of each policy, by label.

    Raises:
        ValueError: a bad argument, or a model that does not load (``agents.runs``), before
            any episode is played.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if video is not None and not 1 <= video_episodes <= episodes:
        raise ValueError(
            f"video_episodes must be in 1..{episodes} (episodes), got {video_episodes}"
        )
    specs = resolve_policies(policies, env_id, env_kwargs, force, trust_pickle)
    check_policies(specs)
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
            else f"{model_run(Path(s.name)).algo.upper()} {s.label}"
            for s in specs
        }
        shown = {names[label]: recs for label, recs in records.items()}
        plot_errors(shown, out / "error_vs_step.png", specs[0].env_id, REACH_THRESHOLD)
    for spec in specs if video is not None else []:
        record_video(spec, seeds[:video_episodes], video_path(video, spec.label))
    return summaries


def video_path(folder: str | Path, label: str) -> Path:
    """Where ``evaluate`` writes the video of the policy labelled ``label``."""
    return Path(folder) / (label.replace("/", "_") + ".mp4")


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
    parser.add_argument(
        "--trust-pickle",
        action="store_true",
        help="let the models' files be unpickled, which can run code they hold (old "
        "vecnormalize.pkl statistics, rl_zoo3 runs, algorithms agents.train does not run): only "
        "for folders you trust; python -m agents.convert_models converts a trusted folder once",
    )
    parser.add_argument(
        "--video",
        default=None,
        metavar="DIR",
        help="write an MP4 per policy of its first episodes here (<policy label>.mp4, real time)",
    )
    parser.add_argument(
        "--video-episodes", type=int, default=1, help="episodes in each video (with --video)"
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
        trust_pickle=args.trust_pickle,
        video=args.video,
        video_episodes=args.video_episodes,
    )
    data = json.loads((Path(args.out) / "evaluation.json").read_text())
    last = args.seed + args.episodes - 1
    print(f"{data['env_id']}, {args.episodes} episodes, seeds {args.seed}..{last}")
    print(markdown_table(summaries))
    if REFERENCE in data["episodes_detail"] and len(data["episodes_detail"]) > 1:
        print(f"\n{paired_table(data['episodes_detail'])}")
    print(f"wrote {Path(args.out) / 'evaluation.json'}")
    if args.video is not None:
        print(f"wrote {', '.join(str(video_path(args.video, label)) for label in summaries)}")
    return summaries


if __name__ == "__main__":
    sys.exit(run_main(main))
