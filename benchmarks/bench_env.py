"""Env step throughput of HingeProbe-v0, against bare physics on the same scene.

    python benchmarks/bench_env.py [--steps 400]

Rows: one process with random actions (mostly free motion), one process with the scripted
contact-keeping policy (presses, shears and pushes), and a 2-process async vector env with
random actions. The baseline is ``stepSimulation`` on the same PyBullet scene, times the
substeps of one env step, measured in the same run; the ratio says how many times dearer an
env step (skin, sensing, estimation, observation) is than the rigid-body physics alone.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np
import pybullet as p

import tactile_gym  # noqa: F401 - registers the envs
from agents.scripted import ScriptedProbePolicy

ENV_ID = "tactile_gym/HingeProbe-v0"


def bare_physics_per_env_step(env: gym.Env, repeats: int = 2000) -> float:
    """Seconds of bare ``stepSimulation`` per env step (all its substeps)."""
    scene = env.unwrapped.scene
    client_id = scene.world.client_id
    start = time.perf_counter()
    for _ in range(repeats):
        p.stepSimulation(physicsClientId=client_id)
    per_step = (time.perf_counter() - start) / repeats
    return per_step * scene.substeps


def time_single(policy: str, steps: int) -> tuple[float, float, float]:
    """(env steps/s, bare-physics seconds per env step, mean contact force)."""
    env = gym.make(ENV_ID)
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    scripted = ScriptedProbePolicy.for_env(env.unwrapped)
    forces = []
    start = time.perf_counter()
    for _ in range(steps):
        action = scripted.get_action(obs) if policy == "scripted" else env.action_space.sample()
        obs, _, terminated, truncated, _ = env.step(action)
        forces.append(float(np.linalg.norm(obs["wrench"][:3])))
        if terminated or truncated:
            obs, _ = env.reset()
            scripted.reset()
    elapsed = time.perf_counter() - start
    bare = bare_physics_per_env_step(env)
    env.close()
    return steps / elapsed, bare, float(np.mean(forces))


def time_vector(steps: int) -> float:
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async")
    envs.reset(seed=0)
    envs.action_space.seed(0)
    start = time.perf_counter()
    for _ in range(steps):
        envs.step(envs.action_space.sample())
    elapsed = time.perf_counter() - start
    envs.close()
    return 2 * steps / elapsed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400)
    args = parser.parse_args(argv)
    rows = []
    for name, policy in (
        ("1 process, random actions", "random"),
        ("1 process, scripted (in contact)", "scripted"),
    ):
        rate, bare, force = time_single(policy, args.steps)
        rows.append((name, rate, 1e3 / rate, bare * 1e3, (1.0 / rate) / bare, force))
    vec_rate = time_vector(args.steps // 2)
    print(f"{ENV_ID}, {args.steps} steps per row, 12 substeps at 1/240 s per env step")
    print()
    print(
        "| case | env steps/s | ms per env step | bare physics ms per env step |"
        " env step / bare physics | mean |f| (N) |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for name, rate, ms, bare_ms, ratio, force in rows:
        print(f"| {name} | {rate:,.0f} | {ms:.2f} | {bare_ms:.3f} | {ratio:.0f}x | {force:.1f} |")
    print(
        f"| 2-process async vector env, random actions (total) | {vec_rate:,.0f} | - | - | - | - |"
    )


if __name__ == "__main__":
    main()
