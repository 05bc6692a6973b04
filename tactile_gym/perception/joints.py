"""The measurement pipeline for an unknown joint: presses labelled by edge line and link
configuration, handed to the joint-type estimator (``docs/design.md`` 7.12).

:class:`JointPipeline` is :class:`~tactile_gym.perception.pipeline.MeasurementPipeline` (the
stream checks, the tare, the touch sensing and the gate, unchanged) with a
:class:`~tactile_gym.estimation.JointTypeEstimator` in place of the axis estimator. The joint
estimator needs two labels per press that nothing in a stream states
(``docs/design.md`` 6.9); the pipeline derives both from the readings and the fingertip's
poses alone, so that a robot's log is labelled as the env's stream is:

* **configuration** (``LabelConfig.push_travel``): presses share a configuration unless the
  link may have moved between them. Only a push moves a link: a touch whose contact patch
  travelled tangentially (off the force's line of action, summed step by step as the gate
  sums the skin's preload: ``patch_displacement``) further than ``push_travel`` dragged the
  skin, and the sticking skin drags the link with it. A pure press moves along the force
  line, bar the tilt of an edge press (0.3 mm over a 5 N press at 14 deg). A press the gate
  refused because the force did not hold steady or the fingertip sank in (rules ``steady``
  and ``link_held``: the link gave way) and a fault of the stream during a touch (the motion
  is unknown) start a new configuration too. The configuration changes as soon as the touch
  shows it, so a press taken before the drag in the same touch keeps the old one.
* **line** (``LabelConfig.line_angle``): a box's top face has four edges whose physically
  oriented directions (``docs/design.md`` 7.3) lie 90 deg apart, so a press joins the known
  line whose last measured direction is nearest, within ``line_angle`` (45 deg: a link that
  turns less than that between two presses of an edge keeps its label); at a configuration
  where that line was already pressed it joins only if it lies on it (within
  ``line_tolerance`` plus ``line_sigmas`` predicted sigmas), else it starts a line of its own
  (another edge of the same direction, or a corner's false edge). A line pressed once adds
  no information to any model, so a mislabelled stray press costs nothing.

What becomes of the same-edge test: the HingeProbe pipeline keeps only presses whose edge
line lies at the probed edge's distance from the estimated axis, which presumes a hinge; with
the joint unknown every press the gate accepts enters, under its line's label, and each
model explains every line. The estimate the pipeline keeps as ``estimate`` is the revolute
model's axis (the prior's before a fit): what the render draws, and the axis a revolute
reading of the data gives; the joint-type estimate is ``joint_estimate``.

NumPy and SciPy only. World frame, metres, newtons, radians, seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation import AxisEstimate, JointTypeEstimate, JointTypeEstimator
from tactile_gym.perception.gate import GateConfig, Measurement, line_distance, patch_displacement
from tactile_gym.perception.pipeline import (
    MeasurementPipeline,
    Perceived,
    Sample,
    StreamLimits,
)
from tactile_gym.sensing import FingertipGeometry, SensorConfig
from tactile_gym.validation import check_number
from tactile_gym.vec3 import norm

__all__ = ["MOVING_RULES", "JointPipeline", "LabelConfig", "LineRecord"]

#: The gate's refusals that say the link gave way under a press: a new configuration.
MOVING_RULES = ("steady", "link_held")


@dataclass(frozen=True)
class LabelConfig:
    """How presses are labelled (module docstring).

    Attributes:
        push_travel: a touch whose contact patch travelled further than this off the force's
            line of action counts as a push, m.
        line_angle: a press joins the known line whose last direction is nearest within this
            angle, rad.
        line_tolerance: slack of the test that a press at a line's configuration lies on it,
            m, beyond ``line_sigmas`` predicted sigmas.
        line_sigmas: predicted sigmas of that test.
    """

    push_travel: float = 0.001
    line_angle: float = math.radians(45.0)
    line_tolerance: float = 0.002
    line_sigmas: float = 3.0

    def __post_init__(self) -> None:
        check_number("labels.push_travel", self.push_travel, 0.0, 0.05, low_open=True)
        check_number("labels.line_angle", self.line_angle, 0.0, math.pi / 2, low_open=True)
        check_number("labels.line_tolerance", self.line_tolerance, 0.0, 0.05)
        check_number("labels.line_sigmas", self.line_sigmas, 0.0, 10.0)


@dataclass
class LineRecord:
    """An edge line of the link as last pressed.

    Attributes:
        label: its label for the estimator.
        point: (3,) the last press's contact point on it, m.
        edge: (3,) the last press's edge direction, oriented physically.
        point_std, edge_std: that press's predicted errors, m and rad.
        configuration: the configuration it was last pressed at.
        presses: how often it was pressed.
    """

    label: int
    point: np.ndarray
    edge: np.ndarray
    point_std: float
    edge_std: float
    configuration: int
    presses: int = 1


class JointPipeline(MeasurementPipeline):
    """Samples in, measurements labelled by line and configuration, joint types out.

    Args:
        geometry, sensor, skin_stiffness, gate, limits: as for ``MeasurementPipeline``.
        estimator: the joint-type estimator, with its priors (its ``prior.axis``, if set,
            gives the revolute axis before any fit).
        labels: how presses are labelled.
    """

    def __init__(
        self,
        geometry: FingertipGeometry,
        sensor: SensorConfig,
        skin_stiffness: float,
        gate: GateConfig,
        estimator: JointTypeEstimator,
        labels: LabelConfig = LabelConfig(),  # noqa: B008 - frozen dataclass
        limits: StreamLimits = StreamLimits(),  # noqa: B008
    ) -> None:
        if not isinstance(estimator, JointTypeEstimator):
            raise TypeError(f"estimator must be a JointTypeEstimator, got {type(estimator)}")
        super().__init__(geometry, sensor, skin_stiffness, gate, estimator, None, limits)
        self.labels = labels

    def reset(self, sample: Sample) -> Perceived:
        #: The current link configuration's label.
        self.configuration = 0
        #: The edge lines pressed this episode, by label.
        self.lines: list[LineRecord] = []
        #: Each accepted measurement's (line, configuration) labels, in order.
        self.measurement_labels: list[tuple[int, int]] = []
        self._touching = False
        self._travel = 0.0  # the touch's tangential travel so far, m
        self._moved = False  # the touch started a configuration
        self._pose: tuple[np.ndarray, np.ndarray] | None = None
        perceived = super().reset(sample)
        self._pose = (np.asarray(sample.rotation, float), np.asarray(sample.position, float))
        return perceived

    def step(self, sample: Sample) -> Perceived:
        judged = len(self.presses)
        perceived = super().step(sample)
        refused = [p.rule for p in self.presses[judged:] if not p.accepted]
        self._track(sample, perceived, refused)
        return perceived

    # ------------------------------------------------------------------ configurations
    def _track(self, sample: Sample, perceived: Perceived, refused: list[str]) -> None:
        """Follow the touch in progress; start a configuration when it pushed the link."""
        if perceived.fault:
            if self._touching:
                self._push()
            if perceived.fault in ("non_finite", "time_order", "repeated_time"):
                return  # the sample was dropped: keep the last pose
        rotation = np.asarray(sample.rotation, float)
        position = np.asarray(sample.position, float)
        touch = perceived.touch
        if sample.lift or not touch.valid:
            self._touching, self._travel, self._moved = False, 0.0, False
        else:
            if self._touching and self._pose is not None:
                moved = patch_displacement(touch.point, self._pose, (rotation, position))
                line = touch.force / norm(touch.force)
                self._travel += norm(moved - (moved @ line) * line)
                if self._travel > self.labels.push_travel:
                    self._push()
            self._touching = True
        if any(rule in MOVING_RULES for rule in refused):
            self._push()
        self._pose = (rotation, position)

    def _push(self) -> None:
        """The touch in progress may have moved the link: later presses are at a new
        configuration (once per touch)."""
        if not self._moved:
            self._moved = True
            self.configuration += 1

    # ------------------------------------------------------------------ lines
    def _line_of(self, m: Measurement) -> LineRecord | None:
        """The known line a measurement continues (module docstring), or None."""
        cfg = self.labels
        best, best_angle = None, cfg.line_angle
        for line in self.lines:
            angle = math.acos(min(max(float(m.edge @ line.edge), -1.0), 1.0))
            if angle >= best_angle:
                continue
            if line.configuration == self.configuration:
                # Pressed at this configuration already: the press must lie on it.
                spread = math.hypot(m.point_std, line.point_std)
                offset = line_distance(m.point, line.edge, line.point, line.edge)
                turn = math.hypot(m.edge_std, line.edge_std)
                if offset > cfg.line_tolerance + cfg.line_sigmas * spread or (
                    angle > cfg.line_sigmas * turn
                ):
                    continue
            best, best_angle = line, angle
        return best

    def _admit(self, m: Measurement) -> bool:
        line = self._line_of(m)
        if line is None:
            line = LineRecord(
                len(self.lines), m.point, m.edge, m.point_std, m.edge_std, self.configuration, 0
            )
            self.lines.append(line)
        line.point, line.edge = m.point, m.edge
        line.point_std, line.edge_std = m.point_std, m.edge_std
        line.configuration = self.configuration
        line.presses += 1
        self.estimator.add(
            m.point,
            m.edge,
            m.point_std,
            m.edge_std,
            edge_cov=m.edge_cov,
            line=line.label,
            config=self.configuration,
        )
        self.measurement_labels.append((line.label, self.configuration))
        return True

    # ------------------------------------------------------------------ estimates
    def _estimate(self) -> AxisEstimate | None:
        #: The joint-type estimate (``JointTypeEstimate``).
        self.joint_estimate: JointTypeEstimate = self.estimator.estimate()
        revolute = self.joint_estimate.models.get("revolute")
        if revolute is not None and revolute.axis is not None:
            return revolute.axis
        prior = self.estimator.prior.axis
        return None if prior is None else prior.estimate(planar=self.estimator.mode == "planar")

    @property
    def configurations(self) -> int:
        """Configurations the link was pressed at so far (of those labelled)."""
        return len({config for _, config in self.measurement_labels})
