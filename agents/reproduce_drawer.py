"""The paper's Table I for a drawer, in simulation and by touch: a slide's direction from the
edge lines, against the contact points' "simple method".

    python -m agents.reproduce_drawer                    # 20 trials per case
    python -m agents.reproduce_drawer --trials 50 --seeds 4

The scene: a drawer whose top face (200 mm wide at the front, 300 mm deep, 50 mm high) is
probed from above, on the table at a yaw drawn per trial within +-5 deg of the nominal one
(never told), sliding along its sides. Each trial (issue 28, item 5): at four displacements
10 mm apart, pulled out by hand, the finger measures the front edge and a side edge (one
horizontal edge cannot give a direction in the table plane: ``docs/design.md`` 6.10). Then
the direction of the slide is estimated from the edge lines (the prismatic model,
``tactile_gym.estimation.fit_slide_direction``, the lines and displacements labelled as the
operator pressed them) and by the simple method (the direction of the contact points'
displacement, ``fit_slide_simple``). Errors are the angle to the true direction, deg.

**What the operator knows.** The nominal layout (:class:`DrawerLayout`: where the drawer
stands, its nominal yaw and its size) and the commanded pull. Everything the finger does
follows from F/T readings, with the paper's finger (``agents.paper_finger``: its press, tare
and edge search, :func:`~agents.paper_finger.find_edge`), which reads of the layout only
the top face's height (``thickness``).

**The hand** (:func:`pull_by_hand` and :func:`carried_by_hand`, with the error the only code
that reads the truth) sets the drawer's travel while the finger is lifted; it holds the
drawer meanwhile (a holding force of ``HAND_HOLD``, so that a press does not move it).

**Contact cases**, as in Table I:

* ``fixed``: each edge's next search starts where its last one ended, moved with the drawer
  by the hand (:func:`carried_by_hand`): the contact stays at one point of the drawer on each
  edge, and its displacement is the drawer's.
* ``slides``: each search starts at the nominal edge moved by the commanded pull, at a place
  along the edge drawn anew (within ``ALONG_SPREAD``): the contact slides along the edges
  between presses, as a finger that finds an edge again by touch does. The contact points'
  displacement is then not the drawer's.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_gym.estimation import fit_slide_direction, fit_slide_simple, slide_error
from tactile_gym.sim import ObjectConfig, ProbeScene, SensorConfig
from tactile_gym.sim.scene import PHYSICS

from .cli import make_parser, progress_bar, run_main
from .paper_finger import DOWN, Finger, find_edge, lift, log_header

__all__ = ["CASES", "DrawerLayout", "Trial", "reproduce"]

CASES = ("slides", "fixed")
DISPLACEMENTS = 4  # measurements per edge
PULL = 0.010  # m, the hand's pull between them
YAW_SPREAD = math.radians(5.0)  # rad, the true yaw about the nominal one, +- (never told)
ALONG_SPREAD = 0.015  # m, ``slides``: where along an edge a search starts, +-
HAND_HOLD = 10.0  # N, the hand holding the drawer (its slide's own holding force: 1.5 N)
SEARCH_INSET = 0.005  # m, a search starts this far inside the nominal edge
POINT_STD = 0.001  # m, a contact point's error as the env's gate states it
HOME_HEIGHT = 0.03  # m, the finger's sensor over the top face at a trial's start


@dataclass(frozen=True)
class DrawerLayout:
    """What the operator knows: the nominal drawer, not the trial's.

    Attributes:
        corner: (2,) the top face's front corner on the cabinet side, world x-y, m (the
            slide's reference point at travel 0).
        yaw: nominal direction of the slide (out of the cabinet), rad from world +x.
        width: the front edge's length, m.
        depth: the side edges' length, m.
        thickness: the top face's height over the table, m (the drawer's height; the
            paper's finger reads it as the grip's thickness).
    """

    corner: tuple[float, float] = (0.0, 0.10)
    yaw: float = math.radians(90.0)
    width: float = 0.20
    depth: float = 0.30
    thickness: float = 0.05

    def frame(self, yaw: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(out, across): the unit direction of the slide and the front edge's, x-y."""
        angle = self.yaw if yaw is None else yaw
        out = np.array([math.cos(angle), math.sin(angle)])
        return out, np.array([out[1], -out[0]])

    def drawer(self, yaw: float) -> ObjectConfig:
        """The drawer at a yaw (the truth of a trial), held by the hand."""
        out, across = self.frame(yaw)
        pin = np.asarray(self.corner) - 0.5 * self.depth * out  # under the top face's centre
        return ObjectConfig.drawer(
            free_link_size=(self.width, self.thickness, self.depth),
            fixed_link_size=(0.01, 0.6 * self.thickness, 1.5 * self.depth),
            joint_position=(*pin, self.thickness / 2),
            axis=(*out, 0.0),
            link_direction=(*across, 0.0),
            lower_limit=-0.05,
            upper_limit=0.10,
            holding_torque=HAND_HOLD,
        )


@dataclass
class Trial:
    """One trial's measurements and both estimates' errors.

    Attributes:
        points: (2 K, 3) contact points, world, m (NaN where a search failed).
        edges: (2 K, 3) edge directions, oriented physically.
        edge_std: (2 K,) their RMS errors, rad.
        lines: (2 K,) 0 the front edge, 1 the side edge.
        configs: (2 K,) the displacement's index.
        proposed: the edge lines' direction error, rad (pi/2: degenerate).
        simple: the contact points' direction error, rad (pi/2: degenerate).
        degenerate: (proposed, simple) whether each fit said its data set no direction.
    """

    points: np.ndarray
    edges: np.ndarray
    edge_std: np.ndarray
    lines: np.ndarray
    configs: np.ndarray
    proposed: float
    simple: float
    degenerate: tuple[bool, bool]


# --- the hand (reads the truth) ------------------------------------------------------------


def pull_by_hand(scene: ProbeScene, travel: float) -> None:
    """The hand sets the drawer's travel (m) with the finger lifted, where it is."""
    scene.reset(travel, scene.fingertip_position, DOWN)


def carried_by_hand(scene: ProbeScene, xy: np.ndarray, travel: float) -> np.ndarray:
    """Where a point of the drawer at ``xy`` (world x-y) went when the hand pulled it by
    ``travel`` (m): the ``fixed`` case's finger, which the hand moved with the drawer."""
    return np.asarray(xy) + travel * scene.true_axis[1][:2]


def true_direction_error(scene: ProbeScene, estimate) -> float:
    """The angle between an estimated direction and the true one, rad."""
    return slide_error(estimate, scene.true_axis[1])


# --- the protocol --------------------------------------------------------------------------


def run_trial(
    scene: ProbeScene, layout: DrawerLayout, slides: bool, rng: np.random.Generator
) -> Trial:
    """One trial (module docstring)."""
    yaw = layout.yaw + rng.uniform(-YAW_SPREAD, YAW_SPREAD)
    config = layout.drawer(yaw)
    out, across = layout.frame()
    corner = np.asarray(layout.corner)
    # Nominal starts: the front edge's middle, and the side edge (away from the cabinet)
    # 60 mm behind the front, each SEARCH_INSET inside.
    starts = {
        0: (corner + 0.5 * layout.width * across - SEARCH_INSET * out, out),
        1: (corner + layout.width * across - 0.06 * out - SEARCH_INSET * across, across),
    }
    home = np.r_[starts[0][0], layout.thickness + HOME_HEIGHT]
    scene.reset(0.0, home, DOWN, object_config=config, rng=rng)
    finger = Finger(scene, log_header(scene, "nominal"), rng)
    points, edges, stds, lines, configs, last = [], [], [], [], [], {}
    for k in range(DISPLACEMENTS):
        if k:
            lift(finger, layout)
            pull_by_hand(scene, k * PULL)
        for line in (0, 1):
            start, outward = starts[line]
            along = across if line == 0 else out
            if slides:
                start = start + k * PULL * out
                start = start + rng.uniform(-ALONG_SPREAD, ALONG_SPREAD) * along
            elif k:
                # Where the last search of this edge ended, on the drawer as it moved.
                start = carried_by_hand(scene, last[line], PULL)
            pressed, _, _ = find_edge(finger, start, outward, layout)
            last[line] = pressed.centre[:2]
            touch = pressed.touch
            ok = pressed.touched and touch.valid and touch.observable
            points.append(touch.point if ok else np.full(3, np.nan))
            edges.append(touch.edge if ok else np.full(3, np.nan))
            stds.append(touch.edge_std if ok else np.nan)
            lines.append(line)
            configs.append(k)
    points, edges, stds = np.array(points), np.array(edges), np.array(stds)
    lines, configs = np.array(lines), np.array(configs)
    ok = np.all(np.isfinite(points), axis=1) & np.all(np.isfinite(edges), axis=1)
    proposed = fit_slide_direction(
        points[ok], edges[ok], POINT_STD, stds[ok], lines=lines[ok], configs=configs[ok],
        planar=True,
    )  # fmt: skip
    simple = fit_slide_simple(points[ok], lines=lines[ok], planar=True)
    return Trial(
        points,
        edges,
        stds,
        lines,
        configs,
        true_direction_error(scene, proposed),
        true_direction_error(scene, simple),
        (proposed.degenerate, simple.degenerate),
    )


def reproduce(
    trials: int = 20,
    seeds: tuple[int, ...] = (0,),
    layout: DrawerLayout = DrawerLayout(),  # noqa: B008 - frozen dataclass
    physics: str = "v3",
    progress=None,
) -> dict:
    """Every trial of both cases: ``{case: [Trial, ...]}`` (``trials`` per seed), the
    realistic F/T sensor (``SensorConfig()``), on the contact step ``physics``."""
    scene = ProbeScene(layout.drawer(layout.yaw), sensor_config=SensorConfig(), physics=physics)
    results = {}
    try:
        for case in CASES:
            runs = []
            for seed in seeds:
                rng = np.random.default_rng([seed, CASES.index(case)])
                for _ in range(trials):
                    runs.append(run_trial(scene, layout, case == "slides", rng))
                    if progress is not None:
                        progress()
            results[case] = runs
    finally:
        scene.close()
    return results


def table(results: dict, trials: int, seeds: int) -> str:
    """The table: mean / median / P90 direction error per case and method, deg (a
    degenerate fit counts as 90 deg), and how many fits were degenerate."""

    def stats(values) -> str:
        v = np.degrees(np.asarray(values, dtype=float))
        return f"{v.mean():.2f} / {np.median(v):.2f} / {np.percentile(v, 90):.2f}"

    lines = [
        f"Drawer, {DISPLACEMENTS} displacements {PULL * 1e3:.0f} mm apart, front and side edge"
        f" at each; {seeds} seed(s) x {trials} trials per case; direction error, deg,"
        " mean / median / P90 (a degenerate fit counts as 90 deg):",
        "",
        "| contact | edge lines (proposed) | contact points (simple) | simple / proposed"
        " | degenerate: proposed / simple |",
        "|---|---|---|---|---|",
    ]
    for case, runs in results.items():
        proposed = [t.proposed for t in runs]
        simple = [t.simple for t in runs]
        ratio = np.mean(simple) / np.mean(proposed)
        degenerate = np.sum([t.degenerate for t in runs], axis=0)
        lines.append(
            f"| {case} | {stats(proposed)} | {stats(simple)} | {ratio:.1f}x"
            f" | {degenerate[0]} / {degenerate[1]} of {len(runs)} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict:
    parser = make_parser(__spec__.name if __spec__ else "agents.reproduce_drawer", __doc__)
    parser.add_argument("--trials", type=int, default=20, help="trials per case and seed")
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    parser.add_argument("--seeds", type=int, default=1, help="seeds: seed, seed + 1, ...")
    parser.add_argument(
        "--physics", default="v3", choices=PHYSICS, help="the contact step (default: v3)"
    )
    parser.add_argument("--out", default="results/drawer", help="folder for the table")
    args = parser.parse_args(argv)
    if args.trials < 1 or args.seeds < 1:
        raise ValueError(
            f"--trials and --seeds must be >= 1, got --trials {args.trials}, --seeds {args.seeds}"
        )
    seeds = tuple(range(args.seed, args.seed + args.seeds))
    start = time.perf_counter()
    bar = progress_bar(args.trials * len(seeds) * len(CASES), "drawer", "trial")
    try:
        results = reproduce(args.trials, seeds, physics=args.physics, progress=bar.update)
    finally:
        bar.close()
    text = table(results, args.trials, len(seeds))
    print(text)
    print(f"({time.perf_counter() - start:.0f} s)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "drawer.md").write_text(text + "\n")
    summary = {
        case: {
            "proposed_deg": [math.degrees(t.proposed) for t in runs],
            "simple_deg": [math.degrees(t.simple) for t in runs],
        }
        for case, runs in results.items()
    }
    (out / "drawer.json").write_text(json.dumps(summary, indent=1))
    return results


if __name__ == "__main__":
    sys.exit(run_main(main))
