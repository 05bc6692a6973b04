"""How the scripted policy's final error depends on the turn it aims at (docs/design.md 12).

The scripted prober turns the link by ``ProberConfig.step_angle`` between measurements; this
plays it with several values on the same seeded episodes of a primitive id and prints the
final position error, success and measurements per value: the headroom a learned policy could
take by turning more. The default seeds lie in the selection range (``agents.seeds``), never
in the test range.

Run: ``python benchmarks/scripted_turns.py [--env ID] [--episodes N] [--seed S]``.
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
from agents.scripted import PrimitiveProber, ProberConfig  # noqa: E402
from agents.seeds import SELECTION_SEED  # noqa: E402


def play(env, config: ProberConfig, seeds: range) -> dict[str, float]:
    """Final errors (mm), success and measurements of the prober over ``seeds``."""
    prober = PrimitiveProber(env.get_wrapper_attr("scales"), config)
    errors, measurements = [], []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        prober.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(prober.act(obs))
            done = terminated or truncated
        errors.append(info["position_error"] * 1e3)
        measurements.append(info["n_measurements"])
    errors = np.array(errors)
    return {
        "mean": float(errors.mean()),
        "median": float(np.median(errors)),
        "success": float(np.mean(errors < 2.0)),
        "measurements": float(np.mean(measurements)),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="tactile_gym/HingeProbePrimitive-v2")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=SELECTION_SEED + 300)
    parser.add_argument("--angles", type=float, nargs="+", default=[16.0, 20.0, 24.0, 32.0])
    args = parser.parse_args(argv)
    env = gym.make(args.env)  # dict observations: what the prober reads
    seeds = range(args.seed, args.seed + args.episodes)
    print(f"{args.env}, {args.episodes} episodes, seeds {seeds.start}..{seeds.stop - 1}\n")
    print("| step_angle (deg) | final position error mean / median (mm) | success | measurements |")
    print("|---|---|---|---|")
    default = float(np.rad2deg(ProberConfig().step_angle))
    for angle in args.angles:
        row = play(env, ProberConfig(step_angle=float(np.deg2rad(angle))), seeds)
        label = f"{angle:g}{' (default)' if np.isclose(angle, default) else ''}"
        print(
            f"| {label} | {row['mean']:.2f} / "
            f"{row['median']:.2f} | {100 * row['success']:.0f} % | {row['measurements']:.1f} |",
            flush=True,
        )
    env.close()


if __name__ == "__main__":
    main()
