"""The measurement pipeline for an unknown joint: presses labelled by edge line and link
configuration, handed to the joint-type estimator (``docs/design.md`` 7.12).

:class:`JointPipeline` is :class:`~tactile_gym.perception.pipeline.MeasurementPipeline` (the
stream checks, the tare, the touch sensing and the gate, unchanged) with a
:class:`~tactile_gym.estimation.JointTypeEstimator` in place of the axis estimator. The joint
estimator needs two labels per press that nothing in a stream states
(``docs/design.md`` 6.10); the pipeline derives both from the readings and the fingertip's
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
  turns less than that between two presses of an edge keeps its label), if it passes the
  same-edge test below; else it starts a line of its own. A line pressed once adds no
  information to any model, so a stray press labelled on its own costs nothing.

**The same-edge test** becomes a test of the link's rigidity. The HingeProbe pipeline keeps
only presses whose edge line lies at the probed edge's distance from the estimated axis,
which presumes a hinge. Whatever the joint, it moves the link rigidly, so the angle between
two of its edge lines is the same at every configuration: a press joins a line only if its
angle to every other line pressed at its configuration is the angle the two lines made at a
configuration where both were pressed, within ``line_sigmas`` predicted sigmas plus
``line_angle_tolerance``; at a configuration where the line itself was pressed already it
must lie on it (within ``line_tolerance`` plus ``line_sigmas`` predicted sigmas); and while
the estimate finds a hinge unlikely (``turn_probability``), the line keeps its direction
from one configuration to the next, within the angle test's tolerance. A corner, whose false
edge lies between its two edges' directions, fails the first or the third; another edge of
the same direction fails the second.

**Held presses** (``LabelConfig.confirm_spacing``; off on the v0 joint ids). No single press
tells an edge from a corner of its face (a corner's false edge is one edge turned toward the
other), but its line does: a press enters the estimate only once it is consistent with its
line. At its configuration, a second press on the line at least ``confirm_spacing`` away
whose chord with it lies along both presses' edges (within ``confirm_angle`` plus the
chord's own error) confirms both, and both enter; a press on a line that took a press at
this configuration already enters if it lies on it (the same-edge test); at a new
configuration, a press on a line confirmed before enters if it keeps the line's direction
(a slide, or no motion) or, a hinge likely, its distance from the estimated axis and its
angle to it. Until then it is held back, its record refused with rule ``unconfirmed`` (made
an acceptance when it enters). ``docs/design.md`` 7.12 gives the measurements.

The estimate the pipeline keeps as ``estimate`` is the revolute model's axis (the prior's
before a fit): what the render draws, and the axis a revolute reading of the data gives; the
joint-type estimate is ``joint_estimate``.

NumPy and SciPy only. World frame, metres, newtons, radians, seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tactile_gym.estimation import AxisEstimate, JointTypeEstimate, JointTypeEstimator
from tactile_gym.perception.gate import GateConfig, Measurement, line_distance, patch_displacement
from tactile_gym.perception.pipeline import (
    MeasurementPipeline,
    Perceived,
    PressRecord,
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
        line_angle_tolerance: slack of the test of the angles between lines, rad, beyond
            ``line_sigmas`` predicted sigmas.
        line_sigmas: predicted sigmas of the same-edge tests.
        turn_probability: below this revolute probability, a line keeps its direction
            between configurations too (within the angle test's tolerance): a turn of it
            is a hinge's, and a press that turns it otherwise is another edge's or a
            corner's.
        confirm_spacing: 0: every press that the gate passes enters the estimate (the v0
            joint ids). Else a press enters only once it is consistent with its line (module
            docstring, "Held presses"): a second press on it at its configuration at least
            this far away, m, with the chord between them along both presses' edges.
        confirm_angle: largest angle between that chord and either press's edge, rad,
            beyond the chord's own error: ``atan(point_std / spacing)`` (one contact lying a
            point sigma deeper into the face than the other).
    """

    push_travel: float = 0.001
    line_angle: float = math.radians(45.0)
    line_tolerance: float = 0.002
    line_angle_tolerance: float = math.radians(2.0)
    line_sigmas: float = 3.0
    turn_probability: float = 0.2
    confirm_spacing: float = 0.0
    confirm_angle: float = math.radians(4.0)

    def __post_init__(self) -> None:
        check_number("labels.push_travel", self.push_travel, 0.0, 0.05, low_open=True)
        check_number("labels.line_angle", self.line_angle, 0.0, math.pi / 2, low_open=True)
        check_number("labels.line_tolerance", self.line_tolerance, 0.0, 0.05)
        check_number("labels.line_angle_tolerance", self.line_angle_tolerance, 0.0, math.pi / 2)
        check_number("labels.line_sigmas", self.line_sigmas, 0.0, 10.0)
        check_number("labels.turn_probability", self.turn_probability, 0.0, 1.0)
        check_number("labels.confirm_spacing", self.confirm_spacing, 0.0, 0.05)
        check_number("labels.confirm_angle", self.confirm_angle, 0.0, math.pi / 2, low_open=True)


@dataclass
class LineRecord:
    """An edge line of the link, as pressed at each configuration.

    Attributes:
        label: its label for the estimator.
        presses: {configuration: the last measurement on it there that entered the
            estimate}.
        held: the presses on it held back (``LabelConfig.confirm_spacing``), in order, each
            with its configuration and the index of its record in the pipeline's
            ``presses``.
    """

    label: int
    presses: dict[int, Measurement]
    held: list[tuple[int, Measurement, int]] = field(default_factory=list)

    @property
    def last(self) -> Measurement:
        """Its last measurement that entered the estimate (at the latest configuration it
        was pressed at), or, if none did yet, its last held one."""
        if self.presses:
            return self.presses[max(self.presses)]
        return self.held[-1][1]

    def at(self, configuration: int) -> Measurement | None:
        """Its last measurement at ``configuration``: one that entered, else a held one."""
        if configuration in self.presses:
            return self.presses[configuration]
        held = [m for c, m, _ in self.held if c == configuration]
        return held[-1] if held else None


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
        candidates = []
        for line in self.lines:
            angle = _angle(m.edge, line.last.edge)
            if angle < cfg.line_angle:
                candidates.append((angle, line.label, line))
        for _, _, line in sorted(candidates, key=lambda c: c[:2]):
            if self._same_edge(m, line):
                return line
        return None

    def _same_edge(self, m: Measurement, line: LineRecord) -> bool:
        """The same-edge test of ``m`` on ``line`` (module docstring)."""
        cfg = self.labels
        here = self.configuration
        if here not in line.presses and (
            self.joint_estimate.probability("revolute") < cfg.turn_probability
        ):
            last = line.last
            turn = math.hypot(m.edge_std, last.edge_std)
            if _angle(m.edge, last.edge) > cfg.line_angle_tolerance + cfg.line_sigmas * turn:
                return False
        other = line.at(here)
        if other is not None:
            offset = line_distance(m.point, other.edge, other.point, other.edge)
            spread = math.hypot(m.point_std, other.point_std)
            turn = math.hypot(m.edge_std, other.edge_std)
            if offset > cfg.line_tolerance + cfg.line_sigmas * spread:
                return False
            if _angle(m.edge, other.edge) > cfg.line_angle_tolerance + cfg.line_sigmas * turn:
                return False
        for other in self.lines:
            if other is line or here not in other.presses:
                continue
            now = other.presses[here]
            shared = [c for c in line.presses if c in other.presses and c != here]
            if not shared:
                continue
            then_line, then_other = line.presses[shared[-1]], other.presses[shared[-1]]
            drift = abs(_angle(m.edge, now.edge) - _angle(then_line.edge, then_other.edge))
            sigma = math.sqrt(
                m.edge_std**2 + now.edge_std**2 + then_line.edge_std**2 + then_other.edge_std**2
            )
            if drift > cfg.line_angle_tolerance + cfg.line_sigmas * sigma:
                return False
        return True

    def _admit(self, m: Measurement) -> tuple[Measurement, ...]:
        line = self._line_of(m)
        if line is None:
            line = LineRecord(len(self.lines), {})
            self.lines.append(line)
        if not self.labels.confirm_spacing:
            self._enter(m, line, self.configuration)
            return (m,)
        here = self.configuration
        partner = self._partner(m, line)
        if partner is not None:
            line.held = [h for h in line.held if h is not partner]
            config, held, record = partner
            self._enter(held, line, config)
            if record < len(self.presses):  # a press offered outside ``step`` has none
                old = self.presses[record]
                self.presses[record] = PressRecord(old.time, True, "", "")
            self._enter(m, line, here)
            return (held, m)
        if self._consistent(m, line):
            self._enter(m, line, here)
            return (m,)
        line.held.append((here, m, len(self.presses)))
        # The press's record, which the base pipeline appends next, says why.
        self.gate.last_rule = "unconfirmed"
        self.gate.last_rejection = (
            "held back until a press at least"
            f" {self.labels.confirm_spacing * 1e3:.0f} mm along its line agrees with it"
        )
        return ()

    def _enter(self, m: Measurement, line: LineRecord, config: int) -> None:
        """Hand a press, labelled, to the estimator."""
        line.presses[config] = m
        # The edge's error isotropic about it, of the measurement's total RMS: the shape
        # edge_cov predicts is not borne out (docs/design.md 7.12).
        self.estimator.add(m.point, m.edge, m.point_std, m.edge_std, line=line.label, config=config)
        self.measurement_labels.append((line.label, config))

    def _partner(self, m: Measurement, line: LineRecord) -> tuple[int, Measurement, int] | None:
        """The latest held press on ``line`` at this configuration that confirms ``m`` and
        that ``m`` confirms (module docstring, "Held presses"), or None."""
        cfg = self.labels
        for held in reversed(line.held):
            config, other, _ = held
            if config != self.configuration:
                continue
            chord = m.point - other.point
            spacing = norm(chord)
            if spacing < cfg.confirm_spacing:
                continue
            chord = chord / spacing
            allowed = cfg.confirm_angle + math.atan(max(m.point_std, other.point_std) / spacing)
            if max(_line_angle(chord, m.edge), _line_angle(chord, other.edge)) <= allowed:
                return held
        return None

    def _consistent(self, m: Measurement, line: LineRecord) -> bool:
        """Whether ``m``, on ``line`` by the same-edge test, needs no partner: the line took a
        press at this configuration already, which ``m`` lies on (the same-edge test); or it
        took presses at other configurations, and ``m`` keeps the line's last direction (a
        slide's, or a link that did not move; within the angle test's tolerance) or, a hinge
        likely, the line's distance from the estimated axis and its angle to it."""
        cfg = self.labels
        if not line.presses:
            return False
        if self.configuration in line.presses:
            return True
        last = line.last
        turn = math.hypot(m.edge_std, last.edge_std)
        if _angle(m.edge, last.edge) <= cfg.line_angle_tolerance + cfg.line_sigmas * turn:
            return True
        if self.joint_estimate.probability("revolute") < cfg.turn_probability:
            return False
        revolute = self.joint_estimate.models.get("revolute")
        axis = None if revolute is None else revolute.axis
        if axis is None or axis.degenerate or not math.isfinite(axis.position_std):
            return False
        here = line_distance(m.point, m.edge, axis.point, axis.direction)
        then = line_distance(last.point, last.edge, axis.point, axis.direction)
        spread = math.sqrt(m.point_std**2 + last.point_std**2 + axis.position_std**2)
        if abs(here - then) > cfg.line_tolerance + cfg.line_sigmas * spread:
            return False
        tilt = abs(_angle(m.edge, axis.direction) - _angle(last.edge, axis.direction))
        return tilt <= cfg.line_angle_tolerance + cfg.line_sigmas * turn

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


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two unit directions, rad."""
    return math.acos(min(max(float(a @ b), -1.0), 1.0))


def _line_angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two unsigned unit directions (lines), rad, in [0, pi/2]."""
    return math.acos(min(abs(float(a @ b)), 1.0))
