"""The vector env's throughput against bare physics in the same run (``docs/design.md`` 7.9).

    python benchmarks/bench_vector.py [--n-envs 1 4 16 64] [--workers 1 2]
                                      [--control-steps 800] [--physics v2 v3]
                                      [--ids tactile_gym/HingeProbe-v1 ...]

A sub-env's memory and build time, then two tables. The first times bare ``stepSimulation``
(one control step's substeps) for N scenes laid out as N PyBullet clients of one object each,
or one client holding N objects, which is the choice behind the vector env's layout. The
second, per id, steps ``gym.make_vec(id, num_envs=N, workers=k)`` (in this process for k = 1,
in k worker processes otherwise; rows with k > N are skipped) with random actions and with
the scripted baseline (``agents.scripted.scripted_policy``, one per sub-env) and gives the
wall time per sub-env control step as a multiple of bare physics
(``bench_env.bare_physics_per_control_step`` on a scene of the id made in this process, the
least of three calls before the row and three after), and sub-env steps/s (primitives for the
primitive ids). Each row runs every contact step of ``--physics`` (the env keyword ``physics``:
``v2``, the exact step, ``v3``, the lean one, ``docs/design.md`` 3.6) in the same run.
The first reset and the first step are not timed (a worker's first step loads the compiled
kernels); ended sub-envs are reset within a step (same-step autoreset, as SB3 trains), so
those resets are timed with their step.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout's agents/

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402

from agents.scripted import scripted_policy  # noqa: E402
from benchmarks.bench_env import (  # noqa: E402
    BARE_REPEATS,
    add_physics_option,
    bare_physics_per_control_step,
)
from tactile_gym import PRIMITIVE_ENV_IDS  # noqa: E402
from tactile_gym.sim import ObjectConfig  # noqa: E402
from tactile_gym.sim.objects import HingedObject  # noqa: E402
from tactile_gym.sim.world import SUBSTEPS, World  # noqa: E402


def physics_layouts(n: int, rounds: int = 9) -> dict[str, float]:
    """Seconds of ``stepSimulation`` per control step for ``n`` hinged objects, as ``n``
    clients of one object or one client of ``n``; each link is pushed round its hinge (beyond
    the joint's holding torque) as the skin pushes it. The best of ``rounds`` alternating
    runs, so that a busy machine's pauses fall on neither layout."""
    config = ObjectConfig.family_default("scissors")
    force, torque = np.zeros(3), np.array([0.0, 0.0, 2.0 * config.holding_torque])
    worlds = [World() for _ in range(n)]
    separate = [HingedObject(world, config) for world in worlds]
    shared_world = World()
    shared = [HingedObject(shared_world, config) for _ in range(n)]
    repeats = max(BARE_REPEATS // (4 * n), 10)

    def run(objects, step) -> float:
        start = time.perf_counter()
        for _ in range(repeats):
            for obj in objects:
                obj.apply_wrench(force, torque)
            step()
        return (time.perf_counter() - start) / repeats * SUBSTEPS

    def step_each() -> None:
        for world in worlds:
            world.step()

    times = {"n clients": np.inf, "1 client": np.inf}
    for _ in range(rounds):
        times["n clients"] = min(times["n clients"], run(separate, step_each))
        times["1 client"] = min(times["1 client"], run(shared, shared_world.step))
    # Same pushes, same physics: does the layout change the joint angles?
    for obj in (*separate, *shared):
        obj.sync()
    angles = np.array([obj.joint_angle for obj in separate + shared]).reshape(2, n)
    times["joint angle"] = float(np.abs(angles[0]).max())
    times["max joint angle difference"] = float(np.abs(angles[0] - angles[1]).max())
    for world in (*worlds, shared_world):
        world.close()
    return times


def resident_mib() -> float:
    """This process's resident memory, MiB (Linux; NaN elsewhere)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return float("nan")


def footprint(env_id: str, n: int = 16) -> str:
    """Memory and time to make and reset one sub-env, over ``n`` of them, after one env has
    paid the process's one-time costs (the reset distribution's prior, compiled kernels)."""
    gym.make(env_id).reset(seed=0)
    before, start = resident_mib(), time.perf_counter()
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    seconds, mib = (time.perf_counter() - start) / n, (resident_mib() - before) / n
    envs.close()
    return f"`{env_id}`: {mib:.0f} MiB and {seconds:.2f} s to make and reset per sub-env (N = {n})"


def time_vector(
    env_id: str, n: int, workers: int, policy: str, control_steps: int, physics: str
) -> dict[str, float]:
    """Time ``gym.make_vec(env_id, num_envs=n, workers=workers, physics=physics)`` for about
    ``control_steps`` sub-env control steps in all."""
    # The scripted policies read only the id's configuration, so one env of the id made here
    # serves them (the sub-envs may be in workers) and the bare physics: the least of three
    # calls before the row and three after, as the least disturbed by other jobs.
    reference = gym.make(env_id, physics=physics)
    reference.reset(seed=0)
    bare = min(bare_physics_per_control_step(reference) for _ in range(3))
    envs = gym.make_vec(
        env_id,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
        workers=workers,
        physics=physics,
    )
    primitive = env_id in PRIMITIVE_ENV_IDS
    policies = [scripted_policy(reference) for _ in range(n)]
    for pol in policies:
        pol.reset()
    envs.reset(seed=0)
    envs.action_space.seed(0)
    obs, *_ = envs.step(np.zeros(envs.action_space.shape, np.float32))  # warm-up, not timed
    per_step = 13 if primitive else 1  # control steps, to size the run
    vector_steps = max(control_steps // (n * per_step), 3)
    elapsed, done_steps, done_control = 0.0, 0, 0
    for _ in range(vector_steps):
        if policy == "scripted":
            rows = [{k: v[i] for k, v in obs.items()} for i in range(n)]
            actions = np.stack([pol.get_action(row) for pol, row in zip(policies, rows)])
        else:
            actions = envs.action_space.sample()
        start = time.perf_counter()
        obs, _, terminated, truncated, info = envs.step(actions)
        elapsed += time.perf_counter() - start
        ended = terminated | truncated
        done_steps += n
        if primitive:  # an ended sub-env's info is its reset's; its steps are in final_info
            for part in (info, info.get("final_info", {})):
                if "steps" in part:
                    done_control += int(np.sum(part["steps"][part["_steps"]]))
        else:
            done_control += n
        for i in np.flatnonzero(ended):
            policies[i].reset()
    envs.close()
    bare = min(bare, *(bare_physics_per_control_step(reference) for _ in range(3)))
    reference.close()
    return {
        "steps/s": done_steps / elapsed,
        "control steps/s": done_control / elapsed,
        "us/control step": 1e6 * elapsed / done_control,
        "bare us/control step": 1e6 * bare,
    }


def layout_table(sizes: list[int]) -> str:
    lines = [
        "Bare `stepSimulation` per control step (12 substeps), N scissors objects",
        "",
        "| N | N clients, us per object | 1 client, us per object | N clients / 1 client |"
        " joint angle reached (rad) | max difference between layouts (rad) |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for n in sizes:
        r = physics_layouts(n)
        lines.append(
            f"| {n} | {1e6 * r['n clients'] / n:.1f} | {1e6 * r['1 client'] / n:.1f} |"
            f" {r['n clients'] / r['1 client']:.2f} | {r['joint angle']:.2f} |"
            f" {r['max joint angle difference']:.1e} |"
        )
    return "\n".join(lines)


def vector_table(
    env_id: str,
    sizes: list[int],
    worker_counts: list[int],
    control_steps: int,
    physics: list[str],
) -> str:
    primitive = env_id in PRIMITIVE_ENV_IDS
    step = "primitives" if primitive else "sub-env steps"
    lines = [
        f"`{env_id}`, about {control_steps} sub-env control steps per row; wall time",
        "",
        f"| N | workers | policy | physics | {step}/s | control steps/s |"
        " us per sub-env control step | bare physics us per control step |"
        " control step / bare physics |",
        "|---:|---:|---|---|---:|---:|---:|---:|---:|",
    ]
    for n in sizes:
        rows = itertools.product(worker_counts, ("random", "scripted"), physics)
        for workers, policy, name in rows:
            if workers > n:
                continue
            r = time_vector(env_id, n, workers, policy, control_steps, name)
            lines.append(
                f"| {n} | {workers} | {policy} | {name} | {r['steps/s']:,.0f} |"
                f" {r['control steps/s']:,.0f} |"
                f" {r['us/control step']:.0f} | {r['bare us/control step']:.1f} |"
                f" {r['us/control step'] / r['bare us/control step']:.0f}x |"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-envs", type=int, nargs="+", default=[1, 4, 16, 64])
    parser.add_argument(
        "--workers", type=int, nargs="+", default=[1, 2], help="worker processes per row"
    )
    parser.add_argument(
        "--control-steps", type=int, default=800, help="sub-env control steps per row"
    )
    parser.add_argument("--ids", nargs="+", default=["tactile_gym/HingeProbe-v1"])
    add_physics_option(parser)
    args = parser.parse_args(argv)
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the start\n")
    print(footprint(args.ids[0]))
    print()
    print(layout_table(args.n_envs))
    for env_id in args.ids:
        print()
        print(vector_table(env_id, args.n_envs, args.workers, args.control_steps, args.physics))
    print(f"\nload average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
