"""The measurement pipeline: a stream of F/T readings and fingertip poses in, the axis out.

Each sample (:class:`Sample`: the time, the wrench, the fingertip's pose and the robot's
events) goes through, in order:

1. the stream checks: a sample that repeats or reverses the time, that follows a gap of more
   than ``max_gap`` periods (a dropped sample), whose pose jumped further than the fingertip
   can move, or whose numbers are not finite spoils the touch in progress (its press is
   refused with the fault's name, ``STREAM_FAULTS``); a sample that is not finite, or not
   later than the last, is then dropped;
2. the tare (``tactile_gym.sensing.Tare``, ``docs/design.md`` 5.1): a raw reading is
   compensated by the last tare and the change of the fingertip's weight with its rotation;
   a ``tare`` event takes a new tare on the sample's reading, refused while the reading of
   an earlier tare says touching (|f| >= ``TOUCH_FORCE``; the first tare has nothing to go
   by); a reading already tared by the robot passes as is;
3. the touch sensing (``TouchSensor.sense``: Bicchi's contact point, the edge, in the world
   frame by the pose);
4. the measurement gate (``MeasurementGate``, ``docs/design.md`` 7.2), then its same-edge
   test against the current estimate (the expected distance of the probed edge from the axis,
   ``edge_distance``, handed in);
5. the online estimator (handed in, e.g. ``JointAxisEstimator`` with its prior), refitted
   when a measurement is accepted;
6. the count of distinct edge directions (the env's progress observation).

It never sees a simulator: the env (``tactile_gym.envs``) and the log replay
(``tactile_gym.replay``) feed it alike, and what is known before touching (the prior inside
the estimator, the edge distance) is handed to it. NumPy and SciPy only.

Conventions (``docs/design.md`` 2): SI units; wrenches in the sensor frame (force on the
fingertip, moment about the sensor origin); poses map sensor to world; time in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation import AxisEstimate
from tactile_gym.perception.gate import GateConfig, Measurement, MeasurementGate
from tactile_gym.sensing import (
    TARE_SAMPLES,
    TOUCH_FORCE,
    FingertipGeometry,
    SensorConfig,
    Tare,
    Touch,
    TouchSensor,
)
from tactile_gym.vec3 import norm

__all__ = [
    "DISTINCT_ANGLE",
    "STREAM_FAULTS",
    "MeasurementPipeline",
    "Perceived",
    "PressRecord",
    "Sample",
    "StreamLimits",
    "TareRecord",
]

#: Edge directions closer than this count as one link angle in the progress, rad.
DISTINCT_ANGLE = float(np.deg2rad(3.0))
#: The faults of a stream that refuse the press they interrupt (the pipeline's step 1).
STREAM_FAULTS = ("non_finite", "time_order", "repeated_time", "dropped_sample", "pose_jump")
#: A tare's offset may differ from the last tare's by this many standard deviations of what
#: the drift and the two tares' noise allow before it is flagged (``TareRecord``).
TARE_JUMP_SIGMAS = 5.0


@dataclass(frozen=True, eq=False)
class Sample:
    """One reading of the F/T sensor with the fingertip's pose: one row of a robot's log.

    Attributes:
        time: s, increasing.
        wrench: (6,) force on the fingertip (N) and moment about the sensor origin (N m),
            sensor frame: raw, or already tared and gravity-compensated when ``tared``.
        position: (3,) the sensor origin, world frame, m.
        rotation: (3, 3) the fingertip's rotation, sensor to world.
        tared: the robot tared and gravity-compensated ``wrench`` itself.
        tare: take a tare on this reading (held still in free air), unless it says touching.
        lift: the robot lifted off: the touch in progress, if any, ends here.
        commanded_rotation: (3, 3) the rotation the robot commanded, where it logs one apart
            from the measured ``rotation``; the gravity compensation takes it (the env passes
            its controller's target). None: ``rotation``.
    """

    time: float
    wrench: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    tared: bool = False
    tare: bool = False
    lift: bool = False
    commanded_rotation: np.ndarray | None = None


@dataclass(frozen=True)
class StreamLimits:
    """What a stream of samples may do before a sample counts as a fault (step 1).

    Attributes:
        period: the nominal time between samples, s (the env's control period).
        max_gap: a gap longer than this many periods is a dropped sample.
        max_speed: the fingertip's fastest plausible motion, m/s (a larger jump is a fault).
        max_angular_speed: its fastest plausible turn, rad/s.
    """

    period: float = 0.05
    max_gap: float = 1.5
    max_speed: float = 0.25
    max_angular_speed: float = 3.0


@dataclass(frozen=True, eq=False)
class Perceived:
    """What one sample gave.

    Attributes:
        wrench: (6,) the reading, tared and gravity-compensated, sensor frame (zeros for a
            dropped sample).
        touch: the contact estimate of this reading alone.
        accepted: the measurements it completed that entered the estimate (0 or 1).
        tared: a tare was taken on it.
        tare_refused: a tare was asked for and refused (the reading says touching).
        fault: the stream fault it showed (``STREAM_FAULTS``), or "".
    """

    wrench: np.ndarray
    touch: Touch
    accepted: tuple[Measurement, ...]
    tared: bool
    tare_refused: bool
    fault: str


@dataclass(frozen=True)
class PressRecord:
    """A press the pipeline judged: accepted, or refused by a rule of the gate or a fault.

    Attributes:
        time: s, of the sample that completed or spoiled it.
        accepted: whether it entered the estimate.
        rule: the rule that refused it (``GATE_RULES``, ``STREAM_FAULTS``), "" if accepted.
        reason: why, in words.
    """

    time: float
    accepted: bool
    rule: str
    reason: str


@dataclass(frozen=True)
class TareRecord:
    """A tare taken, and how far its offset moved from the last tare's.

    Attributes:
        time: s.
        jump: |change of the force offset| since the last tare, N: the tare readings less the
            fingertip's weight at their rotations, which only the sensor's drift should move
            (0 for the first tare).
        allowed: what the drift over the time between the tares and the two tares' noise allow
            at ``TARE_JUMP_SIGMAS``, N.
        flagged: ``jump > allowed``: most likely a tare taken while something touched the skin
            (a robot cannot see it either: ``docs/design.md`` 5.1).
    """

    time: float
    jump: float
    allowed: float
    flagged: bool


class MeasurementPipeline:
    """Turns a stream of samples into measurements and an axis estimate (module docstring).

    Args:
        geometry: the fingertip.
        sensor: the F/T sensor: its noise (the sensing's predicted errors) and the fingertip's
            mass and centre of mass (the gravity compensation).
        skin_stiffness: Winkler modulus of the skin, N/m^3 (the indentation correction).
        gate: the gate's thresholds.
        estimator: the online estimator, with its prior (``add``, ``estimate``, ``reset``,
            as ``tactile_gym.estimation.JointAxisEstimator``).
        edge_distance: expected distance of the probed edge from the axis (mean, std), m;
            None: the same-edge test only keeps contacts clear of the hinge.
        limits: the stream's limits.
    """

    def __init__(
        self,
        geometry: FingertipGeometry,
        sensor: SensorConfig,
        skin_stiffness: float,
        gate: GateConfig,
        estimator,
        edge_distance: tuple[float, float] | None = None,
        limits: StreamLimits = StreamLimits(),  # noqa: B008 - frozen dataclass
    ) -> None:
        self.sensor = TouchSensor(geometry, sensor, skin_stiffness)
        self.gate = MeasurementGate(gate, self.sensor)
        self.gate.edge_distance = edge_distance
        self.estimator = estimator
        self.limits = limits
        self._tare = Tare.of(sensor)
        #: Called with every sample the pipeline takes, reset's included (a log's recorder).
        self.recorder = None

    def reset(self, sample: Sample) -> Perceived:
        """Start an episode (a log) from its first sample: tared if it asks, sensed, not
        offered to the gate."""
        self.gate.reset()
        self.estimator.reset()
        self._tare = Tare.of(self.sensor.sensor)
        self.measurements: list[Measurement] = []
        #: Every press judged this episode, in order.
        self.presses: list[PressRecord] = []
        #: Every tare taken this episode, in order.
        self.tares: list[TareRecord] = []
        self._directions: list[np.ndarray] = []  # one representative per distinct direction
        self.span = 0.0
        self.estimate: AxisEstimate = self._estimate()
        #: Time of the last tare taken, s (the first sample's when there was none).
        self.tare_time = float(sample.time)
        self._last: Sample | None = None
        if self.recorder is not None:
            self.recorder(sample)
        wrench, tared, refused = self._compensate(sample)
        self._last = sample
        self.wrench = wrench
        self.touch = self.sensor.sense(wrench, sample.rotation, sample.position)
        return Perceived(wrench, self.touch, (), tared, refused, "")

    def step(self, sample: Sample) -> Perceived:
        """Take one sample; return what it gave (module docstring)."""
        if self.recorder is not None:
            self.recorder(sample)
        fault = self._check(sample)
        if fault in ("non_finite", "time_order", "repeated_time"):
            return Perceived(np.zeros(6), self.touch, (), False, False, fault)
        self._last = sample
        wrench, tared, refused = self._compensate(sample)
        self.wrench = wrench
        if sample.lift:
            self.gate.end_touch()
        rotation, position = sample.rotation, sample.position
        self.touch = self.sensor.sense(wrench, rotation, position)
        refusals = self.gate.refusals
        offered = self.gate.offer(wrench, rotation, position, self.touch)
        if self.gate.refusals > refusals:
            self._record(sample.time, False)
        accepted = []
        for m in offered:
            entered = self._admit(m)
            self._record(sample.time, any(e is m for e in entered))
            for e in entered:
                self._count_direction(e.edge)
                accepted.append(e)
        self.measurements.extend(accepted)
        if accepted:
            self.estimate = self._estimate()
        return Perceived(wrench, self.touch, tuple(accepted), tared, refused, fault)

    @property
    def directions(self) -> int:
        """Distinct edge directions measured (closer than ``DISTINCT_ANGLE`` count as one)."""
        return len(self._directions)

    @property
    def last(self) -> Measurement | None:
        """The last accepted measurement, or None."""
        return self.measurements[-1] if self.measurements else None

    def tare_age(self, time: float) -> float:
        """Time since the last tare at ``time``, s."""
        return float(time) - self.tare_time

    # ------------------------------------------------------------------ the steps
    def _admit(self, m: Measurement) -> tuple[Measurement, ...]:
        """Steps 4-5 for a measurement the gate completed: the same-edge test against the
        current estimate, then the estimator; the measurements that entered it, in order
        (here ``m`` or none; a pipeline that holds presses back may release earlier ones
        with it)."""
        if not self.gate.same_edge(m, self.estimate):
            return ()
        self.estimator.add(m.point, m.edge, m.point_std, m.edge_std, edge_cov=m.edge_cov)
        return (m,)

    def _estimate(self) -> AxisEstimate:
        """The estimator's current axis estimate."""
        return self.estimator.estimate()

    def _check(self, sample: Sample) -> str:
        """The stream fault a sample shows (step 1), or ""; a fault spoils the touch."""
        last, limits = self._last, self.limits
        fault, why = "", ""
        # One pass of math.isfinite over Python floats: NumPy's per-call cost on arrays this
        # small is most of a check made every sample.
        position = np.asarray(sample.position, dtype=float)
        values = [
            sample.time,
            *np.ravel(sample.wrench).tolist(),
            *position.ravel().tolist(),
            *np.ravel(sample.rotation).tolist(),
        ]
        if not all(map(math.isfinite, values)):
            fault, why = "non_finite", "a reading or a pose that is not finite"
        elif last is not None:
            gap = sample.time - last.time
            if gap < 0.0:
                fault, why = "time_order", f"time {sample.time!r} s after {last.time!r} s"
            elif gap == 0.0:
                fault, why = "repeated_time", f"a second sample at {sample.time!r} s"
            elif gap > limits.max_gap * limits.period:
                fault, why = "dropped_sample", f"{gap:.3g} s since the last sample"
            else:
                jump = norm(position - last.position)
                turn = _angle_between(sample.rotation, last.rotation)
                if jump > limits.max_speed * gap or turn > limits.max_angular_speed * gap:
                    fault = "pose_jump"
                    why = f"the pose moved {jump * 1e3:.2f} mm and {math.degrees(turn):.2f} deg"
                    why += f" in {gap:.3g} s"
        if fault:
            refusals = self.gate.refusals
            self.gate.interrupt(fault, why)
            if self.gate.refusals > refusals:
                self._record(sample.time, False)
        return fault

    def _compensate(self, sample: Sample) -> tuple[np.ndarray, bool, bool]:
        """The tared, gravity-compensated reading (step 2), after a tare if one is asked for
        and the reading does not say touching; and whether it was taken, or refused."""
        reading = np.asarray(sample.wrench, dtype=float)
        if sample.tared:
            if sample.tare:
                self.tare_time = float(sample.time)
            return reading, sample.tare, False
        rotation = (
            sample.rotation if sample.commanded_rotation is None else sample.commanded_rotation
        )
        wrench = self._tare.compensate(reading, rotation)
        if not sample.tare:
            return wrench, False, False
        if self._tare.taken and norm(wrench[:3]) >= TOUCH_FORCE:
            # Only a tared reading can say touching: the first tare has nothing to go by.
            return wrench, False, True
        before = self._tare.reading - self._tare.load if self._tare.taken else None
        self._tare.take(reading, rotation)
        self._record_tare(float(sample.time), before)
        self.tare_time = float(sample.time)
        return self._tare.compensate(reading, rotation), True, False

    def _record_tare(self, time: float, before: np.ndarray | None) -> None:
        """Record a tare and how far its force offset moved from the last one's."""
        if before is None:
            self.tares.append(TareRecord(time, 0.0, math.inf, False))
            return
        sensor = self.sensor.sensor
        jump = norm((self._tare.reading - self._tare.load)[:3] - before[:3])
        drift = sensor.force_drift**2 * (time - self.tare_time)
        noise = 2.0 * sensor.force_noise_std**2 / TARE_SAMPLES
        allowed = TARE_JUMP_SIGMAS * math.sqrt(3.0 * (drift + noise))
        self.tares.append(TareRecord(time, jump, allowed, jump > allowed))

    def _record(self, time: float, accepted: bool) -> None:
        gate = self.gate
        rule, reason = ("", "") if accepted else (gate.last_rule, gate.last_rejection)
        self.presses.append(PressRecord(float(time), accepted, rule, reason))

    def _count_direction(self, edge: np.ndarray) -> None:
        """Update the span and the distinct directions of the measured edges with one more."""
        if self._directions:
            cos = np.array(self._directions) @ edge
            self.span = max(self.span, float(np.arccos(np.clip(cos.min(), -1.0, 1.0))))
            if cos.max() >= np.cos(DISTINCT_ANGLE):
                return
        self._directions.append(edge)


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The angle of the rotation from ``b`` to ``a``, rad (0 for equal matrices)."""
    if (a == b).all():
        return 0.0
    cos = 0.5 * (float(np.trace(a @ b.T)) - 1.0)
    return math.acos(min(max(cos, -1.0), 1.0))
