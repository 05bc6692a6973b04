"""The measurement gate: which touches become measurements for the joint-axis estimator.

World frame, metres, newtons, radians. The gate sees, each control step, one F/T reading and
the fingertip pose (both known to a real robot), never the simulator. It accepts a
measurement only where the physics makes the sensing valid (``docs/design.md``, "What the skin
measures"), judged from observable quantities alone:

A measurement is a static, pure press on the edge of a face. The edge cuts the contact patch,
the line of action of the force misses the hemisphere's centre, and e = n x f is the edge. The
rules come from the regime map (``benchmarks/regime_map.py``, ``docs/design.md``, "What the
skin measures"); each uses the readings and the fingertip's pose since the skin last was free
(|f| <= ``touch_force``), which a real robot knows:

1. *Still and steady*: the fingertip held still for ``dwell`` readings, which are averaged (a
   filtered F/T reading: a single reading at 5 N errs 6 deg at P95, the mean of ten 2.4 deg),
   and the force stayed steady over them (within ``max_force_spread``).
2. *In the band*: the averaged force lies in ``force_band`` (the paper's 5 N press).
3. *An edge, cut well*: the force is tilted from the skin normal beyond its noise
   (``ContactEstimate.edge_observable``; a press on a flat face is not) and by at least
   ``min_tilt``. The less the edge cuts the patch, the smaller the tilt and the deeper inside
   the face the contact point (the patch's pressure centre) lies: 2.5 mm at 6 deg, 1.9 mm at
   10 deg.
4. *Not friction's tilt*: the angle between the press path and the force line is at most
   ``friction_share`` times the tilt. When the truncated patch tilts the force, the force
   stays on the path (measured ratio 0.04-0.23); when a drag makes the tilt, the force lies
   between the path and the skin normal (ratio >= 1.05), and its "edge" is the drag's normal,
   30-90 deg off on a flat face.
5. *A small drag bias*: a path component along the measured edge (``drag``, as an angle, less
   twice the noise of the measured force line) drags the sticking skin along the edge and
   turns the measured edge by up to ``atan(drag_gain tan(drag) / tan(tilt))``
   (``drag_gain`` = 1.7 covers straight oblique presses and sideways moves after a press);
   that bias plus twice the predicted edge error must stay within ``bias_budget``. The bias
   is added to the measurement's edge variance.
6. *A link that held*: since the first contact the fingertip travelled at most
   ``max_travel_ratio`` times what a flat face needs for the same force (a link that gives
   way under the press lets the finger travel 5-10 times that, and turns the edge during the
   press), and it did not turn by more than ``max_press_rotation``.

7. *Only the object*: the skin's lowest point stays at least ``table_clearance`` above the
   table (z = 0 in the world frame, which the robot knows like its workbench): a skin that
   also rests on the table sums two contacts into one wrench (measured 10-60 deg off).

One press measurement is taken per touch; a new one needs the skin to lift off first.

*The same edge*: a press near the link's end measures the end's edge, and one at a corner a
mix of two (both edges cut the patch: the edge comes out up to 45 deg off); no single wrench
tells them from the long edge. Their edge lines, though, lie tens of millimetres further from
the axis than the long edge's, and the fit assumes one distance. The reset distribution fixes
that distance (half the link's width for these objects, known before touching, like the
axis prior), so a press is kept only if its edge line lies at that distance from the current
estimated axis, within ``identity_tolerance`` plus three times the spread that the distance's
own spread, the press's errors and the estimate's uncertainty predict
(``MeasurementGate.same_edge``; the env sets ``edge_distance``). Near the hinge the links
overlap around the pin and a press can touch both, mixing two links' edges; a press whose
contact lies within ``min_hinge_distance`` (plus the estimate's position uncertainty) of the
estimated axis is not kept either.

Slides along the edge are not measured. A line through the contact points of a slide along
the edge does give the edge, but while the skin sticks and carries the link round (the way a
fingertip turns it) the contact moves with the link, across the edge, and the readings alone
cannot tell the two apart: such traces were accepted 80 deg off in tests. Pure presses give
0.2-2 deg edges anyway.

Every accepted edge is oriented physically (``tactile_gym.envs.touch``), so both long edges of a
link share one signed distance to the axis and the estimator must not re-sign them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.envs.touch import Touch, TouchSensor
from tactile_gym.estimation import AxisEstimate
from tactile_gym.sensing import indentation_depth
from tactile_gym.spatial import matrix_to_rotvec
from tactile_gym.validation import check_int, check_number, check_range

__all__ = ["GateConfig", "Measurement", "MeasurementGate", "line_distance"]

_DEG = np.pi / 180.0


@dataclass(frozen=True)
class GateConfig:
    """Thresholds of the measurement gate (module docstring).

    Attributes:
        force_band: accepted (min, max) force of a measurement, N.
        touch_force: force above which the skin counts as touching, N. Just above the
            reading noise (|f| of noise alone: about 0.035 N), so that a skin loaded sideways
            before a press shows as part of the press's path.
        dwell: readings averaged for one press measurement (the fingertip held still).
        still_translation: largest fingertip motion in one step that counts as still, m.
        still_rotation: largest fingertip rotation in one step that counts as still, rad.
        max_force_spread: largest change of |f| over the averaged readings, N.
        min_press_depth: least fingertip travel since the skin was free, m.
        min_tilt: least tilt of the force from the skin normal, rad.
        friction_share: largest ratio of the path-to-force angle to the force's tilt.
        drag_gain: how much a drag along the edge turns the measured edge (rule 5).
        bias_budget: largest drag bias plus twice the predicted edge error, rad.
        max_travel_ratio: largest travel since the first contact over the flat-face
            indentation at the measured force.
        max_press_rotation: largest fingertip rotation since the skin was free, rad.
        table_clearance: least height of the skin's lowest point above the table, m.
        identity_tolerance: the slack of the same-edge test beyond three predicted sigmas, m
            (the contact point's own depth inside the face varies by about 2 mm).
        min_hinge_distance: least distance of a kept contact from the estimated axis, m (the
            links overlap 10 mm past the pin, and a patch reaches 5 mm).
        point_std: 1-sigma error of a measured contact point handed to the estimator, m (the
            point sits 0.9-3.1 mm inside the face, at the truncated patch's pressure centre).
        edge_std_floor: least edge error handed to the estimator, rad: the 0.1-0.9 deg model
            error (node spacing, edge rounding) that sensor noise does not show.
    """

    force_band: tuple[float, float] = (4.0, 7.5)
    touch_force: float = 0.1
    dwell: int = 6
    still_translation: float = 2e-5
    still_rotation: float = 2e-4
    max_force_spread: float = 0.15
    min_press_depth: float = 5e-4
    min_tilt: float = 6.0 * _DEG
    friction_share: float = 0.5
    drag_gain: float = 1.7
    bias_budget: float = 5.0 * _DEG
    max_travel_ratio: float = 2.5
    max_press_rotation: float = 0.2 * _DEG
    table_clearance: float = 0.001
    identity_tolerance: float = 0.002
    min_hinge_distance: float = 0.02
    point_std: float = 0.001
    edge_std_floor: float = 1.0 * _DEG

    def __post_init__(self) -> None:
        check_range("gate.force_band", self.force_band, 0.0, 50.0, allow_equal=False)
        check_number("gate.touch_force", self.touch_force, 0.0, 50.0, low_open=True)
        if self.touch_force > self.force_band[0]:
            raise ValueError(
                f"gate.touch_force must be <= gate.force_band[0] ({self.force_band[0]:g} N),"
                f" got {self.touch_force!r}"
            )
        check_int("gate.dwell", self.dwell, 1, 100)
        check_number("gate.still_translation", self.still_translation, 0.0, 1e-3, low_open=True)
        check_number("gate.still_rotation", self.still_rotation, 0.0, 0.1, low_open=True)
        check_number("gate.max_force_spread", self.max_force_spread, 0.0, 5.0, low_open=True)
        check_number("gate.min_press_depth", self.min_press_depth, 0.0, 0.005)
        check_number("gate.min_tilt", self.min_tilt, 0.0, np.pi / 4)
        check_number("gate.friction_share", self.friction_share, 0.0, 1.0, low_open=True)
        check_number("gate.drag_gain", self.drag_gain, 0.0, 10.0)
        check_number("gate.bias_budget", self.bias_budget, 0.0, np.pi / 4, low_open=True)
        check_number("gate.max_travel_ratio", self.max_travel_ratio, 1.0, 20.0)
        check_number("gate.max_press_rotation", self.max_press_rotation, 0.0, 0.1, low_open=True)
        check_number("gate.table_clearance", self.table_clearance, 0.0, 0.05)
        check_number("gate.identity_tolerance", self.identity_tolerance, 0.0, 0.05)
        check_number("gate.min_hinge_distance", self.min_hinge_distance, 0.0, 0.1)
        check_number("gate.point_std", self.point_std, 0.0, 0.01, low_open=True)
        check_number("gate.edge_std_floor", self.edge_std_floor, 0.0, np.pi / 4)


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
        self._window: list[np.ndarray] = []
        self.last_rejection = ""

    def offer(self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray, touch: Touch):
        """Offer one control step's reading; return the measurements it completes (0 or 1).

        Args:
            wrench: (6,) the F/T reading, sensor frame.
            rotation, position: the fingertip pose after the step (sensor to world).
            touch: the contact estimate of this single reading (``TouchSensor.sense``).
        """
        cfg = self.config
        moved, turned = self._motion(rotation, position)
        before = self._pose
        self._pose = (rotation.copy(), position.copy())
        magnitude = float(np.linalg.norm(touch.force))
        if not (touch.valid and magnitude > cfg.touch_force):
            self._touch_pose, self._pressed = None, False
            self._window = []
            return []
        if self._touch_pose is None:
            # The press path starts at the last pose without contact (its direction tells a
            # drag of a lightly loaded skin too); its travel counts from the first contact.
            self._touch_pose = before if before is not None else self._pose
            self._contact_position = position.copy()
        in_band = cfg.force_band[0] <= magnitude <= cfg.force_band[1]
        still = moved <= cfg.still_translation and turned <= cfg.still_rotation
        out = []
        if still and in_band and not self._pressed:
            self._window.append(np.asarray(wrench, dtype=float))
            if len(self._window) >= cfg.dwell:
                self._pressed = True
                measurement = self._press(rotation, position)
                if measurement is not None:
                    out.append(measurement)
        else:
            self._window = []
        return out

    # ------------------------------------------------------------------ press
    def _motion(self, rotation: np.ndarray, position: np.ndarray) -> tuple[float, float]:
        if self._pose is None:
            return np.inf, np.inf
        r0, p0 = self._pose
        return float(np.linalg.norm(position - p0)), float(
            np.linalg.norm(matrix_to_rotvec(rotation @ r0.T))
        )

    def _reject(self, why: str) -> None:
        self.last_rejection = why

    def _press(self, rotation: np.ndarray, position: np.ndarray) -> Measurement | None:
        cfg = self.config
        window = np.asarray(self._window)
        spread = float(np.ptp(np.linalg.norm(window[:, :3], axis=1)))
        if spread > cfg.max_force_spread:
            return self._reject(f"force changed by {spread:.2f} N while still (the link moved)")
        touch = self.sensor.sense(window.mean(axis=0), rotation, position, readings=len(window))
        if not touch.valid:
            return self._reject("averaged press gave no contact")
        r0, p0 = self._touch_pose
        path = position - p0
        depth = float(np.linalg.norm(path))
        magnitude = float(np.linalg.norm(touch.force))
        if depth < cfg.min_press_depth:
            return self._reject(f"press depth {depth:.2e} m < {cfg.min_press_depth} m")
        if not touch.observable:
            return self._reject("the press shows no edge (untilted force)")
        if touch.tilt < cfg.min_tilt:
            return self._reject(f"force tilt {np.degrees(touch.tilt):.1f} deg below min_tilt")
        deviation = float(np.arccos(np.clip(-(path / depth) @ touch.force / magnitude, -1, 1)))
        if deviation > cfg.friction_share * touch.tilt:
            return self._reject(
                f"press path {np.degrees(deviation):.2f} deg off the force line, more than"
                f" {cfg.friction_share} x its {np.degrees(touch.tilt):.2f} deg tilt (friction)"
            )
        drag = float(np.arcsin(min(abs(path @ touch.edge) / depth, 1.0)))
        # The force line is known to sigma_f / (|f| sqrt(n)): a drag within twice that is
        # noise, not a drag (a straight-down press reads 0.1-0.2 deg).
        noise = self.sensor.sensor.force_noise_std / (magnitude * np.sqrt(len(window)))
        drag = max(drag - 2.0 * noise, 0.0)
        bias = float(np.arctan(cfg.drag_gain * np.tan(drag) / np.tan(touch.tilt)))
        if bias + 2.0 * touch.edge_std > cfg.bias_budget:
            return self._reject(
                f"drag bias {np.degrees(bias):.2f} deg + 2 x edge std"
                f" {np.degrees(touch.edge_std):.2f} deg over the budget"
            )
        flat = indentation_depth(magnitude, self.sensor.skin_stiffness, self._radius, "plane")
        travel = float(np.linalg.norm(position - self._contact_position))
        if travel > cfg.max_travel_ratio * flat:
            return self._reject(f"press travel {travel:.2e} m since contact: the link gave way")
        if np.linalg.norm(matrix_to_rotvec(rotation @ r0.T)) > cfg.max_press_rotation:
            return self._reject("fingertip turned during the press")
        lowest = float((rotation @ self._centre + position)[2]) - self._radius
        if lowest < cfg.table_clearance:
            return self._reject(f"the skin reaches {lowest * 1e3:.1f} mm above the table")
        # The drag bias turns the edge within the face: about the force line.
        turn = np.cross(touch.force / magnitude, touch.edge)
        cov = touch.edge_cov + bias * bias * np.outer(turn, turn) / (turn @ turn)
        return self._accept(touch.point, touch.edge, cov)

    def same_edge(self, m: Measurement, estimate: AxisEstimate) -> bool:
        """Whether a measurement may enter the fit: its contact is clear of the hinge, and its
        edge line lies at the expected distance (``edge_distance``: mean, std, m; unchecked
        when None) from the estimated axis (module docstring)."""
        radius = estimate.distance_to(m.point)
        if radius < self.config.min_hinge_distance + estimate.position_std:
            self.last_rejection = (
                f"too near the hinge ({radius * 1e3:.1f} mm from the estimated axis): the links"
                " overlap there"
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
        self.last_rejection = (
            f"another edge: its line lies {distance * 1e3:.1f} mm from the estimated axis,"
            f" the probed edge {mean * 1e3:.1f} +- {std * 1e3:.1f} mm"
        )
        return False

    def _accept(self, point: np.ndarray, edge: np.ndarray, cov: np.ndarray) -> Measurement:
        cov = _floored(edge, cov, self.config.edge_std_floor)
        self.last_rejection = ""
        return Measurement(
            point=np.array(point, dtype=float),
            edge=np.array(edge, dtype=float),
            point_std=self.config.point_std,
            edge_std=float(np.sqrt(np.trace(cov))),
            edge_cov=cov,
        )
