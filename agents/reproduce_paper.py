"""Reproduce Table I of Matsuo et al. (IROS 2010) in simulation, by touch alone.

    python -m agents.reproduce_paper                      # 10 trials per cell, table + plots
    python -m agents.reproduce_paper --trials 30 --seeds 3 --variants all
    python -m agents.reproduce_paper --sensor offset --no-tare   # an uncompensated offset

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

* **Press** (:func:`press`): the shared press (``tactile_gym.sensing.PressController``, the
  env's too), straight down (world -z) at a chosen point, until the *noisy* reading reaches
  5 N; then the finger holds still and averages readings (a filtered F/T reading), and the
  env's ``TouchSensor`` reads the mean: the indentation-corrected contact point, the skin
  normal and the edge direction, with the noise std divided by sqrt(n) and the env's
  contact shape (``docs/design.md`` 4.5). If the finger sinks ``MISS_DEPTH`` below the grip's
  nominal top without touching, there is no grip under it.
* **Tare** (:class:`~tactile_gym.sensing.Tare`): before each press, right after the lift to
  the travel height (``TRAVEL_CLEARANCE`` above the grip's nominal top) and before moving
  over, the finger holds still and tares the sensor on ``TARE_SAMPLES`` samples; the
  press's readings are compensated with that tare (the finger points down throughout, so
  the fingertip's weight does not change). ``--no-tare`` skips it: the raw readings, with
  the sensor's offset, drift and weight, go to the press and the sensing.
* **Edge search** (:func:`find_edge`): presses along a line across the edge. A press whose
  patch the edge truncates shifts the contact toward the face's interior (the skin normal
  leans that way) and tilts the force off the normal; a press on the open face puts the
  contact right under the sphere centre; a press past the edge rests on the corner. Each
  press moves the next one so that the sphere centre lands ``CENTRE_PAST_CONTACT`` beyond
  the contact point just measured, measured across the edge (the edge direction from the
  press, once observable, sets "across"). That rule has a fixed point about 1 mm past the
  edge (force tilt ~10 deg), where the edge cuts the patch; it takes ``SEARCH_GAIN`` of the
  step, which makes it converge in one or two presses near the edge and walk 4 mm per press
  over the open face. The search stops when the next step would be shorter than
  ``CONVERGED_STEP``; that press, read longer, is the measurement.
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
0.8, free links of 60 and 150 mm. Errors are |(p, q)_est - (p, q)_true| in mm.
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
from tactile_gym.sensing import (
    TARE_SAMPLES,
    HoldRule,
    PressConfig,
    PressController,
    Tare,
    Touch,
    TouchSensor,
    run_press,
)
from tactile_gym.sim import ProbeScene
from tactile_gym.spatial import matrix_to_quaternion, rotvec_to_matrix, z_to

from .cli import make_parser, progress_bar, run_main
from .paper_report import markdown_table, plot
from .paper_scene import (
    CONDITIONS,
    SENSORS,
    NominalLayout,
    condition_object,
    make_scene,
)

#: Measurement schemes: (number of measurements, turn between them in rad).
SCHEMES = {"paper": (4, math.radians(30.0)), "wide": (7, math.radians(20.0))}
CASES = ("slides", "fixed")

TRAVEL_CLEARANCE = 0.0015  # m, sphere bottom over the grip's nominal top while travelling
MISS_DEPTH = 0.004  # m below the nominal top with no touch: no grip under the finger
SEARCH_READINGS = 4  # readings averaged for a search press (0.2 s at 20 Hz)
#: The press of the searches: the shared press to its 5 N (the paper's) on the noisy reading,
#: in steps of at most 0.3 mm; no touch from the travel height to ``MISS_DEPTH`` below the
#: grip's top means no grip under the finger.
PRESS = PressConfig(max_step=0.0003, dwell=SEARCH_READINGS, reach=TRAVEL_CLEARANCE + MISS_DEPTH)
MEASURE_READINGS = 20  # readings averaged for the measurement press (1 s at 20 Hz)
CENTRE_PAST_CONTACT = 0.0026  # m, sphere centre beyond the contact: ~1 mm past the edge
SEARCH_GAIN = 1.5  # the contact moves ~0.4 mm per mm of finger near the edge: 1 / (1 - 0.4)
CONVERGED_STEP = 0.0003  # m
TRUSTED_EDGE_STD = math.radians(5.0)  # rad, an edge this sure sets the search's direction
#: m, the scan step after presses that touched nothing; the finger touches the grip (or its
#: corner) anywhere within ~40 mm across it, so this cannot step over it.
MISS_STEP = 0.012
MAX_PRESSES = 8  # per search
#: m from the nominal hinge along the nominal grip, the first search of a trial. Sliding
#: contacts creep ~10 mm toward the hinge per 30 deg, so they start far out to stay clear of
#: the fixed grip; fixed ones stay, so they start nearer, where an edge-direction error moves
#: the edge line less (docs/design.md 6.3).
START_ALONG = {"slides": 0.060, "fixed": 0.035}
START_ANGLE_RANGE = math.radians(10.0)  # rad, the grip's true start angle, +- (never told)
DOWN_ROTATION = z_to([0.0, 0.0, -1.0])  # finger axis pointing down, sensor to world
DOWN = matrix_to_quaternion(DOWN_ROTATION)


@dataclass
class Pressed:
    """What one press told, world frame.

    Attributes:
        centre: (3,) sphere centre while pressed, m.
        press: the shared press (it holds the readings averaged so far).
        touch: the reading of the averaged wrench (``TouchSensor.sense``); None when the
            finger met nothing above ``MISS_DEPTH`` below the grip's top.
    """

    centre: np.ndarray
    press: PressController
    touch: Touch | None
    tare: Tare | None = None

    @property
    def touched(self) -> bool:
        return self.touch is not None

    @property
    def readings(self) -> int:
        return self.press.readings

    @property
    def wrench(self) -> np.ndarray:
        """(6,) the averaged reading, sensor frame, N and N m."""
        return self.press.mean

    @property
    def point(self) -> np.ndarray:
        """(3,) indentation-corrected contact point, m; NaN without a valid contact."""
        return self.touch.point if self.touched else np.full(3, np.nan)

    @property
    def edge(self) -> np.ndarray:
        """(3,) unit edge direction, oriented physically; NaN when the press shows none."""
        return self.touch.edge if self.touched else np.full(3, np.nan)


@dataclass
class Trial:
    """One trial: its measurements and both estimates.

    Attributes:
        points: (N, 3) contact points, world, m (NaN where a search failed).
        edges: (N, 3) edge directions, world (NaN where unobservable).
        centres: (N, 3) sphere centres of the measurement presses, world, m.
        presses: (N,) presses each search took.
        proposed: (2,) estimated (p, q), m; NaN when the fit was degenerate.
        simple: (2,) estimated (p, q), m; NaN when the fit was degenerate.
    """

    points: np.ndarray
    edges: np.ndarray
    centres: np.ndarray
    presses: np.ndarray
    proposed: np.ndarray
    simple: np.ndarray


# --- the finger --------------------------------------------------------------------------


def _sensor_position(scene: ProbeScene, centre: np.ndarray) -> np.ndarray:
    """Sensor origin that puts the sphere centre at ``centre`` with the finger pointing down."""
    return centre + np.array([0.0, 0.0, scene.geometry.cylinder_length])


def _sphere_centre(scene: ProbeScene) -> np.ndarray:
    return scene.sensor_to_world_point(scene.geometry.sphere_center)


def _move(scene: ProbeScene, centre: np.ndarray) -> None:
    """Move the finger (pointing down) until its sphere centre is at ``centre``, world, m."""
    target = _sensor_position(scene, centre)
    for _ in range(100):
        if np.linalg.norm(scene.fingertip_position - target) < 1e-9:
            return
        scene.control_step(target, DOWN)
    raise RuntimeError(f"the finger did not reach {target} m in 100 control steps")


def _travel_height(scene: ProbeScene, nominal: NominalLayout) -> float:
    """Sphere-centre height, m, that clears the grip's nominal top by TRAVEL_CLEARANCE."""
    return nominal.thickness + TRAVEL_CLEARANCE + scene.geometry.outer_radius


def lift(scene: ProbeScene, nominal: NominalLayout) -> None:
    """Raise the finger straight up to the travel height."""
    centre = _sphere_centre(scene)
    _move(scene, np.r_[centre[:2], _travel_height(scene, nominal)])


def _hold_or_lower(scene: ProbeScene, pressed: Pressed) -> Callable[[float], object]:
    """The press's moves for the finger pointing down: lower the sphere centre by a step."""

    def move(step: float) -> None:
        pressed.centre = pressed.centre - np.array([0.0, 0.0, step])
        scene.control_step(_sensor_position(scene, pressed.centre), DOWN)

    return move


def _reading(scene: ProbeScene, tare: Tare | None, rng: np.random.Generator) -> np.ndarray:
    """A reading, compensated with ``tare`` (None: raw)."""
    reading = scene.read_wrench(rng)
    return reading if tare is None else tare.compensate(reading, DOWN_ROTATION)


def tare_here(scene: ProbeScene, rng: np.random.Generator) -> Tare:
    """Hold the finger still in free air for a control step and tare on the mean of
    ``TARE_SAMPLES`` sensor samples, as the env's tare does."""
    scene.control_step(scene.fingertip_position, DOWN)
    tare = Tare.of(scene.sensor_config)
    tare.take(scene.read_wrench(rng, TARE_SAMPLES), DOWN_ROTATION)
    return tare


def _read_pressed(scene: ProbeScene, pressed: Pressed, rng: np.random.Generator) -> Pressed:
    """Run the press to its end and read what it averaged (``TouchSensor.sense``)."""
    run_press(
        pressed.press,
        lambda: _reading(scene, pressed.tare, rng),
        _hold_or_lower(scene, pressed),
    )
    if pressed.press.phase == "done":
        sensor = TouchSensor(
            scene.geometry, scene.sensor_config, scene.skin_config.normal_stiffness
        )
        pressed.touch = sensor.sense(
            pressed.press.mean,
            scene.fingertip_rotation,
            scene.fingertip_position,
            pressed.press.readings,
        )
    return pressed


def press(
    scene: ProbeScene,
    xy: np.ndarray,
    nominal: NominalLayout,
    rng: np.random.Generator,
    tare: bool = True,
) -> Pressed:
    """Press straight down at world x-y ``xy`` with the shared press (``PRESS``).

    The finger travels at the travel height to above ``xy`` and presses down until the noisy
    reading shows the press's force, then holds still for ``SEARCH_READINGS`` readings. It
    never moves sideways once it touches. It stays pressed on return (``read_on`` reads
    more, then ``lift``); after a miss it is already lifted.

    Args:
        scene: the scene.
        xy: (2,) where to press, world, m.
        nominal: the nominal layout (the grip's top height).
        rng: the noise of the readings.
        tare: tare in free air after the lift (module docstring); False: raw readings.
    """
    lift(scene, nominal)
    zero = tare_here(scene, rng) if tare else None
    centre = np.r_[np.asarray(xy, dtype=float), _travel_height(scene, nominal)]
    _move(scene, centre)
    pressed = _read_pressed(scene, Pressed(centre, PressController(PRESS), None, zero), rng)
    if not pressed.touched:
        lift(scene, nominal)
    return pressed


def read_on(scene: ProbeScene, pressed: Pressed, rng: np.random.Generator, total: int) -> Pressed:
    """Hold a press still and read on until ``total`` readings are averaged in all."""
    if total <= pressed.readings or not pressed.touched:
        return pressed
    pressed.press.extend(HoldRule(total))
    return _read_pressed(scene, pressed, rng)


def _across(edge: np.ndarray, outward: np.ndarray) -> np.ndarray:
    """Unit horizontal direction across ``edge``, on the same side as ``outward``."""
    across = np.array([edge[1], -edge[0]])
    norm = float(np.linalg.norm(across))
    if not norm > 0.3:  # an edge that is not roughly horizontal: keep the old direction
        return outward
    across /= norm
    return across if across @ outward >= 0 else -across


def find_edge(
    scene: ProbeScene,
    start: np.ndarray,
    outward: np.ndarray,
    nominal: NominalLayout,
    rng: np.random.Generator,
    tare: bool = True,
) -> tuple[Pressed, np.ndarray, int]:
    """Find the probed edge by touch and measure there.

    Presses along a line across the edge, starting at ``start``, until a press sits about
    1 mm past the edge (see the module docstring for the rule). That press is then read for
    ``MEASURE_READINGS`` readings in all and returned, the finger still pressed.

    Args:
        scene: the scene.
        start: (2,) first press, world x-y, m.
        outward: (2,) unit direction across the edge, away from the grip's interior.
        nominal: the nominal layout.
        rng: the noise of the readings.
        tare: tare before each press (``press``).

    Returns:
        (the measurement press, the outward direction it was found along, presses taken).
    """
    xy = np.asarray(start, dtype=float)
    outward = np.asarray(outward, dtype=float)
    misses, anchor = 0, xy
    for k in range(1, MAX_PRESSES + 1):
        pressed = press(scene, xy, nominal, rng, tare)
        if pressed.touched and pressed.touch.valid:
            misses = 0
            if pressed.touch.edge_std < TRUSTED_EDGE_STD:
                outward = _across(pressed.edge[:2], outward)
            step = SEARCH_GAIN * ((pressed.point[:2] - xy) @ outward + CENTRE_PAST_CONTACT)
            if abs(step) < CONVERGED_STEP or k == MAX_PRESSES:
                break
            xy = xy + step * outward
        else:
            # Nothing under the finger: the grip is off to one side or the other; look
            # inward first, then outward, ever further.
            if not misses:
                anchor = xy
            misses += 1
            xy = anchor + MISS_STEP * ((misses + 1) // 2) * (-1) ** misses * outward
    return read_on(scene, pressed, rng, MEASURE_READINGS), outward, k


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
    nominal: NominalLayout,
    n: int,
    step: float,
    slides: bool,
    rng: np.random.Generator,
    tare: bool = True,
) -> Trial:
    """One trial of the paper's sequence: N measurements, the grip turned ``step`` between.

    Args:
        scene: the scene; its grip is put at a random start angle here.
        nominal: what the operator knows of the layout.
        n: number of measurements.
        step: turn of the hand between measurements, rad (counter-clockwise).
        slides: whether the contact slides along the edge (else the hand carries the finger).
        rng: start angle, the sensor's offset for the trial and reading noise.
        tare: tare before each press (``press``).
    """
    start_angle = rng.uniform(-START_ANGLE_RANGE, START_ANGLE_RANGE)
    start, outward = nominal.first_search(START_ALONG["slides" if slides else "fixed"])
    home = np.r_[start, _travel_height(scene, nominal)]
    scene.reset(start_angle, _sensor_position(scene, home), DOWN, rng=rng)
    hinge = np.asarray(nominal.hinge, dtype=float)
    points, edges, centres, presses = [], [], [], []
    for i in range(n):
        if i:
            lift(scene, nominal)
            turn_by_hand(scene, step, carry_finger=not slides)
            outward = _turn(outward, step)
            if slides:
                # The last edge line turned about the nominal hinge; search from the foot
                # of the perpendicular from the last press onto it, as far past it as the
                # last press was past its contact.
                centre, point = centres[-1][:2], points[-1][:2]
                if np.all(np.isfinite(point)):
                    turned = _turn_about(point, hinge, step)
                    past = (centre - point) @ _turn(outward, -step)
                    start = centre + (past - (centre - turned) @ outward) * outward
                else:
                    start = centre
            else:
                start = _sphere_centre(scene)[:2]
        pressed, outward, k = find_edge(scene, start, outward, nominal, rng, tare)
        points.append(pressed.point)
        edges.append(pressed.edge)
        centres.append(pressed.centre)
        presses.append(k)
    lift(scene, nominal)
    points, edges = np.array(points), np.array(edges)
    has_point = np.all(np.isfinite(points), axis=1)
    has_edge = has_point & np.all(np.isfinite(edges), axis=1)
    proposed = fit_axis_planar(points[has_edge], edges[has_edge])
    simple = fit_axis_simple(points[has_point])
    return Trial(
        points,
        edges,
        np.array(centres),
        np.array(presses),
        np.full(2, np.nan) if proposed.degenerate else proposed.point[:2],
        np.full(2, np.nan) if simple.degenerate else simple.point[:2],
    )


# --- the experiment ----------------------------------------------------------------------


def reproduce(
    trials: int = 10,
    seeds: tuple[int, ...] = (0,),
    conditions: tuple[str, ...] = ("nominal",),
    schemes: tuple[str, ...] = tuple(SCHEMES),
    nominal: NominalLayout | None = None,
    sensor: str = "realistic",
    tare: bool = True,
    progress: Callable[[], None] | None = None,
) -> dict:
    """Run every cell: ``trials`` trials per seed, each condition, scheme and contact case.

    The trials of a cell draw from the same random streams under every condition, so the
    conditions differ only by what they change. ``sensor`` (of ``SENSORS``) and ``tare``
    (tare before each press) apply to every condition; ``progress`` is called after each
    trial.

    Returns:
        ``{key: cell}`` with key ``(scheme, case)`` for the nominal condition and
        ``(condition, scheme, case)`` for the others; a cell holds ``trials`` (the Trial
        records), ``proposed_mm`` and ``simple_mm`` (errors, NaN where a fit failed).
    """
    results = {}
    for condition in conditions:
        scene = make_scene(condition, sensor)
        layout = NominalLayout.of(condition_object(condition))
        if nominal is not None and condition == "nominal":
            layout = nominal
        try:
            for scheme in schemes:
                n, step = SCHEMES[scheme]
                for case in CASES:
                    runs, proposed, simple = [], [], []
                    for seed in seeds:
                        rng = np.random.default_rng([seed, n, CASES.index(case)])
                        for _ in range(trials):
                            t = run_trial(scene, layout, n, step, case == "slides", rng, tare)
                            runs.append(t)
                            proposed.append(1e3 * position_error(scene, t.proposed))
                            simple.append(1e3 * position_error(scene, t.simple))
                            if progress is not None:
                                progress()
                    key = (scheme, case) if condition == "nominal" else (condition, scheme, case)
                    results[key] = {"trials": runs, "proposed_mm": proposed, "simple_mm": simple}
        finally:
            scene.close()
    return results


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
        "--no-tare", action="store_true", help="never tare: press on the raw readings"
    )
    parser.add_argument("--out", default="results/paper", help="folder for the table and plots")
    parser.add_argument("--no-plot", action="store_true", help="write the table only")
    args = parser.parse_args(argv)
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
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = tuple(range(args.seed, args.seed + args.seeds))
    t0 = time.perf_counter()
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
        )
    finally:
        bar.close()
    table = markdown_table(results, args.trials, len(seeds), SCHEMES)
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
    if not args.no_plot:
        for path in plot(results, true_joint_position(), out):
            print(f"wrote {path}")
    return results


if __name__ == "__main__":
    sys.exit(run_main(main))
