"""Reproduce Table I of Matsuo et al. (IROS 2010) in simulation.

    python -m agents.reproduce_paper                 # 10 trials per cell, table + plots
    python -m agents.reproduce_paper --trials 2      # quick check

The set-up is ``HingeProbe-v0``'s scene at its nominal layout: scissors on the table, true
axis at (17, 105) mm. As in the paper's sequence (section IV-C), each trial takes N
measurements; before each one the grip is turned counter-clockwise by a fixed step "by hand"
(the joint is set), and during a measurement the joint is held (its holding torque is raised
to ``HOLD_TORQUE``, like a hand steadying the grip). A measurement is the paper's 5 N press on
the edge, plus the 0.8 mm shear across the edge that the physics needs to make the edge
observable (DESIGN.md 2.1-2.2); the wrench is then averaged over ``N_READINGS`` readings.
It goes through the package's own ``estimate_contact`` (indentation-corrected point, edge
direction) into the paper's proposed planar fit (eq. 16-21, unweighted as in the paper)
and its simple method (eq. 22-26).

Cells: the contact point *slides* along the edge between measurements (``SLIDE_PER_RAD`` of
travel per radian of turn, i.e. 10 mm per 30 deg) or *does not* (the same point of the grip
is pressed every time); the paper's 4 measurements 30 deg apart, and a wide variant of
7 measurements 20 deg apart (120 deg). Errors are |(p, q)_est - (p, q)_true| in mm.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_gym.envs.plotting import draw_estimate, draw_measurements
from tactile_gym.envs.scenarios import probed_edge, quaternion_z_to
from tactile_gym.estimation import fit_axis_planar, fit_axis_simple
from tactile_gym.sensing import estimate_contact
from tactile_gym.sim import ObjectConfig, ProbeScene, SkinConfig

#: Table I of the paper: mean joint-position error, mm.
PAPER_TABLE = {
    ("slides", "proposed"): 6.0,
    ("slides", "simple"): 27.7,
    ("fixed", "proposed"): 7.1,
    ("fixed", "simple"): 5.9,
}
HOLD_TORQUE = 2.0  # N m, joint held during a measurement
SLIDE_PER_RAD = 0.010 / np.deg2rad(30.0)  # m of contact travel along the edge per rad of turn
PRESS_FORCE = 5.0  # N
APPROACH_TILT = np.deg2rad(10.0)  # rad, finger axis from vertical toward the probed side
SHEAR = 0.0008  # m, across the edge
N_READINGS = 4  # wrench readings averaged per measurement (0.2 s at 20 Hz)
VARIANTS = {"paper": (4, np.deg2rad(30.0)), "wide": (7, np.deg2rad(20.0))}


@dataclass
class Trial:
    points: np.ndarray  # (N, 3) contact points, world, m
    edges: np.ndarray  # (N, 3) edge directions, world
    proposed: np.ndarray  # (2,) estimated (p, q), m
    simple: np.ndarray  # (2,) estimated (p, q), m


def measure(
    scene: ProbeScene, joint_angle: float, along: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """One press-and-shear measurement at a joint angle and a point along the edge.

    Returns the indentation-corrected contact point and the edge direction (world frame);
    NaNs when the contact estimate is invalid or the edge unobservable.
    """
    geometry = scene.geometry
    origin, direction, side, top = probed_edge(scene.object_config, joint_angle)
    approach = np.cos(APPROACH_TILT) * top + np.sin(APPROACH_TILT) * side
    centre = origin + along * direction + approach * (geometry.outer_radius + 0.002)
    orientation = quaternion_z_to(-approach)
    position = centre + approach * geometry.cylinder_length
    scene.reset(joint_angle, position, orientation)
    for _ in range(80):  # press straight down until the paper's 5 N
        if np.linalg.norm(scene.true_wrench[:3]) >= PRESS_FORCE:
            break
        position = position - np.array([0.0, 0.0, 0.0003])
        scene.control_step(position, orientation)
    for _ in range(4):  # shear across the edge, away from the link
        position = position + side * SHEAR / 4
        scene.control_step(position, orientation)
    wrench = np.zeros(6)
    for _ in range(N_READINGS):  # hold still and average, as a filtered F/T reading would
        scene.control_step(position, orientation)
        wrench += scene.read_wrench(rng) / N_READINGS
    contact = estimate_contact(
        wrench[:3], wrench[3:], geometry, skin_stiffness=scene.skin_config.normal_stiffness
    )
    if not contact.valid:
        return np.full(3, np.nan), np.full(3, np.nan)
    point = scene.sensor_to_world_point(contact.corrected_point)
    edge = scene.sensor_to_world_vector(contact.edge_direction)
    return point, edge


def run_trial(
    scene: ProbeScene, n: int, step: float, slides: bool, rng: np.random.Generator
) -> Trial:
    """N measurements, the grip turned by ``step`` between them."""
    start_angle = rng.uniform(-np.deg2rad(10.0), np.deg2rad(10.0))
    start_along = rng.uniform(0.03, 0.04)
    points, edges = [], []
    for i in range(n):
        angle = start_angle + i * step
        along = start_along + (i * step * SLIDE_PER_RAD if slides else 0.0)
        point, edge = measure(scene, angle, along, rng)
        points.append(point)
        edges.append(edge)
    points, edges = np.array(points), np.array(edges)
    ok = np.all(np.isfinite(points), axis=1) & np.all(np.isfinite(edges), axis=1)
    proposed = fit_axis_planar(points[ok], edges[ok])
    simple = fit_axis_simple(points[np.all(np.isfinite(points), axis=1)])
    return Trial(points, edges, proposed.point[:2], simple.point[:2])


def reproduce(trials: int = 10, seed: int = 0) -> dict:
    """Run every cell; returns the per-trial errors (mm) and the trials themselves."""
    config = ObjectConfig.scissors(holding_torque=HOLD_TORQUE)
    scene = ProbeScene(config, SkinConfig())
    truth = np.asarray(config.joint_position[:2])
    results = {}
    try:
        for variant, (n, step) in VARIANTS.items():
            for case in ("slides", "fixed"):
                rng = np.random.default_rng([seed, n, case == "slides"])
                runs = [run_trial(scene, n, step, case == "slides", rng) for _ in range(trials)]
                results[(variant, case)] = {
                    "trials": runs,
                    "proposed_mm": [1e3 * float(np.linalg.norm(t.proposed - truth)) for t in runs],
                    "simple_mm": [1e3 * float(np.linalg.norm(t.simple - truth)) for t in runs],
                }
    finally:
        scene.close()
    return results


def markdown_table(results: dict, trials: int) -> str:
    lines = [
        f"Joint-position error |(p, q)_est - (p, q)_true| in mm, {trials} trials per cell "
        "(mean / median); paper = Table I mean.",
        "",
        "| measurements | contact | proposed (sim) | proposed (paper) | simple (sim) |"
        " simple (paper) | simple / proposed |",
        "|---|---|---|---|---|---|---|",
    ]
    for (variant, case), r in results.items():
        n, step = VARIANTS[variant]
        prop, simp = np.array(r["proposed_mm"]), np.array(r["simple_mm"])
        paper = (
            (f"{PAPER_TABLE[(case, 'proposed')]:.1f}", f"{PAPER_TABLE[(case, 'simple')]:.1f}")
            if variant == "paper"
            else ("-", "-")
        )
        lines.append(
            f"| {n} x {np.degrees(step):.0f} deg | {'slides' if case == 'slides' else 'fixed'} |"
            f" {prop.mean():.1f} / {np.median(prop):.1f} | {paper[0]} |"
            f" {simp.mean():.1f} / {np.median(simp):.1f} | {paper[1]} |"
            f" {np.median(simp) / max(np.median(prop), 1e-9):.1f}x |"
        )
    return "\n".join(lines)


def plot(results: dict, truth: np.ndarray, out: Path) -> list[Path]:
    """Fig. 12/13-style top views, one PNG per contact case of the paper variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for case, title in (("slides", "contact points move"), ("fixed", "contact points fixed")):
        runs = results[("paper", case)]["trials"]
        fig, axes = plt.subplots(1, 2, figsize=(9, 4.5), sharex=True, sharey=True)
        for ax, method in zip(axes, ("proposed", "simple")):
            for t in runs:
                draw_measurements(ax, t.points, t.edges)
                draw_estimate(ax, np.r_[truth, 0.0], np.r_[getattr(t, method), 0.0])
            ax.set_title(f"{method} method")
            ax.set_xlabel("x [mm]")
            ax.set_aspect("equal")
        axes[0].set_ylabel("y [mm]")
        fig.suptitle(f"Estimated joint position, {title} (blue: truth, red: estimates)")
        fig.tight_layout()
        path = out / f"fig_{case}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="results/paper")
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args(argv)
    if args.trials < 1:
        raise ValueError(f"--trials must be >= 1, got {args.trials}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = reproduce(args.trials, args.seed)
    table = markdown_table(results, args.trials)
    print(table)
    summary = {
        f"{variant}/{case}": {"proposed_mm": r["proposed_mm"], "simple_mm": r["simple_mm"]}
        for (variant, case), r in results.items()
    }
    (out / "table1.json").write_text(json.dumps(summary, indent=1))
    (out / "table1.md").write_text(table + "\n")
    if not args.no_plot:
        truth = np.asarray(ObjectConfig.scissors().joint_position[:2])
        for path in plot(results, truth, out):
            print(f"wrote {path}")
    return results


if __name__ == "__main__":
    main()
