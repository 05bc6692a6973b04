"""The observation codec: every entry of an observation by name (``docs/design.md`` 7.5).

The observation is a ``Dict`` whose keys are *groups* of named entries: ``ContactObs`` is the
``"contact"`` key, with ``touching``, ``point``, ``normal``, ``edge``, ``edge_std`` and
``tilt``, and so on. The env builds each group from named values and encodes them; the skills
and the scripted agent read observations back through the same groups (``ContactObs.read(obs)
.tilt``). No code outside this module indexes an observation by position.

Encoding: the groups' arrays are concatenated in the order of their keys (Gymnasium sorts the
keys of a ``Dict`` space, so the flat vector of ``observation_mode="flat"`` is
``gym.spaces.flatten`` of the dict observation), NaN is set to 0 (an undefined entry, whose
flag or std says so), every entry is clipped to its bounds, and the result is cast to float32.
A dict observation holds views of that vector. World frame, SI units (``docs/design.md`` 2).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from tactile_gym.estimation import FLAGS, JOINT_TYPES, OUTCOMES
from tactile_gym.validation import check_choice
from tactile_gym.vec3 import norm

__all__ = [
    "JOINT_OBSERVATION",
    "NO_EDGE",
    "OBSERVATION",
    "OBSERVATION_LAYOUT",
    "ContactObs",
    "EstimateObs",
    "FingertipPoseObs",
    "JointPipelineParts",
    "JointTypeObs",
    "LastMeasurementObs",
    "ObservationCodec",
    "ObservationGroup",
    "PipelineParts",
    "PrimitiveObs",
    "ProgressObs",
    "WrenchObs",
]

#: Bounds of the observation entries (observations are clipped to them).
FORCE_BOUND = 60.0  # N
MOMENT_BOUND = 3.0  # N m
POSITION_BOUND = 1.0  # m
STD_BOUND = 1.0  # m
MAX_MEASUREMENTS = 10_000.0
#: The "none" value of an edge error: no edge measured, rad.
NO_EDGE = np.pi / 2


def entry(size: int, low: float, high: float) -> Any:
    """A field of an observation group: ``size`` values, each clipped to [low, high]."""
    return dataclasses.field(metadata={"size": size, "low": low, "high": high})


class ObservationGroup:
    """One key of the ``Dict`` observation, as named entries (a frozen dataclass).

    Entries of size 1 are floats; the others are float64 arrays.
    """

    key: ClassVar[str]

    @classmethod
    @functools.cache
    def entries(cls) -> tuple[tuple[str, int], ...]:
        """The entries' names and sizes, in order (read once per group: the env encodes and
        the skills decode every step)."""
        return tuple((f.name, f.metadata["size"]) for f in dataclasses.fields(cls))

    @classmethod
    def size(cls) -> int:
        return sum(n for _, n in cls.entries())

    @classmethod
    def space(cls) -> spaces.Box:
        """The group's ``Box``: every entry's bounds, float32."""
        fields = dataclasses.fields(cls)
        low = np.concatenate([np.full(f.metadata["size"], f.metadata["low"]) for f in fields])
        high = np.concatenate([np.full(f.metadata["size"], f.metadata["high"]) for f in fields])
        return spaces.Box(low=low.astype(np.float32), high=high.astype(np.float32))

    def to_array(self) -> np.ndarray:
        """The entries in order, float64 (before clipping)."""
        # One array of Python floats: an array per entry and their concatenation cost more
        # than the rest of the observation (the env encodes one every step).
        values: list = []
        for name, n in self.entries():
            value = getattr(self, name)
            if n == 1:
                values.append(value)
            else:
                values.extend(value.tolist() if isinstance(value, np.ndarray) else value)
        return np.array(values, dtype=float)

    @classmethod
    @functools.cache
    def _spans(cls) -> tuple[tuple[str, int, int], ...]:
        """The entries' names with their start and end in the group's array."""
        spans, start = [], 0
        for name, n in cls.entries():
            spans.append((name, start, start + n))
            start += n
        return tuple(spans)

    @classmethod
    def from_array(cls, values: np.ndarray) -> ObservationGroup:
        """The group of an observation's array for its key."""
        values = np.asarray(values, dtype=float)
        # Scalars from one list of Python floats: a float() per indexed entry costs more
        # (the skills read several groups every control step).
        floats = values.tolist()
        named = {
            name: floats[start] if end - start == 1 else values[start:end]
            for name, start, end in cls._spans()
        }
        return cls(**named)

    @classmethod
    def read(cls, obs: Mapping[str, np.ndarray]) -> ObservationGroup:
        """The group of a dict observation."""
        return cls.from_array(obs[cls.key])


@dataclass(frozen=True, eq=False)
class WrenchObs(ObservationGroup):
    """The F/T reading (sensor frame): force on the fingertip, N; moment about the sensor
    origin, N m."""

    key: ClassVar[str] = "wrench"
    force: np.ndarray = entry(3, -FORCE_BOUND, FORCE_BOUND)
    moment: np.ndarray = entry(3, -MOMENT_BOUND, MOMENT_BOUND)


@dataclass(frozen=True, eq=False)
class FingertipPoseObs(ObservationGroup):
    """The sensor origin (world, m) and orientation (quaternion x, y, z, w, sensor to world)."""

    key: ClassVar[str] = "fingertip_pose"
    position: np.ndarray = entry(3, -POSITION_BOUND, POSITION_BOUND)
    quaternion: np.ndarray = entry(4, -1.0, 1.0)


@dataclass(frozen=True, eq=False)
class ContactObs(ObservationGroup):
    """This reading's contact estimate (world frame; zeros with ``edge_std`` at ``NO_EDGE``
    where undefined).

    Attributes:
        touching: 1 if the reading gives a contact.
        point: contact point, indentation-corrected, m.
        normal: skin normal at the contact.
        edge: edge direction, oriented physically (0 when not observable).
        edge_std: predicted RMS edge error, rad.
        tilt: angle of the force from the skin normal, rad.
    """

    key: ClassVar[str] = "contact"
    touching: float = entry(1, 0.0, 1.0)
    point: np.ndarray = entry(3, -POSITION_BOUND, POSITION_BOUND)
    normal: np.ndarray = entry(3, -1.0, 1.0)
    edge: np.ndarray = entry(3, -1.0, 1.0)
    edge_std: float = entry(1, 0.0, NO_EDGE)
    tilt: float = entry(1, 0.0, np.pi / 2)

    @classmethod
    def from_touch(cls, touch: Any) -> ContactObs:
        """The entries of a ``Touch`` (``tactile_gym.sensing.probing.Touch``)."""
        zeros = np.zeros(3)
        if not touch.valid:
            return cls(0.0, zeros, zeros, zeros, NO_EDGE, 0.0)
        if not touch.observable:
            return cls(1.0, touch.point, touch.normal, zeros, NO_EDGE, touch.tilt)
        return cls(1.0, touch.point, touch.normal, touch.edge, touch.edge_std, touch.tilt)

    @property
    def has_edge(self) -> bool:
        """Whether ``edge`` is defined (a unit vector rather than zeros)."""
        return norm(np.asarray(self.edge, dtype=float)) > 0.5


@dataclass(frozen=True, eq=False)
class EstimateObs(ObservationGroup):
    """The current axis estimate (world frame): the axis point closest to the world origin
    (m), its direction, and their 1-sigma uncertainties (m, rad)."""

    key: ClassVar[str] = "estimate"
    point: np.ndarray = entry(3, -POSITION_BOUND, POSITION_BOUND)
    direction: np.ndarray = entry(3, -1.0, 1.0)
    position_std: float = entry(1, 0.0, STD_BOUND)
    angle_std: float = entry(1, 0.0, np.pi)

    @classmethod
    def from_estimate(cls, estimate: Any) -> EstimateObs:
        """The entries of an ``AxisEstimate``."""
        return cls(estimate.point, estimate.direction, estimate.position_std, estimate.angle_std)


@dataclass(frozen=True, eq=False)
class LastMeasurementObs(ObservationGroup):
    """The last accepted measurement (world frame): its contact point (m), its edge
    direction (oriented physically) and its RMS edge error (rad; ``NO_EDGE`` before the
    first)."""

    key: ClassVar[str] = "last_measurement"
    point: np.ndarray = entry(3, -POSITION_BOUND, POSITION_BOUND)
    edge: np.ndarray = entry(3, -1.0, 1.0)
    edge_std: float = entry(1, 0.0, NO_EDGE)

    @classmethod
    def from_measurement(cls, measurement: Any | None) -> LastMeasurementObs:
        """The entries of a ``Measurement``, or of none yet."""
        if measurement is None:
            return cls(np.zeros(3), np.zeros(3), NO_EDGE)
        return cls(measurement.point, measurement.edge, measurement.edge_std)


@dataclass(frozen=True, eq=False)
class ProgressObs(ObservationGroup):
    """How far probing has come.

    Attributes:
        span: largest angle between two measured edge directions, rad.
        directions: distinct edge directions measured.
        last_edge_std: RMS edge error of the last measurement, rad (``NO_EDGE``: none yet).
        measurements: measurements accepted.
        time_left: fraction of the episode's control steps left (1 to 0).
    """

    key: ClassVar[str] = "progress"
    span: float = entry(1, 0.0, np.pi)
    directions: float = entry(1, 0.0, MAX_MEASUREMENTS)
    last_edge_std: float = entry(1, 0.0, NO_EDGE)
    measurements: float = entry(1, 0.0, MAX_MEASUREMENTS)
    time_left: float = entry(1, 0.0, 1.0)


@dataclass(frozen=True, eq=False)
class PrimitiveObs(ObservationGroup):
    """The last probing primitive (primitive ids only).

    Attributes:
        kind: -1 probe, +1 turn, 0 none yet.
        measured: 1 if it produced a measurement.
        duration: fraction of the episode's control steps it took.
    """

    key: ClassVar[str] = "primitive"
    kind: float = entry(1, -1.0, 1.0)
    measured: float = entry(1, 0.0, 1.0)
    duration: float = entry(1, 0.0, 1.0)


@dataclass(frozen=True, eq=False)
class JointTypeObs(ObservationGroup):
    """The joint-type estimate (the joint ids, ``docs/design.md`` 7.12).

    Attributes:
        probabilities: posterior probabilities of rigid, revolute, prismatic and none
            (``tactile_gym.estimation.OUTCOMES``).
        flags: 1 for each of the estimate's flags that holds, in the order of
            ``tactile_gym.estimation.FLAGS``.
        configurations: link configurations pressed so far.
        lines: edge lines pressed so far.
    """

    key: ClassVar[str] = "joint"
    probabilities: np.ndarray = entry(len(OUTCOMES), 0.0, 1.0)
    flags: np.ndarray = entry(len(FLAGS), 0.0, 1.0)
    configurations: float = entry(1, 0.0, MAX_MEASUREMENTS)
    lines: float = entry(1, 0.0, MAX_MEASUREMENTS)

    @classmethod
    def from_pipeline(cls, pipeline: Any) -> JointTypeObs:
        """The entries of a ``tactile_gym.perception.JointPipeline``."""
        estimate = pipeline.joint_estimate
        return cls(
            estimate.probabilities,
            np.array([float(flag in estimate.flags) for flag in FLAGS]),
            float(pipeline.configurations),
            float(len(pipeline.lines)),
        )


def most_likely_model(pipeline: Any) -> EstimateObs:
    """The ``estimate`` entries of the joint ids: the most probable joint type's parameters
    (of rigid, revolute and prismatic; ties to the first). Revolute: the axis
    (``pipeline.estimate``: the revolute model's, or the prior's before a fit); prismatic:
    the direction of travel and its RMS angle error, the point and position std 0 (before a
    fit the direction is 0 and its std ``NO_EDGE``); rigid: zeros."""
    estimate = pipeline.joint_estimate
    best = JOINT_TYPES[int(np.argmax(estimate.probabilities[: len(JOINT_TYPES)]))]
    zeros = np.zeros(3)
    if best == "revolute":
        return EstimateObs.from_estimate(pipeline.estimate)
    if best == "rigid":
        return EstimateObs(zeros, zeros, 0.0, 0.0)
    fit = estimate.models.get("prismatic")
    if fit is None:
        return EstimateObs(zeros, zeros, 0.0, NO_EDGE)
    std = float(np.sqrt(max(float(np.trace(fit.covariance)), 0.0)))
    return EstimateObs(zeros, fit.parameters, 0.0, min(std, np.pi))


class ObservationCodec:
    """Encodes observation groups into an env's observation, and reads observations back.

    Args:
        groups: the group classes, one per key of the ``Dict`` observation.
    """

    def __init__(self, groups: Iterable[type[ObservationGroup]]) -> None:
        self.groups = {g.key: g for g in sorted(groups, key=lambda g: g.key)}
        self.dict_space = spaces.Dict({key: g.space() for key, g in self.groups.items()})
        self.flat_space = spaces.flatten_space(self.dict_space)
        self._low = self.flat_space.low.astype(float)
        self._high = self.flat_space.high.astype(float)
        ends = np.cumsum([g.size() for g in self.groups.values()])
        self._slices = {
            key: slice(int(end - g.size()), int(end))
            for (key, g), end in zip(self.groups.items(), ends)
        }

    def with_group(self, group: type[ObservationGroup]) -> ObservationCodec:
        """This codec with one more group."""
        return ObservationCodec((*self.groups.values(), group))

    @property
    def layout(self) -> tuple[tuple[str, int], ...]:
        """The keys of the flat observation, in order, with their sizes."""
        return tuple((key, g.size()) for key, g in self.groups.items())

    def space(self, mode: str) -> spaces.Space:
        """The observation space of ``observation_mode`` ``"dict"`` or ``"flat"``."""
        check_choice("observation_mode", mode, ("dict", "flat"))
        return self.flat_space if mode == "flat" else self.dict_space

    def encode(self, parts: Mapping[str, np.ndarray], mode: str):
        """The observation (module docstring) of the arrays of every key (``to_array``)."""
        flat = np.concatenate([parts[key] for key in self.groups], dtype=float)
        # NaN to 0; clipping then takes infinities to the bounds (``np.nan_to_num`` costs more
        # than the rest of the encoding).
        flat[np.isnan(flat)] = 0.0
        flat = np.clip(flat, self._low, self._high, out=flat).astype(np.float32)
        if mode == "flat":
            return flat
        return {key: flat[s] for key, s in self._slices.items()}

    def as_dict(self, obs) -> dict[str, np.ndarray]:
        """A dict observation of either mode's observation (the flat vector's views)."""
        if isinstance(obs, Mapping):
            return dict(obs)
        return {key: obs[s] for key, s in self._slices.items()}


class PipelineParts:
    """The arrays of every key of the ``HingeProbe`` observation (``to_array``, to encode):
    the state of a measurement pipeline (``tactile_gym.perception.MeasurementPipeline``: the
    last reading and its touch, the estimate, the measurements) and the fingertip's pose
    (world, m; quaternion x y z w), with the fraction of the episode left.

    One per env: the arrays of what changes only with an accepted measurement (the estimate,
    the last measurement) are kept until the pipeline holds another estimate or measurement
    object (they are frozen, so the same object has the same entries).
    """

    def __init__(self) -> None:
        self._kept: dict[str, tuple[tuple, np.ndarray]] = {}

    def kept(self, key: str, group: Callable[..., ObservationGroup], *sources: Any) -> np.ndarray:
        """The array of ``key``: ``group(*sources).to_array()``, computed again only when one
        of ``sources`` (the objects it is made of) is another object than last time."""
        kept = self._kept.get(key)
        if kept is None or any(a is not b for a, b in zip(kept[0], sources, strict=True)):
            kept = (sources, group(*sources).to_array())
            self._kept[key] = kept
        return kept[1]

    def __call__(self, pipeline: Any, position, quaternion, time_left: float) -> dict:
        last = pipeline.last
        estimate = pipeline.estimate
        groups = (
            ContactObs.from_touch(pipeline.touch),
            FingertipPoseObs(position, quaternion),
            ProgressObs(
                span=pipeline.span,
                directions=pipeline.directions,
                last_edge_std=NO_EDGE if last is None else last.edge_std,
                measurements=len(pipeline.measurements),
                time_left=time_left,
            ),
            WrenchObs(pipeline.wrench[:3], pipeline.wrench[3:]),
        )
        parts = {group.key: group.to_array() for group in groups}
        parts[EstimateObs.key] = self.kept(EstimateObs.key, EstimateObs.from_estimate, estimate)
        parts[LastMeasurementObs.key] = self.kept(
            LastMeasurementObs.key, LastMeasurementObs.from_measurement, last
        )
        return parts


class JointPipelineParts(PipelineParts):
    """The arrays of every key of the ``JointProbe`` observation: ``PipelineParts`` of a
    ``JointPipeline``, its ``estimate`` the most likely model's (``most_likely_model``), and
    the joint-type estimate (``JointTypeObs``)."""

    def __call__(self, pipeline: Any, position, quaternion, time_left: float) -> dict:
        parts = super().__call__(pipeline, position, quaternion, time_left)
        # The most likely model is read off the joint-type estimate and the axis estimate.
        parts[EstimateObs.key] = self.kept(
            "most_likely_model",
            lambda *_: most_likely_model(pipeline),
            pipeline.joint_estimate,
            pipeline.estimate,
        )
        parts[JointTypeObs.key] = JointTypeObs.from_pipeline(pipeline).to_array()
        return parts


#: The codec of the ``HingeProbe`` ids (the primitive ids add ``PrimitiveObs``).
OBSERVATION = ObservationCodec(
    (WrenchObs, FingertipPoseObs, ContactObs, EstimateObs, LastMeasurementObs, ProgressObs)
)
#: Keys of the flat observation in order, with their sizes (``OBSERVATION.layout``).
OBSERVATION_LAYOUT = OBSERVATION.layout
#: The codec of the ``JointProbe`` ids: the ``HingeProbe`` ids' and ``JointTypeObs``.
JOINT_OBSERVATION = OBSERVATION.with_group(JointTypeObs)
