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

* **Stream** (:class:`Finger`): every control step, travel included, reads the sensor once and
  feeds the reading with the fingertip's pose, as a robot streams them, to the perception
  pipeline (``tactile_gym.perception.MeasurementPipeline``, built from :func:`log_header`:
  the configured sensing, the gate ``GATE``, an estimator without a prior). The pipeline
  tares, compensates and gates; its accepted measurements are the trial's, and a trial's
  samples are its log (``--record-logs``), so that replaying the logs gives the same table
  (``--logs``, :func:`from_logs`).
* **Press** (:func:`press`): the shared press (``tactile_gym.sensing.PressController``, the
  env's too), straight down (world -z) at a chosen point, until the *noisy* (compensated)
  reading reaches 5 N, stepping by the force gradient it measures (``docs/design.md`` 5.2);
  then the finger holds still until ``SEARCH_HOLD`` is met, and the pipeline's
  ``TouchSensor`` reads their mean (the indentation-corrected contact point, the skin normal
  and the edge direction, with the noise std divided by sqrt(n) and the env's contact shape,
  ``docs/design.md`` 4.5) to steer the search. If the finger sinks ``MISS_DEPTH`` below the
  grip's nominal top without touching, there is no grip under it.
* **Tare**: before each press, after the lift to the travel height (``TRAVEL_CLEARANCE`` above
  the grip's nominal top) and the move over the press point, the finger holds still and
  tares the sensor on ``TARE_SAMPLES`` samples (a ``tare`` event of the stream): the later
  the tare, the less the sensor drifts before the press is read. ``--no-tare`` skips it: the
  readings, less the fingertip's configured weight (pointing down throughout), keep the
  sensor's offset and drift.
* **Edge search** (:func:`find_edge`): presses along a line across the edge. A press whose
  patch the edge truncates shifts the contact toward the face's interior (the skin normal
  leans that way) and tilts the force off the normal; a press on the open face puts the
  contact right under the sphere centre; a press past the edge rests on the corner. Each
  press moves the next one so that the sphere centre lands ``CENTRE_PAST_CONTACT`` beyond
  the contact point just measured, measured across the edge (the edge direction from the
  press, once observable, sets "across"). That rule has a fixed point about 1.2 mm past the
  edge (force tilt ~10.5 deg), where the edge cuts the patch; it takes ``SEARCH_GAIN`` of the
  step, which makes it converge in one or two presses near the edge and walk 4 mm per press
  over the open face. The search stops when the next step would be shorter than
  ``CONVERGED_STEP``; that press holds on until the gate's hold rule measures it (the
  predicted edge error of the mean reaching a target, within a budget: ``HoldRule``), and
  what the gate accepts is the measurement.
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

import dataclasses
import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_gym.estimation import fit_axis_planar, fit_axis_simple
from tactile_gym.perception import GateConfig, Measurement, MeasurementPipeline, Perceived, Sample
from tactile_gym.perception.log import LogHeader, ProbeLog, load_log, replay, truth_path
from tactile_gym.sensing import (
    TARE_SAMPLES,
    HoldRule,
    PressConfig,
    PressController,
    Touch,
    predicted_edge_std,
    run_press,
)
from tactile_gym.sim import ProbeScene
from tactile_gym.sim.scene import PHYSICS
from tactile_gym.spatial import (
    matrix_to_quaternion,
    matrix_to_rotvec,
    quaternion_to_matrix,
    rotvec_to_matrix,
    z_to,
)

from .cli import make_parser, progress_bar, run_main
from .paper_report import markdown_table, plot
from .paper_scene import (
    CONDITIONS,
    SENSORS,
    WORLD_FACTORS,
    NominalLayout,
    condition_object,
    configured,
    make_scene,
    parse_world,
)

__all__ = [
    "CASES",
    "DOWN",
    "SCHEMES",
    "Finger",
    "Pressed",
    "Trial",
    "find_edge",
    "lift",
    "log_header",
    "press",
    "read_on",
    "reproduce",
    "run_trial",
    "true_joint_position",
]

#: Measurement schemes: (number of measurements, turn between them in rad).
SCHEMES = {"paper": (4, math.radians(30.0)), "wide": (7, math.radians(20.0))}
CASES = ("slides", "fixed")

TRAVEL_CLEARANCE = 0.0015  # m, sphere bottom over the grip's nominal top while travelling
MISS_DEPTH = 0.004  # m below the nominal top with no touch: no grip under the finger
#: A search press holds until the predicted edge error of its mean is 2 deg (4 readings,
#: 0.2 s at 20 Hz, with the configured noise), within 15: enough to steer by, and on a
#: noisier sensor than configured the search does not dither on noisy contact points.
SEARCH_HOLD = HoldRule(4, math.radians(2.0), 15)
#: The press of the searches: the shared press to its 5 N (the paper's) on the noisy reading,
#: in steps of at most 0.3 mm by the force gradient it measures, approaching in free air at
#: 0.6 mm a step (a touch within it loads the skin by at most about 1 N on the configured
#: skin, 2 N on one twice as stiff: the press steps back from there), so that the press is
#: read soon after its tare, then holding by ``SEARCH_HOLD``; no touch from the travel
#: height to ``MISS_DEPTH`` below the grip's top means no grip under the finger.
PRESS = PressConfig(
    max_step=0.0003,
    approach_step=0.0006,
    measure_gradient=True,
    dwell=SEARCH_HOLD.least,
    edge_std_target=SEARCH_HOLD.target,
    dwell_budget=SEARCH_HOLD.budget,
    reach=TRAVEL_CLEARANCE + MISS_DEPTH,
)
#: The gate of the protocol's pipeline. It measures the press the search ends on once the
#: predicted edge error of its mean reaches ``edge_std_target`` (about 20 readings, 1 s at
#: 20 Hz, with the configured noise; longer where the readings scatter more), after at least
#: ``dwell`` readings (more than a search press holds, so none is measured) and at most
#: ``dwell_budget``; the force's steadiness is judged on its trend, which a long window of a
#: noisy sensor does not inflate (``docs/design.md`` 5.2). No probed-edge distance is known,
#: and the paper's sliding contacts creep toward the hinge, so none is refused for nearing it.
GATE = GateConfig(
    dwell=SEARCH_HOLD.budget + 1,
    edge_std_target=math.radians(0.7),
    dwell_budget=100,
    steady_rule="trend",
    min_hinge_distance=0.0,
)
#: m, sphere centre beyond the contact: ~1.2 mm past the edge, where the force tilts about
#: 10.5 deg (the edge's error from the sensor's noise and drift goes as 1 / sin(tilt)); much
#: further out the contact point stops following the finger and the search dithers.
CENTRE_PAST_CONTACT = 0.0030
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
#: The finger's largest move and turn per control step between presses: 0.2 m/s and
#: 1.7 rad/s at 20 Hz, below what the pipeline takes for a jump in the stream (the defaults
#: of ``StreamLimits``).
TRAVEL_STEP = 0.010  # m
TURN_STEP = math.radians(5.0)  # rad
DOWN = matrix_to_quaternion(DOWN_ROTATION)


class Finger:
    """The operator's fingertip on its F/T sensor, streaming as a robot does.

    Every control step moves the finger (pointing down) toward a target, reads the sensor once
    (a tare's reading averages ``TARE_SAMPLES`` samples) and feeds the reading with the pose
    to the perception pipeline (``tactile_gym.perception``) as one :class:`Sample`; the
    samples are kept, so the trial can be written as a log (:meth:`log`). The pose is the
    logged one: the rotation read back from its quaternion, so that a replay of the log feeds
    the pipeline the same numbers.

    Args:
        scene: the scene, reset for the trial.
        header: what the pipeline is built from (the configured sensing and ``GATE``).
        rng: the noise of the readings.
    """

    def __init__(self, scene: ProbeScene, header: LogHeader, rng: np.random.Generator) -> None:
        self.scene = scene
        self.header = header
        self.rng = rng
        self.pipeline: MeasurementPipeline = header.pipeline()
        self.samples: list[Sample] = []
        self._quaternions: list[np.ndarray] = []
        self.perceived = self.pipeline.reset(self._sample(tare=False))

    @property
    def wrench(self) -> np.ndarray:
        """(6,) the latest reading as the pipeline compensated it (tared), sensor frame."""
        return self.perceived.wrench

    @property
    def centre(self) -> np.ndarray:
        """(3,) the sphere centre, world, m."""
        return self.scene.sensor_to_world_point(self.scene.geometry.sphere_center)

    def step(self, centre: np.ndarray, tare: bool = False) -> Perceived:
        """One control step toward a sphere centre at ``centre`` (world, m) and pointing down,
        at most ``TRAVEL_STEP`` and ``TURN_STEP`` of it, then one reading (a tare taken on it
        with ``tare``: hold still in free air)."""
        scene = self.scene
        target = np.asarray(centre, dtype=float) + [0.0, 0.0, scene.geometry.cylinder_length]
        move = target - scene.fingertip_position
        distance = float(np.linalg.norm(move))
        if distance > TRAVEL_STEP:
            target = scene.fingertip_position + move * (TRAVEL_STEP / distance)
        rotation = DOWN_ROTATION
        turn = matrix_to_rotvec(DOWN_ROTATION @ scene.fingertip_rotation.T)
        angle = float(np.linalg.norm(turn))
        if angle > TURN_STEP:
            rotation = rotvec_to_matrix(turn * (TURN_STEP / angle)) @ scene.fingertip_rotation
        scene.control_step(target, rotation)
        self.perceived = self.pipeline.step(self._sample(tare))
        return self.perceived

    def sense(self, wrench: np.ndarray, readings: int) -> Touch:
        """The pipeline's reading (``TouchSensor.sense``) of a mean of the compensated readings
        at the current pose."""
        sample = self.samples[-1]
        return self.pipeline.sensor.sense(wrench, sample.rotation, sample.position, readings)

    def log(self) -> ProbeLog:
        """The trial so far as a log (``tactile_gym.perception.log``)."""
        log = ProbeLog.from_samples(self.header, self.samples)
        return dataclasses.replace(log, quaternion=np.array(self._quaternions))

    def _sample(self, tare: bool) -> Sample:
        scene = self.scene
        quaternion = matrix_to_quaternion(scene.fingertip_rotation)
        sample = Sample(
            time=len(self.samples) * self.header.period,
            wrench=scene.read_wrench(self.rng, TARE_SAMPLES if tare else 1),
            position=scene.fingertip_position.copy(),
            rotation=quaternion_to_matrix(quaternion),
            tare=tare,
        )
        self.samples.append(sample)
        self._quaternions.append(quaternion)
        return sample


@dataclass
class Pressed:
    """What one press told, world frame.

    Attributes:
        centre: (3,) sphere centre while pressed, m.
        press: the shared press (it holds the readings averaged so far).
        touch: the protocol's own reading of the averaged wrench (``TouchSensor.sense``),
            which steers the search; None when the finger met nothing above ``MISS_DEPTH``
            below the grip's top.
        measurement: the measurement the pipeline's gate accepted on this press, if any.
    """

    centre: np.ndarray
    press: PressController
    touch: Touch | None
    measurement: Measurement | None = None

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


# --- the finger --------------------------------------------------------------------------


def _move(finger: Finger, centre: np.ndarray) -> None:
    """Move the finger until its sphere centre is at ``centre`` (world, m) and it points down
    (after the hand carried it round, it turns back first: a press while it turns drags the
    skin, and the gate refuses it)."""
    for _ in range(100):
        turned = np.abs(finger.scene.fingertip_rotation - DOWN_ROTATION).max()
        if np.linalg.norm(finger.centre - centre) < 1e-9 and turned < 1e-9:
            return
        finger.step(centre)
    raise RuntimeError(f"the finger did not reach {centre} m in 100 control steps")


def _travel_height(scene: ProbeScene, nominal: NominalLayout) -> float:
    """Sphere-centre height, m, that clears the grip's nominal top by TRAVEL_CLEARANCE."""
    return nominal.thickness + TRAVEL_CLEARANCE + scene.geometry.outer_radius


def lift(finger: Finger, nominal: NominalLayout) -> None:
    """Raise the finger straight up to the travel height."""
    _move(finger, np.r_[finger.centre[:2], _travel_height(finger.scene, nominal)])


def tare_here(finger: Finger) -> None:
    """Hold the finger still in free air for a control step and tare on its reading, the mean
    of ``TARE_SAMPLES`` sensor samples, as the env's tare does."""
    finger.step(finger.centre, tare=True)


def _read_pressed(finger: Finger, pressed: Pressed, still: bool = False) -> Pressed:
    """Run the press to its end on the pipeline's compensated readings, and read what it
    averaged (``TouchSensor.sense``); a measurement the gate accepts on the way is kept.
    With ``still``, hold still for the first reading (the latest one was the press's)."""

    def move(step: float) -> None:
        pressed.centre = pressed.centre - np.array([0.0, 0.0, step])
        accepted = finger.step(pressed.centre).accepted
        if accepted:
            pressed.measurement = accepted[-1]

    if still:
        move(0.0)
    run_press(pressed.press, lambda: finger.wrench, move)
    if pressed.press.phase == "done":
        pressed.touch = finger.sense(pressed.press.mean, pressed.press.readings)
    return pressed


def press(finger: Finger, xy: np.ndarray, nominal: NominalLayout, tare: bool = True) -> Pressed:
    """Press straight down at world x-y ``xy`` with the shared press (``PRESS``).

    The finger travels at the travel height to above ``xy`` and presses down until the noisy
    reading shows the press's force, then holds still until ``SEARCH_HOLD`` is met. It
    never moves sideways once it touches. It stays pressed on return (``read_on`` reads
    more, then ``lift``); after a miss it is already lifted.

    Args:
        finger: the finger.
        xy: (2,) where to press, world, m.
        nominal: the nominal layout (the grip's top height).
        tare: tare in free air after the lift (module docstring); False: never.
    """
    lift(finger, nominal)
    centre = np.r_[np.asarray(xy, dtype=float), _travel_height(finger.scene, nominal)]
    _move(finger, centre)
    if tare:
        tare_here(finger)
    controller = PressController(PRESS, finger.pipeline.sensor)
    pressed = _read_pressed(finger, Pressed(centre, controller, None))
    if not pressed.touched:
        lift(finger, nominal)
    return pressed


def read_on(finger: Finger, pressed: Pressed, rule: HoldRule) -> Pressed:
    """Hold a press still and read on until ``rule`` (over all its readings) is met."""
    if not pressed.touched:
        return pressed
    pressed.press.extend(rule)
    return _read_pressed(finger, pressed, still=pressed.press.phase == "hold")


def _across(edge: np.ndarray, outward: np.ndarray) -> np.ndarray:
    """Unit horizontal direction across ``edge``, on the same side as ``outward``."""
    across = np.array([edge[1], -edge[0]])
    norm = float(np.linalg.norm(across))
    if not norm > 0.3:  # an edge that is not roughly horizontal: keep the old direction
        return outward
    across /= norm
    return across if across @ outward >= 0 else -across


def find_edge(
    finger: Finger,
    start: np.ndarray,
    outward: np.ndarray,
    nominal: NominalLayout,
    tare: bool = True,
) -> tuple[Pressed, np.ndarray, int]:
    """Find the probed edge by touch and measure there.

    Presses along a line across the edge, starting at ``start``, until a press sits about
    1.2 mm past the edge (see the module docstring for the rule). That press then holds on
    until the pipeline's gate measures it (its ``HoldRule``) and is returned, the finger
    still pressed, with the measurement if the gate accepted it.

    Args:
        finger: the finger.
        start: (2,) first press, world x-y, m.
        outward: (2,) unit direction across the edge, away from the grip's interior.
        nominal: the nominal layout.
        tare: tare before each press (``press``).

    Returns:
        (the measurement press, the outward direction it was found along, presses taken).
    """
    xy = np.asarray(start, dtype=float)
    outward = np.asarray(outward, dtype=float)
    misses, anchor = 0, xy
    for k in range(1, MAX_PRESSES + 1):
        pressed = press(finger, xy, nominal, tare)
        if pressed.touched and pressed.touch.valid:
            misses = 0
            if predicted_edge_std(finger.pipeline.sensor, pressed.press.held) < TRUSTED_EDGE_STD:
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
    return read_on(finger, pressed, finger.pipeline.gate.config.hold_rule), outward, k


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
    home = np.r_[start, _travel_height(scene, nominal) + scene.geometry.cylinder_length]
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


def log_header(scene: ProbeScene, condition: str, sensor: str = "realistic") -> LogHeader:
    """The header of a condition's trial logs: the scene's control period and fingertip, the
    sensing the operator configured (the condition's skin and sensor,
    :func:`~agents.paper_scene.configured`; never the world's factors), ``GATE``, a planar
    estimator without a prior, and no probed-edge distance. A trial's pipeline is built from
    it, and so is its replay's."""
    skin, sensor_config = configured(condition, sensor)
    return LogHeader(
        period=scene.time_step * scene.substeps,
        skin_stiffness=skin.normal_stiffness,
        fingertip=dataclasses.asdict(scene.geometry),
        sensor=dataclasses.asdict(sensor_config),
        gate=dataclasses.asdict(GATE),
        estimator={"mode": "planar", "loss": "soft_l1"},
        source=f"agents.reproduce_paper, condition {condition}",
    )


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
