"""Probing by touch: press along a direction to a force, hold, average, and read the wrench.

The one place that says what a press is and what a wrench means, for the env's skills and
gate, the paper's Table I protocol and the regime map alike (``docs/design.md`` 4 and 5):

* :class:`PressController` presses along a direction until the *noisy* reading reaches a
  force, holds the fingertip still and averages the readings taken while it holds. It only
  says how far to move next (a scalar along the press direction), so a policy that acts
  through env actions and a script that moves a simulated or real fingertip share it.
  Once touching it moves only along that one line, so the skin is not dragged and the press
  stays *pure* (``docs/design.md`` 4.2).
* :class:`TouchSensor` turns a wrench, the mean of ``readings`` readings, into a
  :class:`Touch` in the world frame: ``estimate_contact`` with the fingertip's geometry, the
  sensor's noise divided by sqrt(``readings``), the skin's stiffness and the ``"plane"``
  contact shape (``docs/design.md`` 4.5), moved into the world frame with the fingertip's
  pose (which the robot knows).
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

from tactile_gym.sensing.contact import estimate_contact
from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sensing.sensor import TOUCH_FORCE, SensorConfig
from tactile_gym.validation import check_int, check_number
from tactile_gym.vec3 import cross, dot

__all__ = [
    "PRESS_PHASES",
    "PressConfig",
    "PressController",
    "Touch",
    "TouchSensor",
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
        return bool(np.isfinite(self.edge).all())


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

    def sense(
        self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray, readings: int = 1
    ) -> Touch:
        """Estimate the contact from a wrench (the mean of ``readings`` readings).

        Args:
            wrench: (6,) force and moment about the sensor origin, sensor frame, N and N m.
            rotation: (3, 3) fingertip rotation, sensor to world.
            position: (3,) sensor origin, world frame, m.
            readings: how many independent readings ``wrench`` averages (noise / sqrt(n)).
        """
        scale = 1.0 / math.sqrt(readings)
        est = estimate_contact(
            wrench[:3],
            wrench[3:],
            self.geometry,
            force_noise_std=self.sensor.force_noise_std * scale,
            moment_noise_std=self.sensor.moment_noise_std * scale,
            skin_stiffness=self.skin_stiffness,
            contact_shape="plane",
        )
        force = rotation @ est.force
        if not est.valid:
            return Touch(False, force, _NAN3, _NAN3, _NAN3, est.edge_std, _NAN33, np.nan)
        normal = rotation @ est.normal
        edge = _NAN3
        edge_cov = _NAN33
        if est.edge_observable:
            # Sign of e . (n x f), on floats (np.linalg.det of the three cost more than the
            # rest of this method). An observable edge has |n x f| = |f_t| far above the
            # rounding, so the sign is the determinant's.
            edge = rotation @ est.edge_direction
            if dot(edge.tolist(), cross(normal.tolist(), force.tolist())) < 0.0:
                edge = -edge
            edge_cov = rotation @ est.edge_cov @ rotation.T
        return Touch(
            valid=True,
            force=force,
            point=rotation @ est.corrected_point + position,
            normal=normal,
            edge=edge,
            edge_std=est.edge_std,
            edge_cov=edge_cov,
            tilt=est.tilt,
        )


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
        stiffness: the force gradient the press assumes, N/m: once touching, a step is the
            force error over it (6000 N/m is about a 5 N press on an edge).
        dwell: readings taken while holding still, averaged; 0 ends the press on reaching
            the force.
        reach: travel into the object without a touch after which the press gives up, m.
        give_way: travel since the touch without reaching the force after which the press
            gives up, m (a link that gives way under it); inf: never.
    """

    target_force: float = 5.0
    tolerance: float = 0.3
    max_step: float = 0.002
    approach_step: float | None = None
    stiffness: float = 6000.0
    dwell: int = 0
    reach: float = 0.012
    give_way: float = math.inf

    def __post_init__(self) -> None:
        check_number("press.target_force", self.target_force, TOUCH_FORCE, 100.0)
        check_number("press.tolerance", self.tolerance, 0.0, self.target_force - TOUCH_FORCE)
        check_number("press.max_step", self.max_step, 0.0, 0.01, low_open=True)
        if self.approach_step is not None:
            check_number("press.approach_step", self.approach_step, 0.0, 0.01, low_open=True)
        check_number("press.stiffness", self.stiffness, 0.0, 1e7, low_open=True)
        check_int("press.dwell", self.dwell, 0, 1000)
        check_number("press.reach", self.reach, 0.0, 1.0)
        if not (self.give_way == math.inf or 0.0 < self.give_way <= 1.0):
            raise ValueError(f"press.give_way must be in (0, 1] m or inf, got {self.give_way!r}")


class PressController:
    """Press along a direction to a force on the noisy reading, hold still, average.

    Call :meth:`step` with each new reading; it returns how far to move the fingertip along
    the press direction before the next reading (m, positive into the object, 0 to hold
    still), or None once the press is over (``phase`` says how). Before touching it moves
    ``approach_step``; touching (|f| >= ``TOUCH_FORCE``), it steps by the force error over
    ``stiffness``, within ``max_step`` either way; once |f| is within ``tolerance`` of the
    force it holds for ``dwell`` readings, and :attr:`mean` averages them.

    Args:
        config: the press.
    """

    def __init__(self, config: PressConfig) -> None:
        self.config = config
        self.phase = "approach"
        #: Readings to average while holding (``extend`` adds to it).
        self.dwell = config.dwell
        #: Travel commanded into the object so far, m.
        self.travel = 0.0
        #: ``travel`` at the first touching reading, m; None before it.
        self.touch_travel: float | None = None
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

    def step(self, reading: np.ndarray) -> float | None:
        """The next move along the press direction, given the latest reading.

        Args:
            reading: (3,) force or (6,) wrench on the fingertip, N (and N m), in any one
                frame throughout; |f| steers the press, and the readings taken while holding
                are averaged as given.

        Returns:
            The move, m (positive into the object, 0: hold still), or None when over.
        """
        if self.over:
            return None
        cfg = self.config
        if self.phase == "hold":
            self._held.append(np.array(reading, dtype=float))
            if len(self._held) >= self.dwell:
                self.phase = "done"
                return None
            return 0.0
        magnitude = float(np.linalg.norm(reading[:3]))
        error = cfg.target_force - magnitude
        touching = magnitude >= TOUCH_FORCE
        if touching and self.touch_travel is None:
            self.touch_travel = self.travel
        if touching and abs(error) <= cfg.tolerance:
            self.phase = "hold" if self.dwell else "done"
            return 0.0 if self.dwell else None
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
            step = float(np.clip(error / cfg.stiffness, -cfg.max_step, cfg.max_step))
        self.travel += max(step, 0.0)
        return step

    def extend(self, readings: int) -> None:
        """Hold on for ``readings`` more readings (a finished press only; it stays still)."""
        if self.phase != "done":
            raise ValueError(f"only a done press can be extended, this one is {self.phase!r}")
        self.dwell = len(self._held) + check_int("readings", readings, 1, 1000)
        self.phase = "hold"


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
