"""Env throughput of the env ids, against bare physics on the same scene in the same run.

    python benchmarks/bench_env.py [--steps 400] [--ids tactile_gym/HingeProbe-v2 ...]
                                   [--physics v2 v3] [--profile]

One markdown table per id, with rows for each contact step of ``--physics`` (the env keyword
``physics``: ``v2``, the exact step, and ``v3``, the lean one, ``docs/design.md`` 3.6) in the
same run. Rows: one process with random actions (mostly free motion), one process with the
scripted baseline (``agents.scripted.scripted_policy``: presses, turns), and a 2-process
async vector env with random actions (its rate is the total of both envs).
Resets are not timed, nor a short scripted episode before the rows (a process's first steps
load the compiled kernels). Times are this thread's CPU time (``time.thread_time``), so other
processes sharing the cores do not count; the vector env's row is wall time (its envs run in
worker processes). The baseline is ``stepSimulation`` alone on the scene the row's env
used, times the substeps of one control step; the ratio says how many times dearer a control
step of the env (skin, sensing, gate, estimator, observation) is than the rigid-body physics.
For the primitive ids a step is a primitive, which runs several control steps of the 6-D env
underneath: the table gives both, and a primitive's cost as a multiple of one control step's
bare physics (issue 16's yardstick). The v3 step does not call ``stepSimulation`` (it
integrates the hinge itself); its baseline is still PyBullet's on the same scene, the
yardstick of every target. For the scripted primitives the table's first line gives the
headline figure, scripted primitives per core-second (thread CPU time).

``--profile`` adds, per id and physics, where a control step of the scripted policy goes: the
skin's compiled kernels (for v3 also the hinge, which runs in the same call), PyBullet's
calls, the rest of ``ProbeScene.control_step`` (the simulator's Python) and the rest of the
env step (controller, sensing, gate, estimator, task, observation). Each part is timed around
its calls with the thread's CPU time, as the rows are, so that other jobs on the cores do not
count; a timed call costs about a microsecond of the clock's own, which is measured on calls
of a function that does nothing and taken off each part and the total. A second scripted run
splits the env's Python the same way (``ENV_PARTS``: the touch sensing, the gate, the stream
checks and tare, the estimator's refits, the reading, the observation, the task's facts and
``info``). The bare-physics multiple of the plain rows is the figure to quote, the split says
what bounds it.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout's agents/

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
import pybullet as p  # noqa: E402

import tactile_gym  # noqa: E402, F401 - registers the envs
from agents.scripted import scripted_policy  # noqa: E402
from tactile_gym.envs.hinge_probe import HingeProbeEnv  # noqa: E402
from tactile_gym.perception import MeasurementGate, MeasurementPipeline  # noqa: E402
from tactile_gym.sensing import TouchSensor  # noqa: E402
from tactile_gym.sim import _kernels, _pose_kernels, _step_kernels  # noqa: E402
from tactile_gym.sim.scene import PHYSICS, ProbeScene  # noqa: E402

#: The calls each part of ``--profile`` times: ((owner, attribute names), ...).
PARTS = {
    "skin kernels": (
        (_kernels, ("select", "substep", "evaluate", "commit")),
        (_pose_kernels, ("advance", "link_pose")),
        (_step_kernels, ("control_step",)),
    ),
    "PyBullet": (
        (
            p,
            (
                "stepSimulation",
                "getJointState",
                "applyExternalForce",
                "applyExternalTorque",
                "resetJointState",
            ),
        ),
    ),
}

#: The parts of the env's Python that ``--profile`` times in a second run, like ``PARTS``; a
#: call within another part (the touch sensing of a press the gate judges) counts in both.
ENV_PARTS = {
    "touch sensing (TouchSensor.sense)": ((TouchSensor, ("sense",)),),
    "gate (MeasurementGate.offer: stillness, hold rule, presses)": ((MeasurementGate, ("offer",)),),
    "stream checks and tare": ((MeasurementPipeline, ("_check", "_compensate")),),
    "estimator refits": ((MeasurementPipeline, ("_estimate",)),),
    "reading and its sample": ((HingeProbeEnv, ("_sample",)),),
    "observation": ((HingeProbeEnv, ("_observation",)),),
    "task facts and info": ((HingeProbeEnv, ("_true_facts", "_true_info")),),
}

#: Blocks of bare ``stepSimulation`` calls; the fastest block is the baseline, because on
#: shared cores a block that another process slowed down says nothing about the physics.
BARE_BLOCKS, BARE_REPEATS = 5, 400


def bare_physics_per_control_step(env: gym.Env) -> float:
    """Seconds of bare ``stepSimulation`` per control step (all its substeps) on the env's
    scene, as the env left it: the fastest of ``BARE_BLOCKS`` blocks."""
    scene = env.unwrapped.scene
    client_id = scene.world.client_id
    best = np.inf
    for _ in range(BARE_BLOCKS):
        start = time.thread_time()
        for _ in range(BARE_REPEATS):
            p.stepSimulation(physicsClientId=client_id)
        best = min(best, (time.thread_time() - start) / BARE_REPEATS)
    return best * scene.substeps


def time_single(
    env_id: str, policy: str, steps: int, physics: str, clock=time.thread_time, timers=()
) -> dict[str, float]:
    """Time ``steps`` env steps in this process (resets excluded) with ``clock``; ``timers``
    (``_Timer``) count only within the steps, and then bare physics is not timed."""
    env = gym.make(env_id, physics=physics)
    obs, _ = env.reset(seed=0)
    env.action_space.seed(0)
    scripted = scripted_policy(env)
    scripted.reset()
    elapsed, control_steps, forces = 0.0, 0, []
    for _ in range(steps):
        action = scripted.get_action(obs) if policy == "scripted" else env.action_space.sample()
        for timer in timers:
            timer.active = True
        start = clock()
        obs, _, terminated, truncated, info = env.step(action)
        elapsed += clock() - start
        for timer in timers:
            timer.active = False
        control_steps += info.get("steps", 1)
        forces.append(float(np.linalg.norm(obs["wrench"][:3])))
        if terminated or truncated:
            obs, _ = env.reset()
            scripted.reset()
    bare = np.nan if timers else bare_physics_per_control_step(env)
    env.close()
    return {
        "steps/s": steps / elapsed,
        "ms/step": 1e3 * elapsed / steps,
        "control steps/step": control_steps / steps,
        "ms/control step": 1e3 * elapsed / control_steps,
        "bare ms/control step": 1e3 * bare,
        "mean |f|": float(np.mean(forces)),
    }


def warm_up(env_id: str, physics: str, steps: int = 40) -> None:
    """A short scripted episode, untimed: a process's first steps load the compiled kernels
    from numba's cache (about 25 ms), which is no control step's cost."""
    env = gym.make(env_id, physics=physics)
    obs, _ = env.reset(seed=0)
    scripted = scripted_policy(env)
    scripted.reset()
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(scripted.get_action(obs))
        if terminated or truncated:
            break
    env.close()


def time_vector(env_id: str, steps: int, physics: str) -> dict[str, float]:
    """Total throughput of a 2-process async vector env with random actions."""
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="async", physics=physics)
    envs.reset(seed=0)
    envs.action_space.seed(0)
    control_steps = 0
    start = time.perf_counter()
    for _ in range(steps):
        *_, info = envs.step(envs.action_space.sample())
        control_steps += int(np.sum(info["steps"])) if "steps" in info else 2
    elapsed = time.perf_counter() - start
    envs.close()
    return {
        "steps/s": 2 * steps / elapsed,
        "ms/step": 1e3 * elapsed / (2 * steps),
        "control steps/step": control_steps / (2 * steps),
        "ms/control step": 1e3 * elapsed / control_steps,
    }


class _Timer:
    """Accumulates the time spent in the wrapped calls, by ``clock``, and counts them, while
    ``active``."""

    def __init__(self, clock) -> None:
        self.clock = clock
        self.seconds = 0.0
        self.calls = 0
        self.depth = 0
        self.active = True

    def wrap(self, function):
        def timed(*args, **kwargs):
            # A part called from within the same part counts once.
            if self.depth or not self.active:
                return function(*args, **kwargs)
            self.depth += 1
            self.calls += 1
            start = self.clock()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds += self.clock() - start
                self.depth -= 1

        return timed


def timer_cost(clock, n: int = 20_000) -> tuple[float, float]:
    """Seconds a timed call adds to its own measurement (inner) and to the whole run (outer),
    from ``n`` timed calls of a function that does nothing."""
    timer = _Timer(clock)
    timed, plain = timer.wrap(lambda: None), lambda: None
    start = clock()
    for _ in range(n):
        plain()
    base = clock() - start
    start = clock()
    for _ in range(n):
        timed()
    return timer.seconds / n, (clock() - start - base) / n


def profile_parts(env_id: str, steps: int, physics: str) -> tuple[dict[str, float], float]:
    """Where a control step of the scripted policy goes (see the module docstring): us per
    control step by part, and the total, less the timers' own cost."""
    clock = time.thread_time
    inner, outer = timer_cost(clock)
    scene_part = {"control_step": ((ProbeScene, ("control_step",)),)}
    timers, result = timed_run(env_id, steps, physics, clock, {**PARTS, **scene_part})
    control_steps = steps * result["control steps/step"]
    scene = timers.pop("control_step")
    nested = sum(t.calls for t in timers.values())  # all within control_step
    parts = {
        name: 1e6 * (t.seconds - t.calls * inner) / control_steps for name, t in timers.items()
    }
    sim = scene.seconds - scene.calls * inner - nested * (outer - inner)
    sim = 1e6 * sim / control_steps
    total = result["ms/control step"] * 1e3 - 1e6 * (nested + scene.calls) * outer / control_steps
    parts["simulator Python"] = sim - sum(parts.values())
    parts["env Python (sensing, gate, estimator, task, observation)"] = total - sim
    return parts, total


def env_parts(env_id: str, steps: int, physics: str) -> dict[str, float]:
    """The env's Python by part (``ENV_PARTS``), us per control step of the scripted
    policy, less the timers' own cost."""
    clock = time.thread_time
    inner, _ = timer_cost(clock)
    timers, result = timed_run(env_id, steps, physics, clock, ENV_PARTS)
    control_steps = steps * result["control steps/step"]
    return {name: 1e6 * (t.seconds - t.calls * inner) / control_steps for name, t in timers.items()}


def timed_run(env_id: str, steps: int, physics: str, clock, parts: dict):
    """A scripted run with the calls of ``parts`` (name: ((owner, attribute names), ...))
    timed: the parts' ``_Timer`` by name, and ``time_single``'s result."""
    timers = {name: _Timer(clock) for name in parts}
    originals = []
    for name, owners in parts.items():
        for owner, attributes in owners:
            for attribute in attributes:
                originals.append((owner, attribute, getattr(owner, attribute)))
                setattr(owner, attribute, timers[name].wrap(getattr(owner, attribute)))
    try:
        result = time_single(
            env_id, "scripted", steps, physics, clock=clock, timers=list(timers.values())
        )
    finally:
        for owner, attribute, original in originals:
            setattr(owner, attribute, original)
    return timers, result


def profile(env_id: str, steps: int, physics: list[str], bare: float) -> str:
    """The profile of each physics side by side, as multiples of ``bare`` (s per control step,
    the table's baseline: measured here it would time the wrapped ``stepSimulation``)."""
    runs = {name: profile_parts(env_id, steps, name) for name in physics}
    bare_us = 1e6 * bare
    lines = [
        f"`{env_id}`, scripted policy, {steps} steps: where one control step goes"
        f" (bare physics {bare_us:.0f} us per control step)",
        "",
        "| part |" + "".join(f" {name} us | {name} x bare |" for name in physics),
        "|---|" + "---:|---:|" * len(physics),
    ]
    for part in runs[physics[0]][0]:
        cells = "".join(
            f" {parts[part]:.0f} | {parts[part] / bare_us:.1f}x |" for parts, _ in runs.values()
        )
        lines.append(f"| {part} |{cells}")
    cells = "".join(f" {total:.0f} | {total / bare_us:.1f}x |" for _, total in runs.values())
    lines.append(f"| total (timed) |{cells}")
    split = {name: env_parts(env_id, steps, name) for name in physics}
    lines += [
        "",
        f"`{env_id}`, scripted policy, {steps} steps, a second run: the env's Python by part",
        "",
        "| part |" + "".join(f" {name} us |" for name in physics),
        "|---|" + "---:|" * len(physics),
    ]
    for part in ENV_PARTS:
        lines.append(f"| {part} |" + "".join(f" {split[name][part]:.1f} |" for name in physics))
    return "\n".join(lines)


def table(env_id: str, steps: int, physics: list[str]) -> tuple[str, float]:
    """The id's markdown table, and its baseline (s of bare physics per control step)."""
    primitive = env_id in tactile_gym.PRIMITIVE_ENV_IDS
    rows = {}
    for name in physics:
        warm_up(env_id, name)
        rows[f"{name}, 1 process, random actions"] = time_single(env_id, "random", steps, name)
        rows[f"{name}, 1 process, scripted policy"] = time_single(env_id, "scripted", steps, name)
        rows[f"{name}, 2-process async vector env, random actions (total)"] = time_vector(
            env_id, steps // 2, name
        )
    # One baseline for every row: the least bare physics measured on the rows' scenes (the
    # vector env's scenes live in its workers).
    bare = min(r["bare ms/control step"] for r in rows.values() if "bare ms/control step" in r)
    step = "primitive" if primitive else "env step"
    lines = [
        f"`{env_id}`, {steps} {step}s per row ({steps // 2} per env in the vector env);"
        f" bare physics {bare:.3f} ms per control step",
    ]
    if primitive:
        lines.append("")
        for name in physics:
            r = rows[f"{name}, 1 process, scripted policy"]
            lines.append(
                f"* {name}: {r['steps/s']:,.0f} scripted primitives per core-second"
                f" ({r['ms/step'] / bare:.0f}x bare physics per control step)"
            )
    lines += [
        "",
        f"| case | {step}s/s | ms per {step} |"
        + (" control steps per primitive | ms per control step |" if primitive else "")
        + " control step / bare physics |"
        + (" primitive / bare physics per control step |" if primitive else "")
        + " mean |f| (N) |",
        "|---|---:|---:|"
        + ("---:|---:|" if primitive else "")
        + "---:|"
        + ("---:|" if primitive else "")
        + "---:|",
    ]
    for name, r in rows.items():
        extra = (
            f" {r['control steps/step']:.1f} | {r['ms/control step']:.2f} |" if primitive else ""
        )
        ratio = r["ms/control step"] / bare
        per_primitive = f" {r['ms/step'] / bare:.0f}x |" if primitive else ""
        force = f"{r['mean |f|']:.1f}" if "mean |f|" in r else "-"
        lines.append(
            f"| {name} | {r['steps/s']:,.0f} | {r['ms/step']:.2f} |{extra}"
            f" {ratio:.1f}x |{per_primitive} {force} |"
        )
    return "\n".join(lines), bare / 1e3


def add_physics_option(parser: argparse.ArgumentParser) -> None:
    """``--physics``, the contact steps a benchmark times in the same run (all by default)."""
    parser.add_argument(
        "--physics",
        nargs="+",
        choices=PHYSICS,
        default=list(PHYSICS),
        help="contact steps to time in the same run (default: all)",
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=400, help="steps per row")
    parser.add_argument("--ids", nargs="+", default=list(tactile_gym.ENV_IDS))
    add_physics_option(parser)
    parser.add_argument(
        "--profile", action="store_true", help="also split a scripted control step into parts"
    )
    args = parser.parse_args(argv)
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the start\n")
    for env_id in args.ids:
        text, bare = table(env_id, args.steps, args.physics)
        print(text)
        print()
        if args.profile:
            print(profile(env_id, args.steps, args.physics, bare))
            print()
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
