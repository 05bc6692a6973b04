"""The measurement gate: which touches become measurements for the joint-axis estimator.

Each sample the gate takes one F/T reading and the fingertip's pose (both known to a real
robot), never the simulator, and keeps a measurement only where the physics makes the sensing
valid (``docs/design.md`` 7.2, which gives the figures behind every threshold). A
measurement is a static, pure press on the edge of a face. Over the readings since the skin
last was free (a reading below ``TOUCH_FORCE``), a press is accepted when:

1. the fingertip held still for ``dwell`` readings (with ``edge_std_target``: until the
   predicted edge error of their mean reaches it, or ``dwell_budget`` readings; the
   ``HoldRule`` of ``tactile_gym.sensing.probing`` that the press and the skills stop on
   too), whose force stayed steady (``max_force_spread``: its peak-to-peak spread, or with
   ``steady_rule="trend"`` its change along a straight line fitted over the window, which
   averages a noisy sensor's scatter out, :func:`force_change`); they are averaged and read
   as one wrench with as many times less noise variance (``TouchSensor.sense``);
2. the averaged force lies in ``force_band``;
3. its edge is observable and the force is tilted by at least ``min_tilt``;
4. the tilt is the truncated patch's, not friction's (:func:`friction_free`);
5. the bias that the path's drag along the edge predicts, plus twice the predicted edge
   error, is within ``bias_budget`` (:func:`drag_bias`, :func:`bias_within_budget`); the
   bias is added to the measurement's edge covariance;

   with ``preload_rule`` (the default), rules 4 and 5 read the path of the contact patch
   since the first touch, step by step, rather than the net path alone: the skin's sticking
   springs hold a tangential preload of up to the patch's tangential travel however the
   fingertip then comes back or holds still (a shear, a rock of the finger about its
   contact, a drag), so the friction tilt counts from the total tangential travel off the
   press line (:func:`tangential_travel`) and the drag from the larger of the net path's part
   along the edge and the total travel along the edge off that line (:func:`travel_along`),
   each over the press depth (``docs/design.md`` 4.2, 7.2). A press that moves only along its
   line, back and forth included, reads 0 on both;
6. the link held: the fingertip travelled no further than a flat-face press to that force
   needs, times ``max_travel_ratio`` (:func:`link_held`), and did not turn by more than
   ``max_press_rotation``;
7. the skin stayed ``table_clearance`` above the table (z = 0), so the wrench is the object's
   alone.

One measurement per touch. :meth:`MeasurementGate.same_edge` then keeps a measurement only
if its contact is clear of the estimated hinge and its edge line lies at the expected
distance (``edge_distance``) from the estimated axis, which tells the probed long edge from
the link's end and corners. Slides are not measured (``docs/design.md`` 4.3). Every accepted
edge is oriented physically (``tactile_gym.sensing.probing``).

The rules are functions of a :class:`GateConfig`, so that the regime map
(``benchmarks/regime_map``) tests the same rules it supports. Every refusal names its rule
(``GATE_RULES``) and says why. World frame, metres, newtons, radians. NumPy only: the
measurement pipeline of a simulated or a real robot (``tactile_gym.perception``) runs it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.estimation import AxisEstimate
from tactile_gym.sensing import TOUCH_FORCE, HoldRule, Touch, TouchSensor, indentation_depth
from tactile_gym.spatial import matrix_to_rotvec
from tactile_gym.validation import (
    check_bool,
    check_choice,
    check_int,
    check_number,
    check_range,
)
from tactile_gym.vec3 import dot_kernel, norm

__all__ = [
    "GATE_RULES",
    "STEADY_RULES",
    "GateConfig",
    "Measurement",
    "MeasurementGate",
    "bias_within_budget",
    "drag_bias",
    "flat_press_depth",
    "force_change",
    "friction_free",
    "line_distance",
    "link_held",
    "patch_displacement",
    "tangential_travel",
    "travel_along",
]

_DEG = np.pi / 180.0

#: How the steady rule measures the change of the force over a still window
#: (``GateConfig.steady_rule``).
STEADY_RULES = ("spread", "trend")

#: The names of the gate's rules, as a refusal reports them (``MeasurementGate.last_rule``):
#: the press rules of the module docstring in their order, then the same-edge test's two, then
#: the joint pipeline's press held back until its line confirms it
#: (``tactile_gym.perception.joints``; reported like a refusal until it enters).
GATE_RULES = (
    "steady",
    "contact",
    "press_depth",
    "observable",
    "min_tilt",
    "friction_free",
    "preload",
    "drag_bias",
    "link_held",
    "press_rotation",
    "table_clearance",
    "hinge_distance",
    "same_edge",
    "unconfirmed",
)


@dataclass(frozen=True)
class GateConfig:
    """Thresholds of the measurement gate (module docstring).

    Attributes:
        force_band: accepted (min, max) force of a measurement, N; the min at least
            ``TOUCH_FORCE``.
        dwell: readings averaged for one press measurement (the fingertip held still); with
            ``edge_std_target``, the least readings averaged.
        edge_std_target: measure a still press once the predicted edge error of its
            window's mean reaches this, rad (``HoldRule``, ``docs/design.md`` 5.2); None: after
            exactly ``dwell`` readings.
        dwell_budget: with ``edge_std_target``, measure a still press after this many readings
            whatever its predicted error.
        still_translation: largest fingertip motion in one step that counts as still, m.
        still_rotation: largest fingertip rotation in one step that counts as still, rad.
        max_force_spread: largest change of |f| over the averaged readings, N.
        steady_rule: how that change is measured: ``"spread"``, the readings' peak-to-peak
            spread (it grows with the noise and the window's length); ``"trend"``, the change
            along a straight line fitted to them (:func:`force_change`).
        min_press_depth: least fingertip travel since the skin was free, m.
        min_tilt: least tilt of the force from the skin normal, rad.
        friction_share: largest ratio of the path-to-force angle to the force's tilt.
        drag_gain: how much a drag along the edge turns the measured edge (rule 5).
        bias_budget: largest drag bias plus twice the predicted edge error, rad.
        preload_rule: whether rules 4 and 5 count the contact patch's path since the first
            touch step by step (the skin's preload after a shear, a rock or a drag, module
            docstring) rather than the net path alone (off: the gate the v1 ids shipped with).
        max_travel_ratio: largest travel since the first contact over the flat-face
            indentation at the measured force.
        max_press_rotation: largest fingertip rotation since the skin was free, rad.
        table_clearance: least height of the skin's lowest point above the table, m.
        identity_tolerance: the slack of the same-edge test beyond three predicted sigmas, m
            (the variation of the contact point's depth inside the face, ``docs/design.md``
            4.5).
        min_hinge_distance: least distance of a kept contact from the estimated axis, m (where
            the links overlap around the pin, ``docs/design.md`` 7.2), plus the estimate's
            position std; 0: no contact is refused for its distance from the axis (a protocol
            whose contacts near the hinge, as the paper's sliding ones do).
        point_std: 1-sigma error of a measured contact point handed to the estimator, m
            (``docs/design.md`` 4.5).
        edge_std_floor: least edge error handed to the estimator, rad: the model error (node
            spacing, edge rounding) that sensor noise does not show (``docs/design.md`` 4.1).
    """

    force_band: tuple[float, float] = (4.0, 7.5)
    dwell: int = 6
    edge_std_target: float | None = None
    dwell_budget: int = 60
    still_translation: float = 2e-5
    still_rotation: float = 2e-4
    max_force_spread: float = 0.15
    steady_rule: str = "spread"
    min_press_depth: float = 5e-4
    min_tilt: float = 6.0 * _DEG
    friction_share: float = 0.5
    drag_gain: float = 1.7
    bias_budget: float = 5.0 * _DEG
    preload_rule: bool = True
    max_travel_ratio: float = 2.5
    max_press_rotation: float = 0.2 * _DEG
    table_clearance: float = 0.001
    identity_tolerance: float = 0.002
    min_hinge_distance: float = 0.02
    point_std: float = 0.001
    edge_std_floor: float = 1.0 * _DEG

    def __post_init__(self) -> None:
        check_range("gate.force_band", self.force_band, 0.0, 50.0, allow_equal=False)
        if self.force_band[0] < TOUCH_FORCE:
            raise ValueError(
                f"gate.force_band[0] must be >= TOUCH_FORCE ({TOUCH_FORCE:g} N), got"
                f" {self.force_band[0]!r}"
            )
        check_int("gate.dwell", self.dwell, 1, 100)
        check_int("gate.dwell_budget", self.dwell_budget, 1, 1000)
        if self.edge_std_target is not None:
            check_number(
                "gate.edge_std_target", self.edge_std_target, 0.0, np.pi / 2, low_open=True
            )
            check_int("gate.dwell_budget", self.dwell_budget, self.dwell, 1000)
        check_number("gate.still_translation", self.still_translation, 0.0, 1e-3, low_open=True)
        check_number("gate.still_rotation", self.still_rotation, 0.0, 0.1, low_open=True)
        check_number("gate.max_force_spread", self.max_force_spread, 0.0, 5.0, low_open=True)
        check_choice("gate.steady_rule", self.steady_rule, STEADY_RULES)
        check_number("gate.min_press_depth", self.min_press_depth, 0.0, 0.005)
        check_number("gate.min_tilt", self.min_tilt, 0.0, np.pi / 4)
        check_number("gate.friction_share", self.friction_share, 0.0, 1.0, low_open=True)
        check_number("gate.drag_gain", self.drag_gain, 0.0, 10.0)
        check_number("gate.bias_budget", self.bias_budget, 0.0, np.pi / 4, low_open=True)
        check_bool("gate.preload_rule", self.preload_rule)
        check_number("gate.max_travel_ratio", self.max_travel_ratio, 1.0, 20.0)
        check_number("gate.max_press_rotation", self.max_press_rotation, 0.0, 0.1, low_open=True)
        check_number("gate.table_clearance", self.table_clearance, 0.0, 0.05)
        check_number("gate.identity_tolerance", self.identity_tolerance, 0.0, 0.05)
        check_number("gate.min_hinge_distance", self.min_hinge_distance, 0.0, 0.1)
        check_number("gate.point_std", self.point_std, 0.0, 0.01, low_open=True)
        check_number("gate.edge_std_floor", self.edge_std_floor, 0.0, np.pi / 4)

    @property
    def hold_rule(self) -> HoldRule:
        """When a still press has averaged enough (``dwell``, ``edge_std_target``,
        ``dwell_budget``)."""
        return HoldRule(self.dwell, self.edge_std_target, self.dwell_budget)


# --- the rules, as functions of a GateConfig (module docstring; docs/design.md 7.2) ---------


def friction_free(deviation, tilt, config: GateConfig):
    """Whether the force's tilt is the truncated patch's rather than friction's (rule 4).

    A tilt that the truncated patch makes keeps the force on the press path; one that a drag
    makes puts the force between the path and the skin normal, and its "edge" is the drag's
    normal (``docs/design.md`` 4.2).

    Args:
        deviation: angle between the press path and the force line, rad; float or array.
        tilt: the force's tilt from the skin normal, rad; float or array.
        config: the gate (``friction_share``).

    Returns:
        deviation <= ``friction_share`` x tilt, a bool or bool array.
    """
    return deviation <= config.friction_share * tilt


def drag_bias(drag, tilt, gain: float):
    """Edge error that a drag along the edge predicts, rad: atan(gain tan(drag) / tan(tilt)).

    Friction tilts the force along the edge by about ``gain`` x the drag (the path-to-force
    angle along the measured edge) while the truncated patch tilts it across by ``tilt``, so
    the measured edge turns by that angle (``docs/design.md`` 4.2; the gate takes
    ``GateConfig.drag_gain``, the largest gain measured).

    Args:
        drag: rad; float or array. tilt: rad; float or array. gain: >= 0.
    """
    return np.arctan(gain * np.tan(drag) / np.tan(tilt))


def bias_within_budget(bias, edge_std, config: GateConfig):
    """Whether a drag bias plus twice the predicted edge error, rad, fits ``bias_budget``
    (rule 5); floats or arrays."""
    return bias + 2.0 * edge_std <= config.bias_budget


def force_change(magnitudes) -> float:
    """The change of |f| over a still window along a straight line fitted to it by least
    squares, N: the slope times the window's span. A steady force with noise sigma reads
    about sigma sqrt(12 (n - 1) / (n (n + 1))), less the longer the window (the peak-to-peak
    spread grows instead); a link that moves under the press changes it steadily.

    Args:
        magnitudes: (n,) |f| of the window's readings, in order, N.
    """
    f = np.asarray(magnitudes, dtype=float)
    n = len(f)
    if n < 2:
        return 0.0
    index = np.arange(n) - 0.5 * (n - 1)
    return abs(float(index @ f) / float(index @ index)) * (n - 1)


def patch_displacement(point, before, after) -> np.ndarray:
    """How far one step moved the skin at the contact point, world frame, m.

    The skin point now at ``point`` sat at ``R0 R1^T (point - p1) + p0`` before the step: the
    fingertip's translation plus its rotation about the contact (a rock of the finger moves
    the patch by the angle times the lever from the pivot to the contact).

    Args:
        point: (3,) the contact point after the step, world frame, m.
        before, after: the fingertip pose (rotation (3, 3), position (3,)) before and after.
    """
    (r0, p0), (r1, p1) = before, after
    point = np.asarray(point, dtype=float)
    return point - (r0 @ (r1.T @ (point - p1)) + p0)


def tangential_travel(displacements, direction) -> float:
    """The contact patch's total travel off the press line, m: the sum of the steps'
    displacements (``patch_displacement``) less their parts along ``direction`` (unit, the
    net press path). It bounds the tangential stretch of every sticking spring of the skin,
    whatever the path did since (a step back does not undo a slip); a straight press reads 0.

    Args:
        displacements: (n, 3) the steps' patch displacements since the first touch, m.
        direction: (3,) unit press direction.
    """
    d = np.asarray(displacements, dtype=float).reshape(-1, 3)
    off = d - np.outer(d @ direction, direction)
    return float(np.linalg.norm(off, axis=1).sum())


def travel_along(displacements, edge, direction) -> float:
    """The contact patch's total travel along ``edge`` (unit) off the press line, m: sum
    |(displacement less its part along ``direction``) . edge| over the steps since the first
    touch. A press that moves only along its line (back and forth included) reads 0; rule 5
    takes the larger of it and the net path's part along the edge (``preload_rule``)."""
    d = np.asarray(displacements, dtype=float).reshape(-1, 3)
    off = d - np.outer(d @ direction, direction)
    return float(np.abs(off @ edge).sum())


def flat_press_depth(force, skin_stiffness: float, radius: float):
    """Fingertip travel from the first touch to |f| = ``force`` (N) on a flat face, m: the
    Winkler sphere-on-plane indentation (``indentation_depth``, ``"plane"``)."""
    return indentation_depth(force, skin_stiffness, radius, "plane")


def link_held(travel, force, skin_stiffness: float, radius: float, config: GateConfig):
    """Whether a press's travel since the first touch, m, shows a link that held (rule 6):
    at most ``max_travel_ratio`` x ``flat_press_depth(force)``; a link that gives way lets
    the fingertip travel several times that (``docs/design.md`` 7.2)."""
    return travel <= config.max_travel_ratio * flat_press_depth(force, skin_stiffness, radius)


@dataclass(frozen=True)
class Measurement:
    """One accepted measurement, world frame.

    Attributes:
        point: (3,) contact point on the edge, m.
        edge: (3,) unit edge direction, oriented physically.
        point_std: 1-sigma point error, m.
        edge_std: RMS edge angle error, rad (sqrt of the trace of ``edge_cov``).
        edge_cov: (3, 3) covariance of the edge direction, rad^2.
    """

    point: np.ndarray
    edge: np.ndarray
    point_std: float
    edge_std: float
    edge_cov: np.ndarray


def line_distance(point, direction, axis_point, axis) -> float:
    """Distance between the line ``point + t direction`` and the line ``axis_point + s axis``
    (unit directions), m."""
    w = np.asarray(point, dtype=float) - np.asarray(axis_point, dtype=float)
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    normal = np.cross(direction, axis)
    if np.linalg.norm(normal) < 1e-9:  # parallel lines
        return float(np.linalg.norm(w - (w @ axis) * axis))
    return abs(float(w @ normal)) / float(np.linalg.norm(normal))


@kernel()
def _motion(rotation, position, last_rotation, last_position, force):
    """The gate's per-step stillness, in one compiled call: how far the fingertip moved since
    the last pose, m, whether its rotation is the same to the bit, and |f|, N (the norms as
    ``vec3.norm`` takes them)."""
    unturned = True
    for i in range(3):
        for j in range(3):
            if rotation[i, j] != last_rotation[i, j]:
                unturned = False
    d = (
        position[0] - last_position[0],
        position[1] - last_position[1],
        position[2] - last_position[2],
    )
    return math.sqrt(dot_kernel(d, d)), unturned, math.sqrt(dot_kernel(force, force))


def _floored(edge: np.ndarray, cov: np.ndarray, floor: float) -> np.ndarray:
    """``cov`` plus isotropic variance so that its total is at least ``floor^2``."""
    missing = floor * floor - float(np.trace(cov))
    if missing <= 0.0:
        return cov
    return cov + 0.5 * missing * (np.eye(3) - np.outer(edge, edge))


class MeasurementGate:
    """Turns a stream of F/T readings and fingertip poses into measurements.

    Args:
        config: thresholds.
        sensor: the touch sensing it runs on averaged readings.
    """

    def __init__(self, config: GateConfig, sensor: TouchSensor) -> None:
        self.config = config
        self.sensor = sensor
        self._hold = config.hold_rule
        # The still window's readings, in order: rows of one buffer, so that the hold rule
        # reads them as one (n, 6) array every step without stacking them anew.
        self._held = np.empty((self._hold.most, 6))
        #: Expected distance of the probed edge from the axis (mean, std), m, or None.
        self.edge_distance: tuple[float, float] | None = None
        self._radius = sensor.geometry.outer_radius
        self._centre = sensor.geometry.sphere_center
        self.reset()

    def reset(self) -> None:
        """Forget the touch in progress (call at every episode start)."""
        self._touch_pose: tuple[np.ndarray, np.ndarray] | None = None
        self._pose: tuple[np.ndarray, np.ndarray] | None = None
        self._pressed = False  # a press measurement was taken during this touch
        self._count = 0  # readings in the still window
        # The skin's displacement at the contact, step by step since the first touch.
        self._patch: list[np.ndarray] = []
        #: Why the last press or same-edge test refused a measurement ("" after an accept).
        self.last_rejection = ""
        #: The rule (``GATE_RULES``) that refused it ("" after an accept).
        self.last_rule = ""
        #: How many presses and same-edge tests refused a measurement this episode.
        self.refusals = 0

    def end_touch(self) -> None:
        """End the touch in progress, as when the skin reads free: the next contact starts a
        new touch (a robot's "lift" event)."""
        self._touch_pose, self._pressed = None, False
        self._count = 0

    def interrupt(self, rule: str, why: str) -> None:
        """Spoil the touch in progress after a fault in the stream of readings (a dropped
        sample, a repeated time, a pose jump): its still window and its path since the first
        touch are broken, so it gives no measurement, refused under ``rule``; the next touch
        starts afresh once the skin is free. The motion since the last pose is unknown, so the
        next reading is not still."""
        if self._touch_pose is not None and not self._pressed:
            self._pressed = True
            self._count = 0
            self._reject(rule, why)
        self._pose = None

    def offer(self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray, touch: Touch):
        """Offer one control step's reading; return the measurements it completes (0 or 1).

        Args:
            wrench: (6,) the F/T reading, sensor frame.
            rotation, position: the fingertip pose after the step (sensor to world).
            touch: the contact estimate of this single reading (``TouchSensor.sense``).
        """
        cfg = self.config
        if self._pose is None:
            moved = turned = np.inf
            magnitude = norm(touch.force)
        else:
            r0, p0 = self._pose
            moved, unturned, magnitude = _motion(rotation, position, r0, p0, touch.force)
            # An unturned fingertip's rotation vector would be exactly 0 (R R^T is symmetric
            # to the bit); most steps do not turn it.
            turned = 0.0 if unturned else norm(matrix_to_rotvec(rotation @ r0.T))
        before = self._pose
        self._pose = (rotation.copy(), position.copy())
        if not touch.valid:  # |f| below TOUCH_FORCE, or no contact explains the wrench
            self.end_touch()
            return []
        if self._touch_pose is None:
            # The press path starts at the last pose without contact (its direction tells a
            # drag of a lightly loaded skin too); its travel counts from the first contact.
            self._touch_pose = before if before is not None else self._pose
            self._contact_position = position.copy()
            self._patch = []
        if before is not None:  # the skin at the contact, moved by this step
            self._patch.append(patch_displacement(touch.point, before, self._pose))
        in_band = cfg.force_band[0] <= magnitude <= cfg.force_band[1]
        still = moved <= cfg.still_translation and turned <= cfg.still_rotation
        out = []
        if still and in_band and not self._pressed:
            self._held[self._count] = wrench
            self._count += 1
            if self._hold.enough(self.sensor, self._held[: self._count]):
                self._pressed = True
                measurement = self._press(rotation, position)
                if measurement is not None:
                    out.append(measurement)
        else:
            self._count = 0
        return out

    # ------------------------------------------------------------------ press
    def _reject(self, rule: str, why: str) -> None:
        self.last_rule, self.last_rejection = rule, why
        self.refusals += 1

    def _press(self, rotation: np.ndarray, position: np.ndarray) -> Measurement | None:
        cfg = self.config
        window = self._held[: self._count]
        magnitudes = np.linalg.norm(window[:, :3], axis=1)
        if cfg.steady_rule == "spread":
            spread = float(np.ptp(magnitudes))
        else:
            spread = force_change(magnitudes)
        if spread > cfg.max_force_spread:
            return self._reject(
                "steady", f"force changed by {spread:.2f} N while still (the link moved)"
            )
        touch = self.sensor.sense(window.mean(axis=0), rotation, position, readings=len(window))
        if not touch.valid:
            return self._reject("contact", "averaged press gave no contact")
        r0, p0 = self._touch_pose
        path = position - p0
        depth = float(np.linalg.norm(path))
        magnitude = float(np.linalg.norm(touch.force))
        if depth < cfg.min_press_depth:
            return self._reject(
                "press_depth", f"press depth {depth:.2e} m < {cfg.min_press_depth} m"
            )
        if not touch.observable:
            return self._reject("observable", "the press shows no edge (untilted force)")
        if touch.tilt < cfg.min_tilt:
            return self._reject(
                "min_tilt", f"force tilt {np.degrees(touch.tilt):.1f} deg below min_tilt"
            )
        deviation = float(np.arccos(np.clip(-(path / depth) @ touch.force / magnitude, -1, 1)))
        if not friction_free(deviation, touch.tilt, cfg):
            return self._reject(
                "friction_free",
                f"press path {np.degrees(deviation):.2f} deg off the force line, more than"
                f" {cfg.friction_share} x its {np.degrees(touch.tilt):.2f} deg tilt (friction)",
            )
        along = abs(float(path @ touch.edge))
        if cfg.preload_rule:
            # The friction tilt the skin can hold: its tangential travel over the depth.
            off = tangential_travel(self._patch, path / depth)
            if not friction_free(float(np.arctan(off / depth)), touch.tilt, cfg):
                return self._reject(
                    "preload",
                    f"skin preload: the contact travelled {off * 1e3:.2f} mm off the press"
                    f" line since the first touch, over {depth * 1e3:.2f} mm of depth, more"
                    f" than {cfg.friction_share} x the {np.degrees(touch.tilt):.2f} deg tilt",
                )
            along = max(along, travel_along(self._patch, touch.edge, path / depth))
        drag = float(np.arcsin(min(along / depth, 1.0)))
        # The force line is known to sigma_f / (|f| sqrt(n)): a drag within twice that is
        # noise, not a drag (a straight-down press reads 0.1-0.2 deg).
        noise = self.sensor.sensor.force_noise_std / (magnitude * np.sqrt(len(window)))
        drag = max(drag - 2.0 * noise, 0.0)
        bias = float(drag_bias(drag, touch.tilt, cfg.drag_gain))
        if not bias_within_budget(bias, touch.edge_std, cfg):
            return self._reject(
                "drag_bias",
                f"drag bias {np.degrees(bias):.2f} deg + 2 x edge std"
                f" {np.degrees(touch.edge_std):.2f} deg over the budget",
            )
        travel = float(np.linalg.norm(position - self._contact_position))
        if not link_held(travel, magnitude, self.sensor.skin_stiffness, self._radius, cfg):
            return self._reject(
                "link_held", f"press travel {travel:.2e} m since contact: the link gave way"
            )
        if np.linalg.norm(matrix_to_rotvec(rotation @ r0.T)) > cfg.max_press_rotation:
            return self._reject("press_rotation", "fingertip turned during the press")
        lowest = float((rotation @ self._centre + position)[2]) - self._radius
        if lowest < cfg.table_clearance:
            return self._reject(
                "table_clearance", f"the skin reaches {lowest * 1e3:.1f} mm above the table"
            )
        # The drag bias turns the edge within the face: about the force line.
        turn = np.cross(touch.force / magnitude, touch.edge)
        cov = touch.edge_cov + bias * bias * np.outer(turn, turn) / (turn @ turn)
        return self._accept(touch.point, touch.edge, cov)

    def same_edge(self, m: Measurement, estimate: AxisEstimate | None) -> bool:
        """Whether a measurement may enter the fit: its contact is clear of the hinge, and its
        edge line lies at the expected distance (``edge_distance``: mean, std, m; unchecked
        when None) from the estimated axis (module docstring). Without an estimate yet (an
        estimator without a prior) there is nothing to test against: it may."""
        if estimate is None:
            return True
        radius = estimate.distance_to(m.point)
        least = self.config.min_hinge_distance
        if least > 0.0 and radius < least + estimate.position_std:
            self._reject(
                "hinge_distance",
                f"too near the hinge ({radius * 1e3:.1f} mm from the estimated axis): the links"
                " overlap there",
            )
            return False
        if self.edge_distance is None:
            return True
        mean, std = self.edge_distance
        u = estimate.direction
        w = m.point - estimate.point
        distance = line_distance(m.point, m.edge, estimate.point, u)
        along = float(m.edge @ u)
        # Along the edge from the contact point to the foot of the common perpendicular.
        lever = 0.0
        if abs(along) < 1.0 - 1e-9:
            lever = (along * float(u @ w) - float(m.edge @ w)) / (1.0 - along * along)
        spread = np.sqrt(
            std**2 + m.point_std**2 + (lever * m.edge_std) ** 2 + estimate.position_std**2
        )
        if abs(distance - mean) <= self.config.identity_tolerance + 3.0 * spread:
            return True
        self._reject(
            "same_edge",
            f"another edge: its line lies {distance * 1e3:.1f} mm from the estimated axis,"
            f" the probed edge {mean * 1e3:.1f} +- {std * 1e3:.1f} mm",
        )
        return False

    def _accept(self, point: np.ndarray, edge: np.ndarray, cov: np.ndarray) -> Measurement:
        cov = _floored(edge, cov, self.config.edge_std_floor)
        self.last_rule = self.last_rejection = ""
        return Measurement(
            point=np.array(point, dtype=float),
            edge=np.array(edge, dtype=float),
            point_std=self.config.point_std,
            edge_std=float(np.sqrt(np.trace(cov))),
            edge_cov=cov,
        )
