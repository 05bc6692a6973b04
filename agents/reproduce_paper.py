"""Reproduce Table I of Matsuo et al. (IROS 2010) in simulation, by touch alone.

    python -m agents.reproduce_paper                      # 10 trials per cell, table + plots
    python -m agents.reproduce_paper --trials 30 --seeds 3 --variants all
    python -m agents.reproduce_paper --sensor offset --no-tare   # an uncompensated offset
    python -m agents.reproduce_paper --world skin_stiffness=2     # a skin the sensing misjudges
    python -m agents.reproduce_paper --record-logs DIR            # each trial as a log
    python -m agents.reproduce_paper --logs DIR                   # Table I from the logs alone

The scene is the paper's: scissors on the table, the right grip (the free link) hinged about
a vertical axis at (17, 105) mm, a soft fingertip on a 6-axis F/T sensor held upright like the
paper's coordinate-measuring machine. Each trial follows the paper's sequence (section IV-C):
touch the grip, measure the contact point and the edge direction, lift, turn the grip
counter-clockwise by hand, and repeat; then fit the joint position (p, q) with the proposed
method (eq. 16-21, unweighted as in the paper) and the simple method (eq. 22-26).

**What the operator knows.** Only the nominal layout (:class:`NominalLayout`: the hinge pin
near (17, 105) mm, the grip pointing toward +x, 20 mm wide, 8 mm thick, its -y edge probed)
and the commanded turn of the hand. The grip's true start angle is drawn in +-10 deg per
trial and never told. Everything the finger does follows from F/T readings:

* **The finger** (:mod:`agents.paper_finger`): every control step it reads the sensor once
  and streams the reading with its pose to the perception pipeline, which tares,
  compensates and gates; the measurements the gate accepts are the trial's, and a trial's
  samples are its log (``--record-logs``), so that replaying the logs gives the same table
  (``--logs``, :func:`from_logs`). It presses straight down with the shared press until the
  *noisy* reading reaches 5 N, tares before each press (``--no-tare`` skips it: the
  readings, less the fingertip's configured weight, keep the sensor's offset and drift),
  and finds the edge by presses across it, each moving the next so that the sphere centre
  lands past the contact just measured, until the gate measures the last.
* **Hand** (:func:`turn_by_hand`, the only code besides the error and the truth helpers
  that reads the simulator's ground truth): sets the joint to the current angle plus the
  commanded turn while the finger is lifted. The hand holds the grip throughout (the joint's
  holding torque is ``HAND_HOLD_TORQUE`` instead of the loose hinge's), so a 5 N press does
  not turn it.
* **Contact slides**: after the turn the finger goes back to where it pressed last and looks
  for the edge again there. The operator predicts the turned edge line by turning the last
  measured one (point and direction) by the commanded turn about the *nominal* hinge, and
  starts the search at the foot of the perpendicular from the last press onto that line. The
  grip turned under the finger, so the new contact lies 10-14 mm nearer the hinge along
  the edge per 30 deg (the paper's "contact points move").
* **Contact fixed**: the hand turns the grip with the finger resting on it, and the finger is
  carried along with the grip (the hand turns the finger's pose about the true axis with the
  joint; the finger is lifted just clear meanwhile, so the skin is not dragged). The finger
  then runs the same edge search from there; as it sits where the last search ended
  relative to the grip, one press usually confirms it. The contact stays at the same point
  of the grip.

The sensor is the env's default (``SensorConfig()``, the realistic one: an offset drawn per
trial, drift, the fingertip's weight); ``--sensor`` picks another (``SENSORS``: ``ideal``,
the v1 ids' white noise only, and ``offset``, the ideal one with a constant offset of 0.1 N
and 2e-3 N m per axis, which shows what an uncompensated zero costs with ``--no-tare``).

Measurement schemes: the paper's 4 measurements 30 deg apart, and a wide one of 7
measurements 20 deg apart (120 deg). Held-out conditions (``--variants``) change the world,
not the protocol: the ideal sensor (the v1 ids'), doubled sensor noise, skin friction 0.3 and
0.8, free links of 60 and 150 mm; the sensing is told of them. ``--world`` changes the world
without telling the sensing (``WORLD_FACTORS``: the skin's stiffness, the sensor's noise and
drift, as factors of the configured values). Errors are |(p, q)_est - (p, q)_true| in mm.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_gym.estimation import fit_axis_planar, fit_axis_simple
from tactile_gym.perception import Measurement
from tactile_gym.perception.log import LogHeader, ProbeLog, load_log, replay, truth_path
from tactile_gym.sim import ProbeScene
from tactile_gym.sim.scene import PHYSICS
from tactile_gym.spatial import matrix_to_quaternion, rotvec_to_matrix

from .cli import make_parser, progress_bar, run_main
from .paper_finger import DOWN, Finger, Pressed, find_edge, lift, log_header, travel_height
from .paper_report import markdown_table, plot
from .paper_scene import (
    CONDITIONS,
    SENSORS,
    WORLD_FACTORS,
    NominalLayout,
    condition_object,
    make_scene,
    parse_world,
)

__all__ = [
    "CASES",
    "SCHEMES",
    "Trial",
    "reproduce",
    "run_trial",
    "true_joint_position",
]

#: Measurement schemes: (number of measurements, turn between them in rad).
SCHEMES = {"paper": (4, math.radians(30.0)), "wide": (7, math.radians(20.0))}
CASES = ("slides", "fixed")

#: m from the nominal hinge along the nominal grip, the first search of a trial. Sliding
#: contacts creep ~10 mm toward the hinge per 30 deg, so they start far out to stay clear of
#: the fixed grip; fixed ones stay, so they start nearer, where an edge-direction error moves
#: the edge line less (docs/design.md 6.3).
START_ALONG = {"slides": 0.060, "fixed": 0.035}
START_ANGLE_RANGE = math.radians(10.0)  # rad, the grip's true start angle, +- (never told)


@dataclass
class Trial:
    """One trial: its measurements and both estimates.

    Attributes:
        points: (M, 3) contact points of the measurements the gate accepted, world, m.
        edges: (M, 3) their edge directions, world, oriented physically.
        presses: (N,) presses each search took.
        proposed: (2,) estimated (p, q), m; NaN when the fit was degenerate.
        simple: (2,) estimated (p, q), m; NaN when the fit was degenerate.
    """

    points: np.ndarray
    edges: np.ndarray
    presses: np.ndarray
    proposed: np.ndarray
    simple: np.ndarray

    @classmethod
    def fitted(cls, measurements: list[Measurement], presses) -> Trial:
        """A trial's record from the measurements the pipeline accepted, in order: the
        paper's proposed fit (eq. 16-21, unweighted) and its simple fit (eq. 22-26)."""
        points = np.array([m.point for m in measurements], dtype=float).reshape(-1, 3)
        edges = np.array([m.edge for m in measurements], dtype=float).reshape(-1, 3)
        proposed = fit_axis_planar(points, edges)
        simple = fit_axis_simple(points)
        return cls(
            points,
            edges,
            np.asarray(presses, dtype=int),
            np.full(2, np.nan) if proposed.degenerate else proposed.point[:2],
            np.full(2, np.nan) if simple.degenerate else simple.point[:2],
        )


# --- the hand (reads the truth) ----------------------------------------------------------


def turn_by_hand(scene: ProbeScene, turn: float, carry_finger: bool) -> None:
    """The hand turns the grip by ``turn`` (rad, counter-clockwise seen from above).

    The finger must be lifted clear. The joint is set to its current angle plus ``turn``.
    With ``carry_finger`` the finger is carried along with the grip, as a finger resting on
    it would be: its pose is turned by ``turn`` about the true axis. Between turns the hand
    steadies the grip: :func:`make_scene` gives the joint a holding torque of
    ``HAND_HOLD_TORQUE``.
    """
    position, rotation = scene.fingertip_position, scene.fingertip_rotation
    if carry_finger:
        pin, axis = scene.true_axis
        spin = rotvec_to_matrix(turn * axis)
        position = pin + spin @ (position - pin)
        rotation = spin @ rotation
    scene.reset(scene.joint_angle + turn, position, matrix_to_quaternion(rotation))


def true_axis_xy(scene: ProbeScene) -> np.ndarray:
    """The true joint position (p, q), world x-y, m (for the error only)."""
    return scene.true_axis[0][:2].copy()


def position_error(scene: ProbeScene, estimate: np.ndarray) -> float:
    """|(p, q)_est - (p, q)_true|, m; NaN for a failed estimate."""
    return float(np.linalg.norm(np.asarray(estimate) - true_axis_xy(scene)))


# --- the protocol --------------------------------------------------------------------------


def _turn_about(point: np.ndarray, centre: np.ndarray, turn: float) -> np.ndarray:
    """Turn x-y ``point`` by ``turn`` rad about x-y ``centre``."""
    c, s = math.cos(turn), math.sin(turn)
    d = np.asarray(point) - centre
    return centre + np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])


def _turn(vector: np.ndarray, turn: float) -> np.ndarray:
    return _turn_about(vector, np.zeros(2), turn)


def run_trial(
    scene: ProbeScene,
    header: LogHeader,
    nominal: NominalLayout,
    n: int,
    step: float,
    slides: bool,
    rng: np.random.Generator,
    tare: bool = True,
) -> tuple[Trial, ProbeLog]:
    """One trial of the paper's sequence: N measurements, the grip turned ``step`` between.

    Args:
        scene: the scene; its grip is put at a random start angle here.
        header: the pipeline's header (:func:`log_header`).
        nominal: what the operator knows of the layout.
        n: number of measurements.
        step: turn of the hand between measurements, rad (counter-clockwise).
        slides: whether the contact slides along the edge (else the hand carries the finger).
        rng: start angle, the sensor's offset for the trial and reading noise.
        tare: tare before each press (``press``).

    Returns:
        The trial (the fits on the measurements the pipeline accepted) and its log.
    """
    start_angle = rng.uniform(-START_ANGLE_RANGE, START_ANGLE_RANGE)
    start, outward = nominal.first_search(START_ALONG["slides" if slides else "fixed"])
    home = np.r_[start, travel_height(scene, nominal) + scene.geometry.cylinder_length]
    scene.reset(start_angle, home, DOWN, rng=rng)
    finger = Finger(scene, header, rng)
    hinge = np.asarray(nominal.hinge, dtype=float)
    last: Pressed | None = None
    presses = []
    for i in range(n):
        if i:
            lift(finger, nominal)
            turn_by_hand(scene, step, carry_finger=not slides)
            outward = _turn(outward, step)
            if slides:
                # The last edge line turned about the nominal hinge; search from the foot
                # of the perpendicular from the last press onto it, as far past it as the
                # last press was past its contact.
                centre, point = last.centre[:2], last.point[:2]
                if np.all(np.isfinite(point)):
                    turned = _turn_about(point, hinge, step)
                    past = (centre - point) @ _turn(outward, -step)
                    start = centre + (past - (centre - turned) @ outward) * outward
                else:
                    start = centre
            else:
                start = finger.centre[:2]
        last, outward, k = find_edge(finger, start, outward, nominal, tare)
        presses.append(k)
    lift(finger, nominal)
    return Trial.fitted(finger.pipeline.measurements, presses), finger.log()


# --- the experiment ----------------------------------------------------------------------


def _log_name(cell: int, key: tuple[str, ...], seed: int, trial: int) -> str:
    """A trial's log file name; sorted, the names keep the run's order."""
    return f"{cell:02d}_{'_'.join(key)}_{seed:06d}_{trial:04d}.npz"


def reproduce(
    trials: int = 10,
    seeds: tuple[int, ...] = (0,),
    conditions: tuple[str, ...] = ("nominal",),
    schemes: tuple[str, ...] = tuple(SCHEMES),
    nominal: NominalLayout | None = None,
    sensor: str = "realistic",
    tare: bool = True,
    progress: Callable[[], None] | None = None,
    world: dict[str, float] | None = None,
    record: str | Path | None = None,
    physics: str = "v2",
) -> dict:
    """Run every cell: ``trials`` trials per seed, each condition, scheme and contact case.

    The trials of a cell draw from the same random streams under every condition, so the
    conditions differ only by what they change. ``sensor`` (of ``SENSORS``), ``tare`` (tare
    before each press) and ``world`` (factors of ``WORLD_FACTORS`` that change the world
    but not what the sensing is told) apply to every condition; ``progress`` is called after
    each trial. With ``record``, each trial is written there as a log with its truth sidecar
    (:func:`from_logs` reads them back). ``physics`` is the contact step
    (``tactile_gym.sim.scene.PHYSICS``).

    Returns:
        ``{key: cell}`` with key ``(scheme, case)`` for the nominal condition and
        ``(condition, scheme, case)`` for the others; a cell holds ``trials`` (the Trial
        records), ``proposed_mm`` and ``simple_mm`` (errors, NaN where a fit failed).
    """
    results = {}
    cell = 0
    for condition in conditions:
        scene = make_scene(condition, sensor, world, physics)
        header = log_header(scene, condition, sensor)
        layout = NominalLayout.of(condition_object(condition))
        if nominal is not None and condition == "nominal":
            layout = nominal
        try:
            for scheme in schemes:
                n, step = SCHEMES[scheme]
                for case in CASES:
                    key = (scheme, case) if condition == "nominal" else (condition, scheme, case)
                    runs, proposed, simple = [], [], []
                    for seed in seeds:
                        rng = np.random.default_rng([seed, n, CASES.index(case)])
                        for k in range(trials):
                            t, log = run_trial(
                                scene, header, layout, n, step, case == "slides", rng, tare
                            )
                            runs.append(t)
                            proposed.append(1e3 * position_error(scene, t.proposed))
                            simple.append(1e3 * position_error(scene, t.simple))
                            if record is not None:
                                truth = {
                                    "key": list(key),
                                    "seed": seed,
                                    "trial": k,
                                    "joint_position": true_axis_xy(scene).tolist(),
                                    "presses": t.presses.tolist(),
                                    "world": world or {},
                                }
                                path = log.save(Path(record) / _log_name(cell, key, seed, k))
                                truth_path(path).write_text(json.dumps(truth))
                            if progress is not None:
                                progress()
                    results[key] = {"trials": runs, "proposed_mm": proposed, "simple_mm": simple}
                    cell += 1
        finally:
            scene.close()
    return results


def from_logs(directory: str | Path) -> tuple[dict, int, int]:
    """Table I from the logs of a run (``reproduce(record=...)``) alone: each log replayed
    through the perception pipeline its header describes (``tactile_gym.perception.log``),
    the paper's fits on the measurements it accepts, scored against the truth sidecar.

    Returns:
        The results as :func:`reproduce` gives them, the trials per cell and seed, and the
        seeds.

    Raises:
        ValueError: the folder holds no trial logs, or a log without its truth sidecar.
    """
    paths = sorted(Path(directory).glob("*.npz"))
    if not paths:
        raise ValueError(f"--logs: no trial logs (*.npz) in {directory}")
    results: dict = {}
    seeds: set[int] = set()
    for path in paths:
        sidecar = truth_path(path)
        if not sidecar.is_file():
            raise ValueError(f"--logs: {path} has no truth sidecar {sidecar.name}")
        truth = json.loads(sidecar.read_text())
        pipeline = replay(load_log(path))
        t = Trial.fitted(pipeline.measurements, truth["presses"])
        joint = np.asarray(truth["joint_position"], dtype=float)
        cell = results.setdefault(
            tuple(truth["key"]), {"trials": [], "proposed_mm": [], "simple_mm": []}
        )
        cell["trials"].append(t)
        cell["proposed_mm"].append(1e3 * float(np.linalg.norm(t.proposed - joint)))
        cell["simple_mm"].append(1e3 * float(np.linalg.norm(t.simple - joint)))
        seeds.add(truth["seed"])
    trials = len(next(iter(results.values()))["trials"]) // len(seeds)
    return results, trials, len(seeds)


def true_joint_position(condition: str = "nominal") -> np.ndarray:
    """The true (p, q) of a condition's scene, world x-y, m (for the plots)."""
    return np.asarray(condition_object(condition).joint_position[:2])


def main(argv: list[str] | None = None) -> dict:
    parser = make_parser(__spec__.name if __spec__ else "agents.reproduce_paper", __doc__)
    parser.add_argument("--trials", type=int, default=10, help="trials per cell and seed")
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    parser.add_argument("--seeds", type=int, default=1, help="seeds: seed, seed + 1, ...")
    parser.add_argument(
        "--variants",
        default="none",
        help="held-out conditions to run as well: 'all', 'none' or a comma list of "
        + ", ".join(c for c in CONDITIONS if c != "nominal"),
    )
    parser.add_argument(
        "--schemes", default="paper,wide", help="comma list of " + ", ".join(SCHEMES)
    )
    parser.add_argument(
        "--sensor",
        default="realistic",
        choices=tuple(SENSORS),
        help="the F/T sensor (default: realistic)",
    )
    parser.add_argument(
        "--no-tare",
        action="store_true",
        help="never tare: press on the readings less the fingertip's configured weight",
    )
    parser.add_argument(
        "--world",
        default="",
        help="what the world has that the sensing is not told, as factors of the configured"
        " values: name=factor pairs of " + ", ".join(WORLD_FACTORS) + " (e.g. 'noise=4')",
    )
    parser.add_argument(
        "--record-logs", metavar="DIR", help="write each trial as a log with its truth sidecar"
    )
    parser.add_argument(
        "--logs",
        metavar="DIR",
        help="make the table from the logs of an earlier --record-logs run alone (the run's"
        " options are then ignored)",
    )
    parser.add_argument(
        "--physics",
        default="v2",
        choices=PHYSICS,
        help="the contact step: v2, exact, or v3, lean (default: v2)",
    )
    parser.add_argument("--out", default="results/paper", help="folder for the table and plots")
    parser.add_argument("--no-plot", action="store_true", help="write the table only")
    args = parser.parse_args(argv)
    out = Path(args.out)
    t0 = time.perf_counter()
    if args.logs is not None:
        results, trials, seeds = from_logs(args.logs)
        return _write(results, trials, seeds, out, not args.no_plot, t0)
    if args.trials < 1 or args.seeds < 1:
        raise ValueError(
            f"--trials and --seeds must be >= 1, got --trials {args.trials}, --seeds {args.seeds}"
        )
    held_out = [c for c in CONDITIONS if c != "nominal"]
    if args.variants == "all":
        variants = held_out
    elif args.variants == "none":
        variants = []
    else:
        variants = args.variants.split(",")
        unknown = [v for v in variants if v not in held_out]
        if unknown:
            raise ValueError(
                f"--variants must be 'all', 'none' or a comma list of {', '.join(held_out)};"
                f" got {', '.join(map(repr, unknown))}"
            )
    schemes = tuple(args.schemes.split(","))
    unknown = [s for s in schemes if s not in SCHEMES]
    if unknown or "paper" not in schemes:
        raise ValueError(
            f"--schemes must include 'paper' and come from {', '.join(SCHEMES)};"
            f" got {args.schemes!r}"
        )
    world = parse_world(args.world)
    seeds = tuple(range(args.seed, args.seed + args.seeds))
    conditions = ("nominal", *variants)
    total = args.trials * len(seeds) * len(conditions) * len(schemes) * len(CASES)
    bar = progress_bar(total, "Table I", "trial")
    try:
        results = reproduce(
            args.trials,
            seeds,
            conditions,
            schemes,
            sensor=args.sensor,
            tare=not args.no_tare,
            progress=bar.update,
            world=world,
            record=args.record_logs,
            physics=args.physics,
        )
    finally:
        bar.close()
    return _write(results, args.trials, len(seeds), out, not args.no_plot, t0)


def _write(results: dict, trials: int, seeds: int, out: Path, plots: bool, t0: float) -> dict:
    """Print Table I and write it (``table1.md``, ``table1.json``) and the plots to ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    table = markdown_table(results, trials, seeds, SCHEMES)
    print(table)
    print(f"({time.perf_counter() - t0:.0f} s)")
    summary = {
        "/".join(key): {
            name: [None if not np.isfinite(v) else v for v in cell[name]]
            for name in ("proposed_mm", "simple_mm")
        }
        for key, cell in results.items()
    }
    (out / "table1.json").write_text(json.dumps(summary, indent=1))
    (out / "table1.md").write_text(table + "\n")
    if plots:
        for path in plot(results, true_joint_position(), out):
            print(f"wrote {path}")
    return results


if __name__ == "__main__":
    sys.exit(run_main(main))
