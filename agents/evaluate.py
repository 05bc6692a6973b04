"""Evaluate policies on a tactile_gym env over seeded episodes.

    python -m agents.evaluate --policies random scripted --episodes 20
    python -m agents.evaluate --policies scripted runs/ppo/HingeProbe-v0_s0_.../best_model.zip

A policy is ``random``, ``scripted`` or the path of a stable-baselines3 model saved by
``agents.train`` (its run folder supplies the algorithm and the ``VecNormalize`` statistics).
Episode k of every policy uses seed ``seed + k``, so all policies meet the same objects. The
script prints a markdown table and writes ``evaluation.json`` and ``error_vs_step.png`` to
``--out``.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict, dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import yaml

import tactile_gym

from .scripted import ScriptedProbePolicy

#: Position error reported while there is no estimate, m (the task's E_max).
NO_ESTIMATE_ERROR = 0.1
#: The "steps to reach" threshold of the table, m.
REACH_THRESHOLD = 0.005


class RandomPolicy:
    """Uniform random actions from a seeded action space."""

    def __init__(self, env: gym.Env, seed: int) -> None:
        self.action_space = env.action_space
        self.action_space.seed(seed)

    def reset(self) -> None:
        pass

    def get_action(self, obs) -> np.ndarray:
        return self.action_space.sample()


class ModelPolicy:
    """A stable-baselines3 model saved by ``agents.train``, with its observation scaling."""

    def __init__(self, path: str | Path, env: gym.Env) -> None:
        from stable_baselines3 import PPO, SAC
        from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

        path = Path(path)
        run_dir, algo = model_run(path)
        self.model = {"ppo": PPO, "sac": SAC}[algo].load(path, device="cpu")
        self.normalizer = None
        # A checkpoint has its own normalisation statistics (CheckpointCallback names them
        # rl_model_vecnormalize_<steps>_steps.pkl); other models use the run's final ones.
        stats = run_dir / "vecnormalize.pkl"
        if path.parent.name == "checkpoints":
            name = path.stem.replace("rl_model_", "rl_model_vecnormalize_")
            stats = path.with_name(name + ".pkl")
        if stats.exists():
            dummy = DummyVecEnv([lambda: env])
            self.normalizer = VecNormalize.load(str(stats), dummy)
            self.normalizer.training = False

    def reset(self) -> None:
        pass

    def get_action(self, obs) -> np.ndarray:
        if self.normalizer is not None:
            obs = self.normalizer.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=True)
        return action


@dataclass
class EpisodeRecord:
    seed: int
    position_error: list[float]
    angle_error: list[float]
    success: bool
    n_measurements: int
    terminated: bool


def model_run(path: Path) -> tuple[Path, str]:
    """The run folder of a model saved by ``agents.train`` (final, best or checkpoint) and
    its algorithm (from the run's ``config.yml``; ``"ppo"`` when there is none)."""
    run_dir = path.parent.parent if path.parent.name == "checkpoints" else path.parent
    config_file = run_dir / "config.yml"
    algo = yaml.safe_load(config_file.read_text())["algo"] if config_file.exists() else "ppo"
    return run_dir, algo


def policy_label(name: str) -> str:
    """A short name for tables and plots: the policy name, or "<algo> <model file stem>"."""
    path = Path(name)
    if not path.exists():
        return name
    return f"{model_run(path)[1]} {path.stem}"


def make_policy(name: str, env: gym.Env, seed: int):
    """The policy called ``name``: ``random``, ``scripted`` or a model path."""
    if name == "random":
        return RandomPolicy(env, seed)
    if name == "scripted":
        return ScriptedProbePolicy.for_env(env.unwrapped)
    if Path(name).exists():
        return ModelPolicy(name, env)
    raise ValueError(f"policy must be 'random', 'scripted' or an existing model path, got {name!r}")


def run_episode(env: gym.Env, policy, seed: int) -> EpisodeRecord:
    """One episode; errors are recorded after reset and after every step."""
    obs, info = env.reset(seed=seed)
    policy.reset()
    position, angle = [_finite(info["position_error"])], [info["angle_error"]]
    terminated = truncated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(policy.get_action(obs))
        position.append(_finite(info["position_error"]))
        angle.append(info["angle_error"])
    return EpisodeRecord(
        seed=seed,
        position_error=position,
        angle_error=angle,
        success=bool(info["is_success"]),
        n_measurements=int(info["n_measurements"]),
        terminated=bool(terminated),
    )


def _finite(error: float) -> float:
    return float(min(error, NO_ESTIMATE_ERROR))


def summarize(records: list[EpisodeRecord]) -> dict[str, float]:
    """Table figures over episodes: errors in mm and degrees."""
    final_pos = np.array([r.position_error[-1] for r in records]) * 1e3
    final_ang = np.degrees([r.angle_error[-1] for r in records])
    reach = [
        next((i for i, e in enumerate(r.position_error) if e < REACH_THRESHOLD), None)
        for r in records
    ]
    reached = [i for i in reach if i is not None]
    return {
        "episodes": len(records),
        "position_mean_mm": float(final_pos.mean()),
        "position_median_mm": float(np.median(final_pos)),
        "position_p90_mm": float(np.percentile(final_pos, 90)),
        "angle_mean_deg": float(final_ang.mean()),
        "angle_median_deg": float(np.median(final_ang)),
        "success_rate": float(np.mean([r.success for r in records])),
        "reached_5mm_rate": len(reached) / len(records),
        "steps_to_5mm_mean": float(np.mean(reached)) if reached else float("nan"),
        "measurements_mean": float(np.mean([r.n_measurements for r in records])),
        "failure_rate": float(np.mean([r.terminated for r in records])),
    }


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
        f"{s['reached_5mm_rate']:.0%} | {s['steps_to_5mm_mean']:.0f} | "
        f"{s['measurements_mean']:.1f} | {s['failure_rate']:.0%} |"
        for name, s in summaries.items()
    ]
    return "\n".join([header, *rows])


def plot_errors(records: dict[str, list[EpisodeRecord]], path: Path) -> None:
    """Median and inter-quartile band of the position error against the step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for name, recs in records.items():
        length = max(len(r.position_error) for r in recs)
        padded = (
            np.array(
                [
                    r.position_error + [r.position_error[-1]] * (length - len(r.position_error))
                    for r in recs
                ]
            )
            * 1e3
        )
        steps = np.arange(length)
        ax.plot(steps, np.median(padded, axis=0), label=name)
        ax.fill_between(steps, *np.percentile(padded, [25, 75], axis=0), alpha=0.2, linewidth=0)
    ax.set_xlabel("step")
    ax.set_ylabel("axis position error (mm)")
    ax.set_yscale("log")
    ax.axhline(REACH_THRESHOLD * 1e3, color="grey", linestyle=":", linewidth=1)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def evaluate(
    policies: list[str],
    env_id: str = "tactile_gym/HingeProbe-v0",
    episodes: int = 20,
    seed: int = 1000,
    out: str | Path = "results/evaluation",
    env_kwargs: dict | None = None,
    plot: bool = True,
) -> dict[str, dict[str, float]]:
    """Evaluate each policy over the same seeded episodes; write JSON and a plot."""
    if env_id not in tactile_gym.ENV_IDS:
        raise ValueError(f"env_id must be one of {tactile_gym.ENV_IDS}, got {env_id!r}")
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    records: dict[str, list[EpisodeRecord]] = {}
    for name in policies:
        env = gym.make(env_id, **(env_kwargs or {}))
        try:
            policy = make_policy(name, env, seed)
            records[policy_label(name)] = [
                run_episode(env, policy, seed + k) for k in range(episodes)
            ]
        finally:
            env.close()
    summaries = {name: summarize(recs) for name, recs in records.items()}
    result = {
        "env_id": env_id,
        "policies": {policy_label(name): name for name in policies},
        "episodes": episodes,
        "seed": seed,
        "summaries": summaries,
        "episodes_detail": {name: [asdict(r) for r in recs] for name, recs in records.items()},
    }
    (out / "evaluation.json").write_text(json.dumps(result, indent=1))
    if plot:
        plot_errors(records, out / "error_vs_step.png")
    return summaries


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policies", nargs="+", default=["random", "scripted"])
    parser.add_argument("--env", default="tactile_gym/HingeProbe-v0")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--out", default="results/evaluation")
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args(argv)
    summaries = evaluate(
        args.policies, args.env, args.episodes, args.seed, args.out, plot=not args.no_plot
    )
    print(
        f"{args.env}, {args.episodes} episodes, seeds {args.seed}..{args.seed + args.episodes - 1}"
    )
    print(markdown_table(summaries))
    print(f"wrote {Path(args.out) / 'evaluation.json'}")
    return summaries


if __name__ == "__main__":
    main()
