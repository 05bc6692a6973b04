"""The paper's finger (``agents.reproduce_paper``, ``agents.reproduce_drawer``): a soft
fingertip on a 6-axis F/T sensor, held pointing down like the paper's coordinate-measuring
machine, that streams its readings, presses and finds the probed edge by touch.

It reads the scene as a robot reads its arm and sensor: the fingertip's pose and the F/T
readings, never the truth (``tests/test_ground_truth.py`` fails any read of the truth made
under this module). Of the layout it knows only the nominal one
(:class:`~agents.paper_scene.NominalLayout`), and reads of it only the grip's top height.

* **Stream** (:class:`Finger`): every control step, travel included, reads the sensor once and
  feeds the reading with the fingertip's pose, as a robot streams them, to the perception
  pipeline (``tactile_gym.perception.MeasurementPipeline``, built from :func:`log_header`:
  the configured sensing, the gate ``GATE``, an estimator without a prior). The pipeline
  tares, compensates and gates; its accepted measurements are the trial's, and a trial's
  samples are its log (:meth:`Finger.log`), so that replaying the logs gives the same table
  (:func:`~agents.reproduce_paper.from_logs`).
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
  the tare, the less the sensor drifts before the press is read. ``tare=False`` (the
  command's ``--no-tare``) skips it: the readings, less the fingertip's configured weight
  (pointing down throughout), keep the sensor's offset and drift.
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
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.perception import GateConfig, Measurement, MeasurementPipeline, Perceived, Sample
from tactile_gym.perception.log import LogHeader, ProbeLog
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
from tactile_gym.spatial import (
    matrix_to_quaternion,
    matrix_to_rotvec,
    quaternion_to_matrix,
    rotvec_to_matrix,
    z_to,
)

from .paper_scene import NominalLayout, configured

__all__ = [
    "DOWN",
    "GATE",
    "PRESS",
    "SEARCH_HOLD",
    "Finger",
    "Pressed",
    "find_edge",
    "lift",
    "log_header",
    "press",
    "read_on",
    "tare_here",
    "travel_height",
]

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


def travel_height(scene: ProbeScene, nominal: NominalLayout) -> float:
    """Sphere-centre height, m, that clears the grip's nominal top by TRAVEL_CLEARANCE."""
    return nominal.thickness + TRAVEL_CLEARANCE + scene.geometry.outer_radius


def lift(finger: Finger, nominal: NominalLayout) -> None:
    """Raise the finger straight up to the travel height."""
    _move(finger, np.r_[finger.centre[:2], travel_height(finger.scene, nominal)])


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
    centre = np.r_[np.asarray(xy, dtype=float), travel_height(finger.scene, nominal)]
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
