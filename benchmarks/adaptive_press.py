"""What the adaptive press gives the scripted baseline on an env (docs/design.md 5.2).

Plays the scripted policy on the same seeded episodes of a primitive id with the v2 press
(a fixed force gradient, a fixed dwell) and with the adaptive one (the skills measure the
force gradient, and the gate measures a still press once the predicted edge error of its mean
reaches a target, within a budget, judging its steadiness on the force's trend; the v3 ids'
keywords unless ``--target``, ``--budget``, ``--holds-only`` or ``--gradient-only`` change
them), on the default skin and on stiffer or softer ones (``--skins``: the env's
``skin.normal_stiffness`` as a factor of the default; the sensing is told, the press's assumed
6000 N/m is not). It prints, per press and skin, the final position error (mean, median, P90),
the mean final angle error, the success rate, the accepted measurements and the readings a
probe held, per episode, and the adaptive press's paired difference of the final position
error to the v2 press on the same episodes, with its 95 % bootstrap interval. The default
seeds lie in the selection range (``agents.seeds``), never in the test range.

Run: ``python benchmarks/adaptive_press.py [--env ID] [--episodes N] [--seed S]
[--skins 1 2 0.5] [--target DEG] [--budget N] [--holds-only | --gradient-only]
[--env-kwargs KEY:VALUE ...]``; e.g. ``--env-kwargs "sensor: {force_noise_std: 0.08,
moment_noise_std: 0.002}"`` plays both on a sensor four times as noisy (and the sensing told).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

# Measure the checkout this file is in (git worktrees share one virtual environment).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym  # noqa: E402

import tactile_gym  # noqa: E402, F401 - registers the envs
from agents.cli import KEY_VALUE_HELP, KeyValue  # noqa: E402
from agents.episodes import EpisodeRecord, run_episode, summarize  # noqa: E402
from agents.paired import bootstrap_ci  # noqa: E402
from agents.scripted import scripted_policy  # noqa: E402
from agents.seeds import SELECTION_SEED  # noqa: E402
from tactile_gym.envs import skills  # noqa: E402
from tactile_gym.perception import GateConfig  # noqa: E402
from tactile_gym.registration import merge_keywords  # noqa: E402
from tactile_gym.sim import SkinConfig  # noqa: E402

#: The v3 ids' adaptive press (``tactile_gym``'s registration): its gate keywords.
V3_GATE = gym.spec("tactile_gym/HingeProbePrimitive-v3").kwargs["gate"]
#: The gate keywords that make its hold rule and steadiness adaptive.
ADAPTIVE_GATE_KEYS = ("edge_std_target", "dwell_budget", "steady_rule")


def press_kwargs(adaptive: dict | None) -> dict:
    """Keywords that replace an id's press: the v2 press (``adaptive`` None), or the adaptive
    one of ``adaptive`` (:func:`adaptive`). Each adaptive gate field is set, to ``GateConfig``'s
    default (the v2 gate's) where ``adaptive`` does not give it: ``gym.make`` merges a ``gate``
    into the id's registered one, so a field left out would keep the registered value."""
    adaptive = adaptive or {"measure_gradient": False}
    v2_gate = {key: getattr(GateConfig(), key) for key in ADAPTIVE_GATE_KEYS}
    return {
        "measure_gradient": adaptive["measure_gradient"],
        "gate": {**v2_gate, **adaptive.get("gate", {})},
    }


def adaptive(target: float, budget: int, holds=True, gradient=True) -> dict:
    """The keywords that turn the adaptive press on (``holds``: the gate's hold rule, a
    ``target`` in deg and a ``budget`` in readings, with the trend's steadiness;
    ``gradient``: the skills' measured force gradient)."""
    kwargs: dict = {"measure_gradient": gradient}
    if holds:
        kwargs["gate"] = {
            "edge_std_target": math.radians(target),
            "dwell_budget": budget,
            "steady_rule": "trend",
        }
    return kwargs


class HoldCounter:
    """Counts the readings each probe's press held (``skills.Press``), by wrapping its move."""

    def __init__(self) -> None:
        self.holds: list[int] = []
        self._move = skills.Press._move

        def move(press, reading):
            out = self._move(press, reading)
            if out is None and press.press.phase == "done" and press.press.rule.most > 0:
                self.holds.append(press.press.readings)
            return out

        skills.Press._move = move

    def close(self) -> None:
        skills.Press._move = self._move


def play(env_id: str, kwargs: dict, seeds: range) -> tuple[list[EpisodeRecord], float]:
    """The scripted policy's episodes on ``seeds``, and the mean readings a probe held."""
    env = gym.make(env_id, **kwargs)
    counter = HoldCounter()
    try:
        policy = scripted_policy(env)
        records = [run_episode(env, policy, seed) for seed in seeds]
    finally:
        counter.close()
        env.close()
    return records, float(np.mean(counter.holds)) if counter.holds else math.nan


def final_errors_mm(records: list[EpisodeRecord]) -> np.ndarray:
    """Each episode's final position error, mm."""
    return 1e3 * np.array([r.position_error[-1] for r in records])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="tactile_gym/HingeProbePrimitive-v3")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=SELECTION_SEED)
    parser.add_argument("--skins", type=float, nargs="+", default=[1.0])
    parser.add_argument(
        "--target", type=float, default=math.degrees(V3_GATE["edge_std_target"]), help="deg"
    )
    parser.add_argument("--budget", type=int, default=V3_GATE["dwell_budget"], help="readings")
    only = parser.add_mutually_exclusive_group()
    only.add_argument("--holds-only", action="store_true", help="the gradient assumed")
    only.add_argument("--gradient-only", action="store_true", help="the v2 dwell")
    parser.add_argument("--env-kwargs", nargs="+", action=KeyValue, default={}, help=KEY_VALUE_HELP)
    args = parser.parse_args(argv)
    chosen = adaptive(args.target, args.budget, not args.gradient_only, not args.holds_only)
    seeds = range(args.seed, args.seed + args.episodes)
    print(f"{args.env}, {args.episodes} episodes, seeds {seeds.start}..{seeds.stop - 1}")
    print(f"adaptive: {chosen}; both: {args.env_kwargs}\n")
    print(
        "| press | skin stiffness (x configured) | final position error mean / median / P90 (mm)"
        " | angle error (deg) | success | measurements | readings a probe held"
        " | paired error difference to v2 (mm, 95 % CI) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    stiffness = SkinConfig().normal_stiffness
    for skin in args.skins:
        for name, press in (("v2", None), ("adaptive", chosen)):
            world = {"skin": {"normal_stiffness": skin * stiffness}} if skin != 1.0 else {}
            kwargs = merge_keywords(merge_keywords(press_kwargs(press), args.env_kwargs), world)
            records, held = play(args.env, kwargs, seeds)
            row = summarize(records)
            if press is None:
                reference = final_errors_mm(records)
                paired = "-"
            else:
                diff = final_errors_mm(records) - reference
                low, high = bootstrap_ci(diff)
                paired = f"{diff.mean():+.2f} ({low:+.2f} to {high:+.2f})"
            print(
                f"| {name} | {skin:g} | {row['position_mean_mm']:.2f} /"
                f" {row['position_median_mm']:.2f} / {row['position_p90_mm']:.2f} |"
                f" {row['angle_mean_deg']:.2f} |"
                f" {100 * row['success_rate']:.0f} % | {row['measurements_mean']:.1f} |"
                f" {held:.1f} | {paired} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
