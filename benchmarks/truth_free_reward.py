"""Does the truth-free reward rank policies as the true error does, and can it be gamed?

    python benchmarks/truth_free_reward.py [--ids ...] [--episodes 200] [--seed 200000]

With ``task={"reward_source": "predicted"}`` a step's reward is the reduction of U, the
estimator's own predicted error (position std + 0.05 m/rad angle std), which a robot can
compute (``tactile_gym.envs.task``). For it to be worth training on, it must order policies as
the true error E does, and a policy must not gain by shrinking U without shrinking E. Each id
is played by seven policies on the same episodes (``--episodes``, seeds from ``--seed``, the
selection range of ``agents.seeds`` by default), with the truth-free reward:

* ``random``: uniform primitives;
* ``scripted 1/3``: the scripted policy with a third of the episode's control steps;
* ``scripted``: the scripted policy;
* ``learned``: the committed model of the id's family (``models/``; trained on v2, here on
  the id it is given, whose spaces are the same);
* three adversaries that try to shrink U without shrinking E: ``same spot`` presses one place
  again and again (a probe with no offset), ``one edge`` presses along the edge it first
  found and never turns the link, ``no turn`` presses anywhere near the edges (random
  offsets across and along) and never turns the link.

The table gives, per policy, the mean truth-free return's error term ((U_0 - U_T) / 10 mm)
and the true one ((E_0 - E_T) / 10 mm) over the same episodes, the mean final E and U, and
their difference's mean with a 95 % bootstrap interval; then Kendall's tau between the order
by mean truth-free return and the order by mean final E, and Spearman's rho between the final
U and E of every episode pooled, and within the scripted policy's. Results: docs/design.md
6.9 ("The truth-free reward after it"). The claims:
``tests/test_truth_free_reward.py`` checks the adversaries' claims on fewer episodes.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gymnasium as gym  # noqa: E402

import tactile_gym  # noqa: E402, F401
from agents.paired import bootstrap_ci  # noqa: E402
from agents.policies import make_policy  # noqa: E402
from agents.scripted import scripted_policy  # noqa: E402
from agents.seeds import SELECTION_SEED  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
IDS = ("tactile_gym/HingeProbePrimitive-v3", "tactile_gym/HingeProbe3DPrimitive-v3")
#: The committed model of each id's family (trained on v2).
MODELS = {
    "HingeProbePrimitive": ROOT / "models/ppo_HingeProbePrimitive-v2_s3/final_model.zip",
    "HingeProbe3DPrimitive": ROOT / "models/ppo_HingeProbe3DPrimitive-v2_s5/best_model.zip",
}
TRUTH_FREE = {"task": {"reward_source": "predicted", "workspace_center": "start"}}
#: E's weight of the angle, m/rad, and its cap, m: the task's (``TaskConfig``).
ANGLE_SCALE, CAP, SCALE = 0.05, 0.1, 0.01
POLICIES = ("random", "scripted 1/3", "scripted", "learned", "same spot", "one edge", "no turn")
ADVERSARIES = POLICIES[4:]


class Adversary:
    """A primitive policy of fixed or drawn actions that never turns the link: ``kind`` is
    one of ``ADVERSARIES`` (module docstring)."""

    def __init__(self, env: gym.Env, kind: str) -> None:
        if kind not in ADVERSARIES:
            raise ValueError(f"kind must be one of {ADVERSARIES}, got {kind!r}")
        self.kind = kind
        self.rng = np.random.default_rng(0)

    def reset(self) -> None:
        self.primitives = 0

    def get_action(self, obs) -> np.ndarray:
        self.primitives += 1
        if self.kind == "same spot":
            across, along = 0.0, 0.0
        elif self.kind == "one edge":
            across, along = 0.0, self.rng.uniform(-1.0, 1.0)
        else:  # no turn: anywhere near the edges, never a turn
            across, along = self.rng.uniform(-1.0, 1.0, 2)
        return np.array([-1.0, across, along], np.float32)


@dataclass
class Outcomes:
    """Each episode's true and predicted errors at its start and end, m."""

    e0: np.ndarray
    e_end: np.ndarray
    u0: np.ndarray
    u_end: np.ndarray

    @property
    def true_gain(self) -> np.ndarray:
        return (self.e0 - self.e_end) / SCALE

    @property
    def free_gain(self) -> np.ndarray:
        return (self.u0 - self.u_end) / SCALE


def combined(info: dict) -> float:
    """E of an info, m (``AxisEstimationTask.combined_error``)."""
    error = float(info["position_error"]) + ANGLE_SCALE * float(info["angle_error"])
    return min(error, CAP) if np.isfinite(error) else CAP


def play(env_id: str, policy: str, seeds: list[int]) -> Outcomes:
    """The episodes of one policy on one id, with the truth-free reward."""
    kwargs = dict(TRUTH_FREE)
    if policy == "scripted 1/3":
        kwargs["max_steps"] = 400 // 3
    env = gym.make(env_id, **kwargs)
    if policy in ("scripted", "scripted 1/3"):
        agent = scripted_policy(env)
    elif policy == "learned":
        family = env_id.split("/")[1].rsplit("-", 1)[0]
        agent = make_policy(str(MODELS[family]), env)
    elif policy == "random":
        agent = make_policy("random", env)
    else:
        agent = Adversary(env, policy)
    rows = []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        env.action_space.seed(seed)
        agent.reset()
        start = (combined(info), float(info["predicted_error"]))
        done = False
        total = 0.0
        while not done:
            obs, reward, terminated, truncated, info = env.step(agent.get_action(obs))
            total += float(info["reward_error_reduction"])
            done = terminated or truncated
        rows.append((*start, combined(info), float(info["predicted_error"])))
    env.close()
    e0, u0, e_end, u_end = np.array(rows).T
    return Outcomes(e0=e0, e_end=e_end, u0=u0, u_end=u_end)


def ranking(results: dict[str, Outcomes]) -> tuple[float, float, float]:
    """Kendall's tau between the order by mean truth-free return and by mean final E (a
    higher return goes with a lower error, so the second order is of -E), Spearman's rho of
    final U and E pooled over every episode, and within the scripted policy's."""
    free = [results[p].free_gain.mean() for p in results]
    error = [-results[p].e_end.mean() for p in results]
    tau = stats.kendalltau(free, error).statistic
    u = np.concatenate([r.u_end for r in results.values()])
    e = np.concatenate([r.e_end for r in results.values()])
    pooled = stats.spearmanr(u, e).statistic
    scripted = stats.spearmanr(results["scripted"].u_end, results["scripted"].e_end).statistic
    return float(tau), float(pooled), float(scripted)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ids", nargs="+", default=list(IDS))
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=SELECTION_SEED)
    args = parser.parse_args(argv)
    seeds = list(range(args.seed, args.seed + args.episodes))
    for env_id in args.ids:
        start = time.monotonic()
        results = {policy: play(env_id, policy, seeds) for policy in POLICIES}
        print(f"\n{env_id}: {args.episodes} episodes per policy, seeds {seeds[0]}..{seeds[-1]}")
        print(
            "| policy | truth-free return (U_0 - U_T) / 10 mm | true return (E_0 - E_T) / 10 mm "
            "| truth-free - true, mean [95 % CI] | final E (mm) | final U (mm) |"
        )
        print("|---|---:|---:|---|---:|---:|")
        for policy, r in results.items():
            low, high = bootstrap_ci(r.free_gain - r.true_gain)
            print(
                f"| {policy} | {r.free_gain.mean():+.3f} | {r.true_gain.mean():+.3f} "
                f"| {np.mean(r.free_gain - r.true_gain):+.3f} [{low:+.3f}, {high:+.3f}] "
                f"| {1e3 * r.e_end.mean():.2f} | {1e3 * r.u_end.mean():.2f} |"
            )
        tau, pooled, scripted = ranking(results)
        print(
            f"Kendall tau (mean truth-free return vs mean final E) {tau:.2f}; Spearman rho "
            f"(final U, final E) pooled {pooled:.2f}, within scripted {scripted:.2f}"
            f" ({time.monotonic() - start:.0f} s)"
        )


if __name__ == "__main__":
    main()
