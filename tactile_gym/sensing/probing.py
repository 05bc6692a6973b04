"""Probing by touch: press along a direction to a force, hold, average, and read the wrench.

The one place that says what a press is and what a wrench means, for the env's skills and
gate, the paper's Table I protocol and the regime map alike (``docs/design.md`` 4 and 5):

* :class:`PressController` presses along a direction until the *noisy* reading reaches a
  force, holds the fingertip still and averages the readings taken while it holds. It only
  says how far to move next (a scalar along the press direction), so a policy that acts
  through env actions and a script that moves a simulated or real fingertip share it.
  Once touching it moves only along that one line, so the skin is not dragged and the press
  stays *pure* (``docs/design.md`` 4.2). It steps by the force error over a force gradient:
  the one it assumes, or (``measure_gradient``) the one it measures as it presses
  (:class:`GradientEstimate`, ``docs/design.md`` 5.2).
* :class:`HoldRule` says when a still press has averaged enough: a fixed count, or until
  the predicted edge error of the mean (:func:`predicted_edge_std`) reaches a target,
  within a budget. The press, the measurement gate and the env's skills use it alike.
* :class:`TouchSensor` turns a wrench, the mean of ``readings`` readings, into a
  :class:`Touch` in the world frame: ``estimate_contact`` (its soft model) with the
  fingertip's geometry, the sensor's noise divided by sqrt(``readings``), the skin's
  stiffness and the ``"plane"`` contact shape (``docs/design.md`` 4.5), moved into the world
  frame with the fingertip's pose (which the robot knows).
* ``TOUCH_FORCE`` (``tactile_gym.sensing.sensor``) is the one threshold of a touch.

Edge orientation. ``estimate_contact`` returns the edge as a line. A :class:`Touch` orients it
*physically*: ``e = normalise(n x f)`` with n the skin's outward normal at the contact and f
the force on the fingertip. Pressing the edge of a face, the line of action passes through
the truncated patch's centroid, on the face's side of the edge, so the contact normal leans
toward the face's interior and ``e`` points along the edge with the interior on a fixed side
(``docs/design.md`` 7.3).

Conventions (``docs/design.md`` 2): SI units; wrenches in the sensor frame (force on the
fingertip, moment about the sensor origin); poses map sensor to world. NumPy only.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from tactile_gym._jit import kernel
from tactile_gym.sensing import contact
from tactile_gym.sensing.contact import MIN_TILT_SNR, contact_core, contact_parameters
from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sensing.sensor import TOUCH_FORCE, SensorConfig
from tactile_gym.validation import check_bool, check_int, check_number
from tactile_gym.vec3 import cross, dot

__all__ = [
    "PRESS_PHASES",
    "GradientEstimate",
    "HoldRule",
    "PressConfig",
    "PressController",
    "Touch",
    "TouchSensor",
    "effective_readings",
    "predicted_edge_std",
    "run_press",
]

_NAN3 = np.full(3, np.nan)
_NAN33 = np.full((3, 3), np.nan)


@dataclass(frozen=True)
class Touch:
    """One contact estimate in the world frame (NaN fields when not valid or not observable).

    Attributes:
        valid: a contact was found (|f| at least ``TOUCH_FORCE``, a line of action on the skin).
        force: (3,) force on the fingertip, N.
        point: (3,) indentation-corrected contact point, m.
        normal: (3,) outward skin normal at the contact.
        edge: (3,) unit edge direction, oriented physically (module docstring); NaN when the
            edge is not observable (an untilted press).
        edge_std: predicted RMS angle error of the edge, rad (pi/2 when not observable).
        edge_cov: (3, 3) predicted covariance of the edge direction, rad^2.
        tilt: angle between the force and the inward skin normal, rad.
    """

    valid: bool
    force: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    edge: np.ndarray
    edge_std: float
    edge_cov: np.ndarray
    tilt: float

    @property
    def observable(self) -> bool:
        """Whether the edge direction is defined."""
        # On Python floats: the env, its observation and the gate ask every control step.
        return all(map(math.isfinite, self.edge.tolist()))


class TouchSensor:
    """What a wrench means: contact sensing for one fingertip, sensor and skin.

    Args:
        geometry: the fingertip.
        sensor: the F/T sensor's noise (used for the predicted errors).
        skin_stiffness: Winkler modulus of the skin for the indentation correction, N/m^3.
    """

    def __init__(
        self, geometry: FingertipGeometry, sensor: SensorConfig, skin_stiffness: float
    ) -> None:
        self.geometry = geometry
        self.sensor = sensor
        self.skin_stiffness = check_number("skin_stiffness", skin_stiffness, 0.0, low_open=True)
        # ``estimate_contact``'s soft model with this fingertip, noise and skin, checked here
        # once: a reading is sensed every control step.
        self._parameters = contact_parameters(
            geometry,
            "soft",
            TOUCH_FORCE,
            check_number("force_noise_std", sensor.force_noise_std, 0.0),
            check_number("moment_noise_std", sensor.moment_noise_std, 0.0),
            self.skin_stiffness,
            "plane",
            MIN_TILT_SNR,
        )

    def sense(
        self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray, readings: float = 1
    ) -> Touch:
        """Estimate the contact from a wrench (the mean of ``readings`` readings).

        Args:
            wrench: (6,) force and moment about the sensor origin, sensor frame, N and N m.
            rotation: (3, 3) fingertip rotation, sensor to world.
            position: (3,) sensor origin, world frame, m.
            readings: how many independent readings ``wrench`` averages (noise / sqrt(n));
                a float where the mean is worth a fractional count
                (:func:`effective_readings`).
        """
        w = self._checked(wrench)
        out = contact_core(w, self._parameters, 1.0 / math.sqrt(readings))
        return self._sensed(out, rotation @ w[:3], rotation, position)

    @staticmethod
    def _checked(wrench) -> np.ndarray:
        """The wrench as a (6,) float array, or a ValueError if it is not 6 finite numbers."""
        w = np.ascontiguousarray(wrench, dtype=float)  # the kernel's one layout
        values = w.tolist()
        if w.shape != (6,) or not all(map(math.isfinite, values)):
            raise ValueError(f"wrench must be 6 finite numbers, got {values}")
        return w

    @staticmethod
    def _sensed(out: np.ndarray, force: np.ndarray, rotation, position) -> Touch:
        """The Touch of ``contact_core``'s output, in the world frame of the pose."""
        values = out.tolist()
        if values[contact.STATUS] != contact.FOUND:
            return Touch(
                False, force, _NAN3, _NAN3, _NAN3, contact.EDGE_STD_UNOBSERVABLE, _NAN33, np.nan
            )
        normal = rotation @ out[contact.NORMAL]
        edge = _NAN3
        edge_cov = _NAN33
        if values[contact.OBSERVABLE]:
            # Signed physically: e . (n x f) > 0, on floats (np.linalg.det of the three cost
            # more than the rest of this method). An observable edge has |n x f| = |f_t| far
            # above the rounding, so the sign is the determinant's.
            edge = rotation @ out[contact.EDGE]
            if dot(edge.tolist(), cross(normal.tolist(), force.tolist())) < 0.0:
                edge = -edge
            edge_cov = rotation @ out[contact.EDGE_COV].reshape(3, 3) @ rotation.T
        return Touch(
            valid=True,
            force=force,
            point=rotation @ out[contact.CORRECTED] + position,
            normal=normal,
            edge=edge,
            edge_std=values[contact.EDGE_STD],
            edge_cov=edge_cov,
            tilt=values[contact.TILT],
        )


def effective_readings(sensor: SensorConfig, readings: np.ndarray) -> float:
    """How many readings of the configured noise the mean of ``readings`` is worth.

    The readings of a still press scatter by the sensor's noise. Where they scatter more than
    ``sensor`` says (a noisier sensor than configured, a trend), their mean is worth as many
    configured readings as their count over the larger ratio of the measured to the
    configured variance (force or moment, pooled over the axes); never more than their count.

    Args:
        sensor: the configured noise.
        readings: (n, 6) wrenches of a still press, any one frame.

    Returns:
        n divided by max(1, measured / configured variance), readings.
    """
    readings = _checked_readings(readings)
    return _effective_readings(readings, sensor.force_noise_std, sensor.moment_noise_std)


def predicted_edge_std(sensor: TouchSensor, readings: np.ndarray) -> float:
    """The predicted RMS edge error of the mean of a still press's readings, rad.

    ``TouchSensor.sense`` of their mean, read as the mean of :func:`effective_readings`
    readings: the configured noise over sqrt(n), or the noise the readings show where it is
    larger (pi/2 when the mean shows no edge). One compiled call (``_hold_edge_std``): the
    measurement gate asks it on every still reading of a press.

    Args:
        sensor: the touch sensing (its configured noise, fingertip and skin).
        readings: (n, 6) wrenches in the sensor frame, n >= 1.
    """
    readings = _checked_readings(readings)
    if len(readings) == 0:
        raise ValueError("readings must hold at least one wrench, got none")
    return _hold_edge_std(readings, sensor._parameters)


def _checked_readings(readings) -> np.ndarray:
    """(n, 6) finite wrenches as a C-ordered float array (the kernels' one layout)."""
    r = np.ascontiguousarray(np.asarray(readings, dtype=float).reshape(-1, 6))
    if not np.isfinite(r).all():
        raise ValueError(f"readings must be finite, got {r.tolist()}")
    return r


@kernel()
def _column_sums(readings):
    """The sums down the columns of (n, 6) readings (n >= 1), as NumPy's ``sum(axis=0)``
    adds them: row after row."""
    total = readings[0].copy()
    for i in range(1, readings.shape[0]):
        for j in range(6):
            total[j] = total[j] + readings[i, j]
    return total


@kernel()
def _effective_readings(readings, force_std, moment_std):
    """``effective_readings`` of checked (n, 6) readings, rounding as NumPy's
    ``var(axis=0, ddof=1)`` and ``mean`` do (sums in order, then one division)."""
    n = readings.shape[0]
    if n < 2:
        return float(n)
    mean = _column_sums(readings) / n
    variance = np.empty(6)
    for j in range(6):
        d = readings[0, j] - mean[j]
        total = d * d
        for i in range(1, n):
            d = readings[i, j] - mean[j]
            total = total + d * d
        variance[j] = total / (n - 1)
    ratio = 1.0
    for first, std in ((0, force_std), (3, moment_std)):
        if std > 0.0:
            part = ((variance[first] + variance[first + 1]) + variance[first + 2]) / 3
            r = part / (std * std)
            ratio = r if r > ratio else ratio  # max(ratio, r), as Python takes it
    return n / ratio


@kernel()
def _hold_edge_std(readings, parameters):
    """``predicted_edge_std`` of checked (n, 6) readings (n >= 1) and ``TouchSensor``'s
    ``contact_parameters``."""
    count = _effective_readings(readings, parameters[4], parameters[5])
    out = contact_core(
        _column_sums(readings) / readings.shape[0], parameters, 1.0 / math.sqrt(count)
    )
    if out[contact.STATUS] != contact.FOUND:
        return contact.EDGE_STD_UNOBSERVABLE
    return out[contact.EDGE_STD]


@dataclass(frozen=True)
class HoldRule:
    """When a still press has averaged enough readings (``docs/design.md`` 5.2).

    Without a ``target``, after exactly ``least`` readings. With one, once the predicted edge
    error of their mean (:func:`predicted_edge_std`) is at most ``target`` and at least
    ``least`` readings are in, or after ``budget`` readings whatever it says. The press, the
    measurement gate and the env's skills stop on this one rule.

    Attributes:
        least: readings to average at least (0: none, with no target).
        target: predicted edge error of the mean to reach, rad; None: a fixed count.
        budget: most readings to average with a target (>= ``least``).
    """

    least: int
    target: float | None = None
    budget: int = 0

    def __post_init__(self) -> None:
        check_int("hold.least", self.least, 0, 1000)
        if self.target is not None:
            check_number("hold.target", self.target, 0.0, math.pi / 2, low_open=True)
            check_int("hold.budget", self.budget, max(self.least, 1), 1000)

    @property
    def most(self) -> int:
        """The most readings the rule averages."""
        return self.least if self.target is None else self.budget

    def enough(self, sensor: TouchSensor | None, readings) -> bool:
        """Whether the still readings so far, (n, 6) in the sensor frame, are enough.

        Args:
            sensor: the touch sensing that predicts the edge error (needed with a target).
            readings: the readings averaged so far (a fixed count needs only their number).
        """
        n = len(readings)
        if n < self.least:
            return False
        if self.target is None or n >= self.budget:
            return True
        if sensor is None:
            raise ValueError("a hold rule with a target needs a TouchSensor")
        return predicted_edge_std(sensor, readings) <= self.target


class GradientEstimate:
    """The force gradient dF/dd a press meets along its line, measured from its readings.

    A Winkler skin (``docs/design.md`` 3.1) pressed by depth d carries a force whose gradient
    is the stiffness times the contact area, dF/dd = k A(d). On a plane A = 2 pi R d, so
    F = pi k R d^2 and dF/dd = 2 sqrt(pi k R F); on a straight edge through the lowest point
    of the skin half of that: F = pi k R d^2 / 2, dF/dd = sqrt(2 pi k R F). Both are
    F = b^2 d^2: sqrt(F) grows linearly with the depth, with slope b. The estimate is that
    slope, fitted by least squares through the origin to the differences between consecutive
    touching readings: the change of sqrt|f| over the commanded move, each weighted by the
    inverse of its noise variance (sqrt|f| reads the force noise sigma as sigma / (2 sqrt F),
    so 1 / (1/F1 + 1/F2), the common sigma cancelling). Until the first difference, and
    within a factor ``spread`` of it after, it is the assumed gradient at the target force.

    The gradient at a force F is then 2 b sqrt(F), and the move that takes F to the target
    F* along that law is (sqrt(F*) - sqrt(F)) / b: the force error over the secant gradient
    b (sqrt(F) + sqrt(F*)). Noise-free, on any law F = b^2 (d - d0)^2, one step reaches the
    force; elsewhere (an edge off the lowest point, a thick skin) it is the local slope.

    Args:
        assumed: the gradient assumed at the target force, N/m.
        target_force: N.
        spread: the estimate stays within [assumed / spread, assumed * spread] at the target.
    """

    def __init__(self, assumed: float, target_force: float, spread: float) -> None:
        self.target_force = float(target_force)
        self._prior = float(assumed) / (2.0 * math.sqrt(self.target_force))
        self._low, self._high = self._prior / spread, self._prior * spread
        self._moment = 0.0  # sum of w * move * d(sqrt F)
        self._weight = 0.0  # sum of w * move^2
        self._last: tuple[float, float] | None = None  # (depth, sqrt F) of the last touching

    @property
    def slope(self) -> float:
        """b = d sqrt(F) / d depth, N^0.5/m (bounded)."""
        if self._weight <= 0.0:
            return self._prior
        return min(max(self._moment / self._weight, self._low), self._high)

    def gradient(self, force: float) -> float:
        """dF/dd at ``force`` (N), N/m."""
        return 2.0 * self.slope * math.sqrt(max(force, 0.0))

    def add(self, depth: float, force: float | None) -> None:
        """Take a reading: the press's depth along its line (m, commanded) and |f| (N), or
        None when the skin is free (the next difference starts afresh)."""
        if force is None:
            self._last = None
            return
        root = math.sqrt(force)
        if self._last is not None:
            move, rise = depth - self._last[0], root - self._last[1]
            if move != 0.0:
                w = 1.0 / (1.0 / force + 1.0 / (self._last[1] ** 2))
                self._moment += w * move * rise
                self._weight += w * move * move
        self._last = (depth, root)

    def step(self, force: float) -> float:
        """The move along the line that takes ``force`` (N) to the target force, m."""
        return (math.sqrt(self.target_force) - math.sqrt(max(force, 0.0))) / self.slope


#: Phases of a press: moving in free of contact, pressing to the force, holding still; and
#: its ends: done (held and averaged), missed (no touch within ``reach``), gave way (no force
#: within ``give_way`` of travel since the touch).
PRESS_PHASES = ("approach", "press", "hold", "done", "missed", "gave_way")


@dataclass(frozen=True)
class PressConfig:
    """How to press. The defaults are the env's probe (``docs/design.md`` 7.6).

    Attributes:
        target_force: |f| to press to, on the noisy reading, N.
        tolerance: |f| within this of ``target_force`` counts as reached, N.
        max_step: largest move per reading once touching, m.
        approach_step: move per reading while free of contact, m; None: ``max_step``.
        stiffness: the force gradient the press assumes at ``target_force``, N/m: once
            touching, a step is the force error over it (6000 N/m is about a 5 N press on an
            edge); with ``measure_gradient``, where the measurement starts.
        measure_gradient: step by the force error over the gradient measured while pressing
            (:class:`GradientEstimate`) instead of ``stiffness``: a skin stiffer or softer
            than assumed is pressed as fast, and the press settles (``docs/design.md`` 5.2).
        gradient_spread: the measured gradient stays within this factor of ``stiffness``.
        dwell: readings taken while holding still, averaged; 0 ends the press on reaching
            the force. With ``edge_std_target``, the least readings to average.
        edge_std_target: hold until the predicted edge error of the mean reaches this, rad
            (:class:`HoldRule`); None: exactly ``dwell`` readings.
        dwell_budget: most readings to hold with ``edge_std_target``.
        reach: travel into the object without a touch after which the press gives up, m.
        give_way: travel since the touch without reaching the force after which the press
            gives up, m (a link that gives way under it); inf: never.
    """

    target_force: float = 5.0
    tolerance: float = 0.3
    max_step: float = 0.002
    approach_step: float | None = None
    stiffness: float = 6000.0
    measure_gradient: bool = False
    gradient_spread: float = 4.0
    dwell: int = 0
    edge_std_target: float | None = None
    dwell_budget: int = 60
    reach: float = 0.012
    give_way: float = math.inf

    def __post_init__(self) -> None:
        check_number("press.target_force", self.target_force, TOUCH_FORCE, 100.0)
        check_number("press.tolerance", self.tolerance, 0.0, self.target_force - TOUCH_FORCE)
        check_number("press.max_step", self.max_step, 0.0, 0.01, low_open=True)
        if self.approach_step is not None:
            check_number("press.approach_step", self.approach_step, 0.0, 0.01, low_open=True)
        check_number("press.stiffness", self.stiffness, 0.0, 1e7, low_open=True)
        check_bool("press.measure_gradient", self.measure_gradient)
        check_number("press.gradient_spread", self.gradient_spread, 1.0, 100.0)
        check_int("press.dwell", self.dwell, 0, 1000)
        check_int("press.dwell_budget", self.dwell_budget, 1, 1000)
        if self.edge_std_target is not None:
            check_number(
                "press.edge_std_target", self.edge_std_target, 0.0, math.pi / 2, low_open=True
            )
            check_int("press.dwell_budget", self.dwell_budget, max(self.dwell, 1), 1000)
        check_number("press.reach", self.reach, 0.0, 1.0)
        if not (self.give_way == math.inf or 0.0 < self.give_way <= 1.0):
            raise ValueError(f"press.give_way must be in (0, 1] m or inf, got {self.give_way!r}")

    @property
    def hold_rule(self) -> HoldRule:
        """When the hold has averaged enough (``dwell``, ``edge_std_target``,
        ``dwell_budget``)."""
        return HoldRule(self.dwell, self.edge_std_target, self.dwell_budget)


class PressController:
    """Press along a direction to a force on the noisy reading, hold still, average.

    Call :meth:`step` with each new reading; it returns how far to move the fingertip along
    the press direction before the next reading (m, positive into the object, 0 to hold
    still), or None once the press is over (``phase`` says how). Before touching it moves
    ``approach_step``; touching (|f| >= ``TOUCH_FORCE``), it steps by the force error over
    the force gradient (``stiffness``, or the measured one with ``measure_gradient``), within
    ``max_step`` either way; once |f| is within ``tolerance`` of the force it holds still
    until its :class:`HoldRule` has enough readings, and :attr:`mean` averages them.

    Args:
        config: the press.
        sensor: the touch sensing that predicts the edge error of the mean; needed with
            ``edge_std_target`` (the readings are then (6,) wrenches in the sensor frame).
    """

    def __init__(self, config: PressConfig, sensor: TouchSensor | None = None) -> None:
        self.config = config
        self.sensor = sensor
        self.phase = "approach"
        #: When the hold has averaged enough (``extend`` replaces it).
        self.rule = self._checked(config.hold_rule)
        #: Travel commanded into the object so far, m.
        self.travel = 0.0
        #: ``travel`` at the first touching reading, m; None before it.
        self.touch_travel: float | None = None
        #: The measured force gradient (``measure_gradient``), or None.
        self.gradient = (
            GradientEstimate(config.stiffness, config.target_force, config.gradient_spread)
            if config.measure_gradient
            else None
        )
        self._depth = 0.0  # position along the line, moves back included, m
        self._approach = config.max_step if config.approach_step is None else config.approach_step
        self._held: list[np.ndarray] = []

    @property
    def over(self) -> bool:
        """Whether the press has ended (done, missed or gave way)."""
        return self.phase in PRESS_PHASES[3:]

    @property
    def readings(self) -> int:
        """How many readings :attr:`mean` averages."""
        return len(self._held)

    @property
    def mean(self) -> np.ndarray | None:
        """The mean of the readings taken while holding, as given to :meth:`step`; None
        before the first."""
        return np.mean(self._held, axis=0) if self._held else None

    @property
    def held(self) -> np.ndarray:
        """(n, k) the readings taken while holding, as given to :meth:`step`."""
        return np.array(self._held, dtype=float)

    def step(self, reading: np.ndarray) -> float | None:
        """The next move along the press direction, given the latest reading.

        Args:
            reading: (3,) force or (6,) wrench on the fingertip, N (and N m), in any one
                frame throughout; |f| steers the press, and the readings taken while holding
                are averaged as given ((6,), sensor frame, for a hold rule with a target).

        Returns:
            The move, m (positive into the object, 0: hold still), or None when over.
        """
        if self.over:
            return None
        cfg = self.config
        if self.phase == "hold":
            self._held.append(np.array(reading, dtype=float))
            if self.rule.enough(self.sensor, self._held):
                self.phase = "done"
                return None
            return 0.0
        magnitude = float(np.linalg.norm(reading[:3]))
        error = cfg.target_force - magnitude
        touching = magnitude >= TOUCH_FORCE
        if self.gradient is not None:
            self.gradient.add(self._depth, magnitude if touching else None)
        if touching and self.touch_travel is None:
            self.touch_travel = self.travel
        if touching and abs(error) <= cfg.tolerance:
            hold = self.rule.most > 0
            self.phase = "hold" if hold else "done"
            return 0.0 if hold else None
        if not touching:
            if self.travel >= cfg.reach:
                self.phase = "missed"
                return None
            step = self._approach
        else:
            if self.travel - self.touch_travel >= cfg.give_way:
                self.phase = "gave_way"
                return None
            self.phase = "press"
            if self.gradient is None:
                step = error / cfg.stiffness
            else:
                step = self.gradient.step(magnitude)
            step = float(np.clip(step, -cfg.max_step, cfg.max_step))
        self.travel += max(step, 0.0)
        self._depth += step
        return step

    def extend(self, rule: HoldRule) -> None:
        """Hold on, still, until ``rule`` is met over all the readings held (a finished
        press only; if the readings held already meet it, the press stays done)."""
        if self.phase != "done":
            raise ValueError(f"only a done press can be extended, this one is {self.phase!r}")
        self.rule = self._checked(rule)
        if not rule.enough(self.sensor, self._held):
            self.phase = "hold"

    def _checked(self, rule: HoldRule) -> HoldRule:
        if rule.target is not None and self.sensor is None:
            raise ValueError("a hold rule with an edge_std_target needs a TouchSensor")
        return rule


def run_press(
    press: PressController,
    read: Callable[[], np.ndarray],
    move: Callable[[float], object],
    limit: int = 1000,
) -> PressController:
    """Drive a press to its end on a fingertip that a script moves directly.

    Args:
        press: the press, in any phase.
        read: returns the latest reading (see ``PressController.step``).
        move: moves the fingertip by the given distance along the press direction, m (0:
            holds it still) and waits for the next reading (one control step).
        limit: most readings to take.

    Returns:
        ``press``, over.

    Raises:
        RuntimeError: the press did not end within ``limit`` readings.
    """
    for _ in range(limit):
        step = press.step(read())
        if step is None:
            return press
        move(step)
    raise RuntimeError(f"the press did not end within {limit} readings (phase {press.phase!r})")
