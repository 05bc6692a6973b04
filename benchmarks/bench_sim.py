"""Speed of the simulator: physics steps/s and control-step cost, in contact and free.

Run: ``python benchmarks/bench_sim.py [--steps N]``. Prints a markdown table. "In contact"
is a steady ~5 N press on the scissors' free link (the paper's probe), a slide along its
edge, and a press held back by the guarded move (the skin's worst case); "free" is the
fingertip moving in the air above the object; "bare" is ``stepSimulation`` alone on the
same scene. Single process, single thread; times are the thread's CPU time
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


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=300, help="control steps per case")
    args = parser.parse_args(argv)
    scene = ProbeScene(ObjectConfig.scissors())
    n_sub = scene.substeps

    pos = _setup_contact(scene)
    # Static press, and a slow 0.02 m/s slide along the edge (stick-slip active).
    press = _time_control(scene, [pos] * args.steps)
    n_nodes = scene.contact.n_active
    force = float(np.linalg.norm(scene.true_wrench[:3]))
    ed = scene.edge_line[1]
    slide = _time_control(scene, [pos + 0.001 * k * ed for k in range(args.steps)][:60])
    # Guarded move held at the force limit: up to 3 skin evaluations per substep.
    pos = _setup_contact(scene)
    scene.force_limit = 0.8 * force
    _time_control(scene, [pos - [0.0, 0.0, 0.002]] * 5)
    guarded = _time_control(scene, [pos - [0.0, 0.0, 0.002]] * args.steps)
    scene.force_limit = 8.0
    pos = _setup_contact(scene)
    bare_contact = _time_bare(scene, args.steps * n_sub)

    high = pos + [0.0, 0.0, 0.05]
    scene.reset(0.0, high, DOWN)
    free = _time_control(
        scene, [high + 0.002 * np.array([np.sin(k), np.cos(k), 0.0]) for k in range(args.steps)]
    )
    bare_free = _time_bare(scene, args.steps * n_sub)
    scene.close()

    rows = [
        ("in contact, static press", press, bare_contact),
        ("in contact, sliding along the edge", slide, bare_contact),
        ("in contact, guarded move at the force limit", guarded, bare_contact),
        ("free (fingertip in the air)", free, bare_free),
    ]
    print(
        f"Scissors, {n_sub} substeps of {1 / 240:.5f} s per control step; "
        f"press {force:.2f} N over {n_nodes} active nodes.\n"
    )
    print(
        "| case | physics steps/s | control step (ms) | control steps/s | bare stepSimulation "
        "steps/s | control step / bare physics |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for name, t, bare in rows:
        print(
            f"| {name} | {n_sub / t:,.0f} | {1e3 * t:.3f} | {1 / t:,.0f} | {1 / bare:,.0f} | "
            f"{t / (n_sub * bare):.1f}x |"
        )


if __name__ == "__main__":
    main()
