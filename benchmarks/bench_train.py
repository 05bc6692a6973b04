"""Training throughput: env steps/s of ``agents.train``'s set-up, and the env's share of it.

    python benchmarks/bench_train.py                      # PPO, configs/train/ppo.yml, 2 envs
    python benchmarks/bench_train.py --algo sac --steps 2000
    python benchmarks/bench_train.py --env tactile_gym/HingeProbePrimitive-v2 --steps 1024

Every case trains the same stable-baselines3 config (the algo's YAML for the env, with its
``n_envs`` and ``VecNormalize``) for ``--steps`` env steps, after a warm-up that is not timed
(process start, numba's cache load, the first update's allocations). The *dummy env* has the
same observation and action spaces and episode length but returns a fixed observation at no
cost, so its run is SB3's own overhead (rollout bookkeeping, normalisation, the network, the
updates); measured in the same run, ``1 - t_dummy / t_env`` is the env's share of training
time. *env only* steps the same vector env with random actions and no learning.

The env cases run for each contact step of ``--physics`` (the env keyword ``physics``:
``v2``, the exact step, ``v3``, the lean one, ``docs/design.md`` 3.6) in the same run; the
headline line gives training's env steps per second end to end (primitives per second on a
primitive id) with ``agents.train``'s choice of workers, per physics.

Prints a markdown table. On a shared machine timings vary a lot with the load from elsewhere:
``--repeats`` runs the cases round-robin and keeps the fastest run of each.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import tactile_gym  # noqa: E402
from agents import cli, hyperparams, resources  # noqa: E402
from benchmarks.bench_env import add_physics_option  # noqa: E402


class SpacesEnv(gym.Env):
    """The spaces and episode length of another env, at no cost per step."""

    def __init__(self, observation_space, action_space, max_steps: int) -> None:
        self.observation_space = observation_space
        self.action_space = action_space
        self.observation_space.seed(0)
        self._obs = self.observation_space.sample()
        self._max_steps = max_steps
        self._t = 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._t = 0
        return self._obs, {}

    def step(self, action):
        self._t += 1
        return self._obs, 0.0, False, self._t >= self._max_steps, {}


def _factory(env_id: str, env_kwargs: dict, dummy: bool):
    def make():
        env = cli.make_env(env_id, **env_kwargs)
        if not dummy:
            return env
        # The env truncates episodes itself (no TimeLimit): a 6-D id after max_steps control
        # steps, a primitive id after max_primitives primitives at most.
        if env.has_wrapper_attr("max_primitives"):
            episode_steps = env.get_wrapper_attr("max_primitives")
        else:
            episode_steps = env.unwrapped.config.max_steps
        spaces_env = SpacesEnv(env.observation_space, env.action_space, episode_steps)
        env.close()
        return spaces_env

    return make


def _vec_env(env_id, config, workers: int, dummy: bool, physics: str | None = None):
    """``agents.train``'s envs (contact step ``physics``, None for the env's default): the
    package's vector env with ``workers`` processes, or for the zero-cost env SB3's loop over
    it (in this process, or one process per env)."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import (
        DummyVecEnv,
        SubprocVecEnv,
        VecMonitor,
        VecNormalize,
    )

    from agents.vec_env import make_sb3_vec_env

    env_kwargs = dict(config.get("env_kwargs") or {})
    if physics is not None:
        env_kwargs["physics"] = physics
    n_envs = int(config["n_envs"])
    if not dummy:
        env = VecMonitor(make_sb3_vec_env(env_id, n_envs, workers, **env_kwargs))
        env.seed(0)
    else:
        # The zero-cost env has no vector env of its own: SB3's loop over it stands in.
        env = make_vec_env(
            _factory(env_id, env_kwargs, dummy),
            n_envs=n_envs,
            seed=0,
            vec_env_cls=SubprocVecEnv if workers > 1 else DummyVecEnv,
        )
    if config.get("normalize"):
        env = VecNormalize(env, gamma=config.get("gamma", 0.99))
    return env


def time_training(algo, env_id, config, workers, threads, steps, dummy, physics) -> float:
    """Seconds of ``learn(steps)`` after an untimed warm-up ``learn`` of one rollout."""
    from stable_baselines3 import PPO, SAC

    env = _vec_env(env_id, config, workers, dummy, physics)
    try:
        with resources.torch_threads(threads):
            model = {"ppo": PPO, "sac": SAC}[algo](
                config["policy"], env, seed=0, device="cpu", **hyperparams.algo_kwargs(config)
            )
            warmup = int(config.get("n_steps", 256)) * int(config["n_envs"])
            model.learn(warmup)
            start = time.perf_counter()
            model.learn(steps, reset_num_timesteps=False)
            return time.perf_counter() - start
    finally:
        env.close()


def time_env_only(env_id, config, workers, steps, physics) -> float:
    """Seconds to step the vector env ``steps`` times (summed over envs), random actions."""
    env = _vec_env(env_id, config, workers, dummy=False, physics=physics)
    try:
        env.reset()
        env.action_space.seed(0)
        n_envs = int(config["n_envs"])
        actions = lambda: np.stack([env.action_space.sample() for _ in range(n_envs)])  # noqa: E731
        for _ in range(50):
            env.step(actions())
        start = time.perf_counter()
        for _ in range(steps // n_envs):
            env.step(actions())
        return time.perf_counter() - start
    finally:
        env.close()


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", choices=hyperparams.ALGOS, default="ppo")
    parser.add_argument("--env", default=cli.DEFAULT_ENV_ID, help=str(tactile_gym.ENV_IDS))
    parser.add_argument("--steps", type=int, default=4096, help="timed env steps per case")
    parser.add_argument("--n-envs", type=int, default=None)
    parser.add_argument("--repeats", type=int, default=1)
    add_physics_option(parser)
    args = parser.parse_args(argv)

    config = hyperparams.resolve_config(args.algo, args.env, n_envs=args.n_envs)
    n_envs, n_cpus = int(config["n_envs"]), resources.available_cpus()
    chosen = resources.choose_env_workers(args.env, n_envs, n_cpus)
    other = 1 if chosen > 1 else min(n_envs, n_cpus)  # in-process against workers
    threads = resources.DEFAULT_TORCH_THREADS
    more = 2 * threads

    def workers(k: int) -> str:
        return "in-process" if k == 1 else f"{k} workers"

    # (label, workers, torch threads, dummy env, physics); the zero-cost env has no physics.
    cases = [(f"dummy env, {workers(chosen)}, {threads} thread", chosen, threads, True, None)]
    cases.append((f"dummy env, {workers(other)}, {threads} thread", other, threads, True, None))
    for name in args.physics:
        cases += [
            (
                f"env, {workers(chosen)} (agents.train's choice), {threads} thread",
                chosen,
                threads,
                False,
                name,
            ),
            (f"env, {workers(other)}, {threads} thread", other, threads, False, name),
            (f"env, {workers(chosen)}, {more} threads", chosen, more, False, name),
        ]
    # Round-robin over the cases, so that a burst of load from elsewhere hits them all alike;
    # each case keeps its fastest run.
    best = [math.inf] * len(cases)
    env_only = dict.fromkeys(args.physics, math.inf)
    for _ in range(args.repeats):
        for i, (_, k, n_threads, dummy, name) in enumerate(cases):
            seconds = time_training(
                args.algo, args.env, config, k, n_threads, args.steps, dummy, name
            )
            best[i] = min(best[i], seconds)
        for name in args.physics:
            seconds = time_env_only(args.env, config, chosen, args.steps, name)
            env_only[name] = min(env_only[name], seconds)
    rows = [
        {"case": f"train: {case[0]}", "physics": case[4], "seconds": seconds}
        for case, seconds in zip(cases, best, strict=True)
    ]
    rows += [
        {"case": f"env only, random actions, {workers(chosen)}", "physics": name, "seconds": t}
        for name, t in env_only.items()
    ]

    step = "primitives" if args.env in tactile_gym.PRIMITIVE_ENV_IDS else "env steps"
    print(
        f"{args.algo.upper()} on {args.env}, {n_envs} envs, {args.steps} timed env steps, "
        f"{n_cpus} cores, best of {args.repeats}, load average {os.getloadavg()[0]:.2f}\n"
    )
    print("| case | physics | env steps/s | ms per env step |\n|---|---|---:|---:|")
    for row in rows:
        rate = args.steps / row["seconds"]
        print(f"| {row['case']} | {row['physics'] or '-'} | {rate:,.0f} | {1e3 / rate:.2f} |")
    t_dummy = rows[0]["seconds"]
    print()
    for name in args.physics:
        t_env, t_other, t_more = (
            r["seconds"] for r in rows if r["physics"] == name and r["case"].startswith("train")
        )
        print(
            f"{name}: {args.steps / t_env:,.0f} {step}/s end to end ({workers(chosen)});"
            f" env share of training time {1.0 - t_dummy / t_env:.0%} (1 - t_dummy / t_env);"
            f" stepping the env alone takes {env_only[name] / t_env:.0%} of it;"
            f" {workers(chosen)} is {t_other / t_env:.2f}x as fast as {workers(other)},"
            f" {threads} torch thread {t_more / t_env:.2f}x as fast as {more}."
        )
    return rows


if __name__ == "__main__":
    main()
