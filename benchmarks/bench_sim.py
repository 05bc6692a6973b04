"""Speed of the simulator: physics steps/s and control-step cost, in contact and free.

Run: ``python benchmarks/bench_sim.py [--steps N] [--physics v2 v3]``. Prints a markdown
table with rows for each contact step of ``--physics`` (``ProbeScene(physics=...)``: ``v2``,
the exact step, ``v3``, the lean one, docs/design.md 3.6), measured in the same run. "In
contact" is a steady ~5 N press on the scissors' free link (the paper's probe), a slide along
its edge, and a press held back by the guarded move (the skin's worst case); "free" is the
fingertip moving in the air above the object; "bare" is ``stepSimulation`` alone on the
same scene (the v3 step does not call it; it is every row's yardstick), the least over the
scenes of the run. Single process, single thread; times are the thread's CPU time
(``time.thread_time``), so other processes sharing the cores do not count.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from tactile_gym.sim import ObjectConfig, ProbeScene  # noqa: E402
from tactile_gym.sim.scene import PHYSICS  # noqa: E402

DOWN = np.array([1.0, 0.0, 0.0, 0.0])


def _setup_contact(scene: ProbeScene) -> np.ndarray:
    g = scene.geometry
    ep, ed = scene.edge_line
    centre = ep + 0.05 * ed + [0.0, 0.004, g.outer_radius - 0.001]
    pos = centre + [0.0, 0.0, g.cylinder_length]
    scene.reset(0.0, pos + [0, 0, 0.0015], DOWN)
    for k in range(1, 6):
        scene.control_step(pos + [0, 0, 0.0015 * (1 - k / 5)], DOWN)
    return pos


def _time_control(scene: ProbeScene, targets: list[np.ndarray]) -> float:
    t0 = time.thread_time()
    for tgt in targets:
        scene.control_step(tgt, DOWN)
    return (time.thread_time() - t0) / len(targets)


def _time_bare(scene: ProbeScene, n: int) -> float:
    """Seconds per bare ``stepSimulation``: the fastest of 5 blocks of ``n // 5`` (a block
    that another process slowed down says nothing about the physics)."""
    world = scene.world
    best = np.inf
    for _ in range(5):
        t0 = time.thread_time()
        for _ in range(max(n // 5, 1)):
            world.step()
        best = min(best, (time.thread_time() - t0) / max(n // 5, 1))
    return best


def run_cases(physics: str, steps: int) -> tuple[dict[str, float], float, float, int]:
    """Seconds per control step of each case on a ``physics`` scene, the least bare
    ``stepSimulation`` per substep on it, the press's force (N) and its nodes in contact."""
    scene = ProbeScene(ObjectConfig.scissors(), physics=physics)
    pos = _setup_contact(scene)
    # Static press, and a slow 0.02 m/s slide along the edge (stick-slip active).
    cases = {"in contact, static press": _time_control(scene, [pos] * steps)}
    n_nodes = scene.contact.n_active
    force = float(np.linalg.norm(scene.true_wrench[:3]))
    ed = scene.edge_line[1]
    slide = [pos + 0.001 * k * ed for k in range(steps)][:60]
    cases["in contact, sliding along the edge"] = _time_control(scene, slide)
    # Guarded move held at the force limit: up to 3 skin evaluations per substep.
    pos = _setup_contact(scene)
    scene.force_limit = 0.8 * force
    _time_control(scene, [pos - [0.0, 0.0, 0.002]] * 5)
    guarded = _time_control(scene, [pos - [0.0, 0.0, 0.002]] * steps)
    cases["in contact, guarded move at the force limit"] = guarded
    scene.force_limit = 8.0
    pos = _setup_contact(scene)
    bare = _time_bare(scene, steps * scene.substeps)
    high = pos + [0.0, 0.0, 0.05]
    scene.reset(0.0, high, DOWN)
    circle = [high + 0.002 * np.array([np.sin(k), np.cos(k), 0.0]) for k in range(steps)]
    cases["free (fingertip in the air)"] = _time_control(scene, circle)
    bare = min(bare, _time_bare(scene, steps * scene.substeps))
    scene.close()
    return cases, bare, force, n_nodes


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=300, help="control steps per case")
    parser.add_argument(
        "--physics", nargs="+", choices=PHYSICS, default=list(PHYSICS), help="contact steps"
    )
    args = parser.parse_args(argv)
    runs = {physics: run_cases(physics, args.steps) for physics in args.physics}
    bare = min(run[1] for run in runs.values())
    n_sub = ProbeScene.__init__.__kwdefaults__["substeps"]
    force, n_nodes = runs[args.physics[0]][2:]
    print(
        f"Scissors, {n_sub} substeps of {1 / 240:.5f} s per control step; press {force:.2f} N"
        f" over {n_nodes} active nodes; bare stepSimulation {1 / bare:,.0f} steps/s; load"
        f" average {os.getloadavg()[0]:.2f}.\n"
    )
    print(
        "| physics | case | physics steps/s | control step (ms) | control steps/s |"
        " control step / bare physics |"
    )
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for physics, (cases, *_) in runs.items():
        for name, t in cases.items():
            print(
                f"| {physics} | {name} | {n_sub / t:,.0f} | {1e3 * t:.3f} | {1 / t:,.0f} |"
                f" {t / (n_sub * bare):.1f}x |"
            )


if __name__ == "__main__":
    main()
