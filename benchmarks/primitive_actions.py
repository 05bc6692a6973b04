"""What primitive policies do: how often they turn and probe, and how far (docs/design.md 12).

Plays each policy (``scripted`` or a model path, as ``agents.evaluate`` names them) on the
same seeded episodes of a primitive id and prints, per policy, the final position error, the
turns and probes per episode, and the mean and std of the clipped action components that set
a primitive's size: a turn's drag (``a[1]``, 1 = 20 mm), a probe's move across the edge
(``a[1]``, 1 = 3 mm) and any primitive's move along it (``a[2]``). A learned policy that
beats the script shows here how it differs. The default seeds lie in the selection range
(``agents.seeds``), never in the test range.

Run: ``python benchmarks/primitive_actions.py --env ID --policies scripted MODEL.zip
[--episodes N] [--seed S]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

# Measure the checkout this file is in (git worktrees share one virtual environment).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents.cli import make_env  # noqa: E402
from agents.episodes import run_episode, summarize  # noqa: E402
from agents.policies import make_policy, resolve_policies  # noqa: E402
from agents.resources import torch_threads  # noqa: E402
from agents.seeds import SELECTION_SEED  # noqa: E402


class Recorder:
    """A policy that acts as ``policy`` does and keeps each action, clipped to the action
    space, for the statistics; the episodes are ``agents.episodes.run_episode``'s."""

    def __init__(self, policy) -> None:
        self.policy = policy
        self.actions: list[np.ndarray] = []

    def reset(self) -> None:
        self.policy.reset()

    def get_action(self, obs) -> np.ndarray:
        action = self.policy.get_action(obs)
        self.actions.append(np.clip(np.asarray(action, dtype=float), -1.0, 1.0))
        return action


def play(name: str, env_id: str, seeds: range) -> dict[str, float]:
    """One policy's episodes and the statistics of its actions."""
    (spec,) = resolve_policies([name], env_id)
    env = make_env(spec.env_id, **spec.env_kwargs)
    records, turns, probes, drags, across, along = [], [], [], [], [], []
    with torch_threads(1):
        for seed in seeds:
            recorder = Recorder(make_policy(name, env))
            records.append(run_episode(env, recorder, seed))
            actions = np.array(recorder.actions)
            turn = actions[:, 0] >= 0.0
            turns.append(np.sum(turn))
            probes.append(np.sum(~turn))
            drags.extend(actions[turn, 1])
            across.extend(actions[~turn, 1])
            along.extend(actions[:, 2])
    env.close()
    return {
        "error_mm": summarize(records)["position_mean_mm"],
        "turns": float(np.mean(turns)),
        "probes": float(np.mean(probes)),
        "drag": (float(np.mean(drags)), float(np.std(drags))),
        "across": (float(np.mean(across)), float(np.std(across))),
        "along": (float(np.mean(along)), float(np.std(along))),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="tactile_gym/HingeProbePrimitive-v2")
    parser.add_argument("--policies", nargs="+", default=["scripted"])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=SELECTION_SEED + 400)
    args = parser.parse_args(argv)
    seeds = range(args.seed, args.seed + args.episodes)
    print(f"{args.env}, {args.episodes} episodes, seeds {seeds.start}..{seeds.stop - 1}\n")
    print(
        "| policy | final position error mean (mm) | turns | probes | turn drag a[1] "
        "| probe across a[1] | along a[2] |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in args.policies:
        row = play(name, args.env, seeds)
        spread = {k: f"{row[k][0]:+.2f} +- {row[k][1]:.2f}" for k in ("drag", "across", "along")}
        print(
            f"| {name} | {row['error_mm']:.2f} | {row['turns']:.1f} | {row['probes']:.1f} | "
            f"{spread['drag']} | {spread['across']} | {spread['along']} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
