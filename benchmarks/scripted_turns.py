"""How the scripted policy's final error depends on the turn it aims at (docs/design.md 12).

The scripted prober turns the link by ``ProberConfig.step_angle`` between measurements; this
plays it with several values on the same seeded episodes of a primitive id and prints the
final position error, success and measurements per value: the headroom a learned policy could
take by turning more. Beside the true error it prints the estimator's own predicted position
std at the episode's end, what a truth-free reward (issue 18) would see. The default seeds lie
in the selection range (``agents.seeds``), never in the test range.

Run: ``python benchmarks/scripted_turns.py [--env ID] [--episodes N] [--seed S]
[--env-kwargs KEY:VALUE ...]``; e.g. ``--env-kwargs "sensor: {force_noise_std: 0,
moment_noise_std: 0, force_drift: 0, moment_drift: 0}"`` plays it with a noise-free sensor.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

# Measure the checkout this file is in (git worktrees share one virtual environment).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym  # noqa: E402

import tactile_gym  # noqa: E402, F401 - registers the envs
from agents.cli import KEY_VALUE_HELP, KeyValue  # noqa: E402
from agents.episodes import run_episode, summarize  # noqa: E402
from agents.scripted import ProberConfig, scripted_policy  # noqa: E402
from agents.seeds import SELECTION_SEED  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="tactile_gym/HingeProbePrimitive-v2")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=SELECTION_SEED + 300)
    parser.add_argument("--angles", type=float, nargs="+", default=[16.0, 20.0, 24.0, 32.0])
    parser.add_argument("--env-kwargs", nargs="+", action=KeyValue, default={}, help=KEY_VALUE_HELP)
    args = parser.parse_args(argv)
    env = gym.make(args.env, **args.env_kwargs)
    seeds = range(args.seed, args.seed + args.episodes)
    print(f"{args.env}, {args.episodes} episodes, seeds {seeds.start}..{seeds.stop - 1}\n")
    print(
        "| step_angle (deg) | final position error mean / median (mm) "
        "| predicted position std, mean (mm) | success | measurements |"
    )
    print("|---|---|---|---|---|")
    default = float(np.rad2deg(ProberConfig().step_angle))
    for angle in args.angles:
        policy = scripted_policy(env, ProberConfig(step_angle=float(np.deg2rad(angle))))
        records, predicted = [], []
        for seed in seeds:
            records.append(run_episode(env, policy, seed))
            # The episode's last estimate, still the env's after the episode.
            predicted.append(env.unwrapped.pipeline.estimate.position_std)
        row = summarize(records)
        label = f"{angle:g}{' (default)' if np.isclose(angle, default) else ''}"
        print(
            f"| {label} | {row['position_mean_mm']:.2f} / {row['position_median_mm']:.2f} | "
            f"{1e3 * np.mean(predicted):.2f} | {100 * row['success_rate']:.0f} % | "
            f"{row['measurements_mean']:.1f} |",
            flush=True,
        )
    env.close()


if __name__ == "__main__":
    main()
