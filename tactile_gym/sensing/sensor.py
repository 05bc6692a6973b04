"""The six-axis force/torque sensor under the fingertip: its errors, a touch, and taring.

The one place the sensor's defaults are written: the simulator draws its readings with them
(:class:`SensorErrors`) and ``estimate_contact`` predicts its errors with them.
``TOUCH_FORCE`` is the one threshold at which a reading counts as a touch, for the sensing,
the gate, the press and the skills alike, with ``RELEASE_FORCE`` its hysteresis
(``docs/design.md`` 5).

A reading is the contact wrench plus the weight of the fingertip that hangs below the sensor
(:func:`gravity_wrench`), a constant bias, an offset drawn per episode, a slow drift (a random
walk in time) and white noise. :class:`Tare` zeroes it as a robot does: an unloaded reading in
free air at a known pose, then the change of the fingertip's weight with the commanded pose
(``docs/design.md`` 5.1, "The F/T sensor and taring"; the figures and their sources are
there).

Conventions (``docs/design.md``, "Frames and units"): SI units (newtons, newton-metres,
kilograms, seconds); wrenches and the centre of mass in the sensor frame (origin at the F/T
sensor, z along the finger axis); rotations map sensor to world; gravity is world -z. NumPy
only, so real robots can reuse it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.validation import check_int, check_number, check_vector
from tactile_gym.vec3 import cross

__all__ = [
    "ALUMINIUM_DENSITY",
    "GRAVITY",
    "RELEASE_FORCE",
    "SENSOR_MODELS",
    "SILICONE_DENSITY",
    "TARE_SAMPLES",
    "TOUCH_FORCE",
    "SensorConfig",
    "SensorErrors",
    "Tare",
    "fingertip_mass_properties",
    "gravity_wrench",
]

#: |f| of a reading, N, at or above which the skin counts as touching: 10 standard deviations
#: of the default per-axis force noise, so noise alone (|f| about 0.035 N) never reads as one.
TOUCH_FORCE = 0.2
#: |f|, N, below which a touch has ended: half of ``TOUCH_FORCE`` (hysteresis), so that a lift
#: leaves the skin unloaded before the next press, and a reading that hovers at the threshold
#: does not end a touch and start another.
RELEASE_FORCE = 0.5 * TOUCH_FORCE

#: Sensor samples a tare averages: the sensor samples at 1 kHz, so 50 fill one 20 Hz control
#: period; their mean's noise (0.003 N, 7e-5 N m per axis) stays below that of a measurement
#: press's 20 readings, so a tare adds less error than it removes (``docs/design.md`` 5.1).
TARE_SAMPLES = 50
#: Standard gravity, m/s^2 (world -z).
GRAVITY = 9.80665
#: Density of the fingertip's shell (aluminium), kg/m^3.
ALUMINIUM_DENSITY = 2700.0
#: Density of its skin (cast silicone rubber), kg/m^3.
SILICONE_DENSITY = 1070.0


def fingertip_mass_properties(
    geometry: FingertipGeometry,
    shell_density: float = ALUMINIUM_DENSITY,
    skin_density: float = SILICONE_DENSITY,
) -> tuple[float, tuple[float, float, float]]:
    """Mass and centre of mass of the fingertip below the sensor, from its shape.

    The shell is taken solid (a cylinder from the sensor face to the hemisphere's centre,
    capped by the hemisphere); the skin covers both with ``skin_thickness``.

    Returns:
        (mass, kg; centre of mass, sensor frame, m).
    """
    r, big, length = geometry.shell_radius, geometry.outer_radius, geometry.cylinder_length
    # (mass, height of the centroid) of each solid; a hemispherical shell between radii a < b
    # has its centroid 3 (b^4 - a^4) / (8 (b^3 - a^3)) above the flat face.
    parts = [
        (shell_density * math.pi * r**2 * length, length / 2),
        (shell_density * 2 / 3 * math.pi * r**3, length + 3 * r / 8),
        (skin_density * math.pi * (big**2 - r**2) * length, length / 2),
        (
            skin_density * 2 / 3 * math.pi * (big**3 - r**3),
            length + 3 * (big**4 - r**4) / (8 * (big**3 - r**3)),
        ),
    ]
    mass = sum(m for m, _ in parts)
    return mass, (0.0, 0.0, sum(m * z for m, z in parts) / mass)


_FINGERTIP_MASS, _FINGERTIP_COM = fingertip_mass_properties(FingertipGeometry())

#: The sensor models a config can start from (:meth:`SensorConfig.preset`).
SENSOR_MODELS = ("realistic", "ideal")


@dataclass(frozen=True)
class SensorConfig:
    """A six-axis force/torque sensor with the fingertip mounted on it.

    The defaults are a NANO-class sensor (``docs/design.md`` 5.1 gives the figures and their
    sources) carrying the paper's fingertip. :meth:`ideal` is the sensor of the v1 ids:
    white noise only.

    Attributes:
        force_noise_std: per-axis Gaussian force noise of a reading, N; >= 0.
        moment_noise_std: per-axis Gaussian moment noise of a reading, N m; >= 0.
        force_bias: constant force offset, sensor frame, N.
        moment_bias: constant moment offset, sensor frame, N m.
        force_offset_std: per-axis std of the force offset drawn at every reset, N; >= 0.
        moment_offset_std: per-axis std of the moment offset drawn at every reset, N m; >= 0.
        force_drift: per-axis random walk of the force zero, N per sqrt(s); >= 0.
        moment_drift: per-axis random walk of the moment zero, N m per sqrt(s); >= 0.
        mass: mass of the fingertip below the sensor, kg; >= 0.
        center_of_mass: its centre of mass, sensor frame, m; inside the fingertip.
    """

    force_noise_std: float = 0.02
    moment_noise_std: float = 5e-4
    force_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    moment_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    force_offset_std: float = 0.5
    moment_offset_std: float = 0.005
    force_drift: float = 0.005
    moment_drift: float = 5e-5
    mass: float = _FINGERTIP_MASS
    center_of_mass: tuple[float, float, float] = _FINGERTIP_COM

    def __post_init__(self) -> None:
        check_number("sensor.force_noise_std", self.force_noise_std, 0.0, 10.0)
        check_number("sensor.moment_noise_std", self.moment_noise_std, 0.0, 1.0)
        for name, bound in (("force_bias", 100.0), ("moment_bias", 10.0)):
            object.__setattr__(
                self, name, check_vector(f"sensor.{name}", getattr(self, name), bound=bound)
            )
        check_number("sensor.force_offset_std", self.force_offset_std, 0.0, 100.0)
        check_number("sensor.moment_offset_std", self.moment_offset_std, 0.0, 10.0)
        check_number("sensor.force_drift", self.force_drift, 0.0, 10.0)
        check_number("sensor.moment_drift", self.moment_drift, 0.0, 1.0)
        check_number("sensor.mass", self.mass, 0.0, 10.0)
        com = check_vector("sensor.center_of_mass", self.center_of_mass, bound=1.0)
        geometry = FingertipGeometry()
        if com[2] < 0.0 or geometry.signed_distance(np.array(com)) > 1e-12:
            raise ValueError(
                f"sensor.center_of_mass must lie inside the fingertip (z >= 0, within"
                f" {geometry.outer_radius:g} m of its axis and its hemisphere's centre),"
                f" got {list(com)}"
            )
        object.__setattr__(self, "center_of_mass", com)

    @classmethod
    def ideal(cls, **changes) -> SensorConfig:
        """Today's v1 sensor: white noise only, no offset, drift or fingertip weight."""
        zero = {"force_offset_std": 0.0, "moment_offset_std": 0.0, "force_drift": 0.0}
        zero.update(moment_drift=0.0, mass=0.0, center_of_mass=(0.0, 0.0, 0.0))
        return cls(**{**zero, **changes})

    @classmethod
    def preset(cls, model: str, **changes) -> SensorConfig:
        """The sensor of a model in ``SENSOR_MODELS`` with some fields changed."""
        if model not in SENSOR_MODELS:
            raise ValueError(f"sensor_model must be one of {SENSOR_MODELS}, got {model!r}")
        return cls.ideal(**changes) if model == "ideal" else cls(**changes)


def gravity_wrench(
    rotation: np.ndarray, mass: float, center_of_mass: np.ndarray | tuple
) -> np.ndarray:
    """The fingertip's weight as the sensor reads it at a pose.

    Args:
        rotation: (3, 3) fingertip rotation, sensor to world.
        mass: kg.
        center_of_mass: (3,) sensor frame, m.

    Returns:
        (6,) force (the weight, world -z, turned into the sensor frame), N, and its moment
        about the sensor origin (``center_of_mass x force``), N m.
    """
    # R^T (0, 0, -m g) is the last row of R times -m g; on floats, as ``rotation.T @ ...``
    # and ``np.cross`` compute it (a sensor reading costs a few of these per control step).
    weight = -mass * GRAVITY
    r = np.asarray(rotation)[2].tolist()
    force = (r[0] * weight, r[1] * weight, r[2] * weight)
    return np.array([*force, *cross(np.asarray(center_of_mass).tolist(), force)])


class SensorErrors:
    """What a simulated reading adds to the contact wrench, over one episode.

    :meth:`reset` draws the episode's offset; each :meth:`read` walks the drift on by one
    sample ``period`` (the sensor is read once per control step), adds the fingertip's weight
    at the pose, the bias, offset, drift and fresh white noise. Every draw comes from the
    ``rng`` passed in; an :meth:`SensorConfig.ideal` sensor draws exactly the noise.

    Args:
        config: the sensor.
        period: time between two readings, s.
    """

    def __init__(self, config: SensorConfig, period: float) -> None:
        self.config = config
        self.period = check_number("period", period, 0.0, 10.0, low_open=True)
        c = config
        self._bias = np.concatenate([c.force_bias, c.moment_bias])
        self._noise = np.repeat([c.force_noise_std, c.moment_noise_std], 3)
        self._offset_std = np.repeat([c.force_offset_std, c.moment_offset_std], 3)
        self._drift_std = np.repeat([c.force_drift, c.moment_drift], 3) * math.sqrt(period)
        self._drifts = bool(np.any(self._drift_std > 0.0))
        self._com = np.asarray(c.center_of_mass)
        self.offset = np.zeros(6)
        self.drift = np.zeros(6)

    def reset(self, rng: np.random.Generator) -> None:
        """A new episode: a fresh offset (none for a sensor without one), no drift yet."""
        self.drift = np.zeros(6)
        if np.any(self._offset_std > 0.0):
            self.offset = rng.standard_normal(6) * self._offset_std
        else:
            self.offset = np.zeros(6)

    def read(
        self,
        wrench: np.ndarray,
        rotation: np.ndarray,
        rng: np.random.Generator,
        samples: int = 1,
    ) -> np.ndarray:
        """A reading: (6,) sensor frame, N and N m.

        Args:
            wrench: (6,) the true contact wrench, sensor frame.
            rotation: (3, 3) the fingertip's rotation, sensor to world.
            rng: the only source of randomness.
            samples: sensor samples averaged within the period (white noise / sqrt(n)).
        """
        check_int("samples", samples, 1, 100_000)
        noise = rng.standard_normal(6) * (self._noise / math.sqrt(samples))
        if self._drifts:
            self.drift = self.drift + rng.standard_normal(6) * self._drift_std
        load = wrench
        if self.config.mass > 0.0:
            load = load + gravity_wrench(rotation, self.config.mass, self._com)
        return load + noise + self._bias + self.offset + self.drift


class Tare:
    """Zeroing the sensor as a robot does: an unloaded reading, then gravity compensation.

    :meth:`take` stores a reading taken in free air (the mean of n readings, while holding
    still) with the commanded rotation it was taken at. :meth:`compensate` then removes it,
    and the change of the fingertip's weight between that rotation and the current commanded
    one (from the configured mass and centre of mass). Before the first tare only the weight
    is removed. Nothing here knows whether the skin touches: a tare taken while touching
    subtracts the contact too, and every later reading carries that error until the next tare
    (``docs/design.md`` 5.1).

    Args:
        mass: the fingertip's mass below the sensor, kg.
        center_of_mass: its centre of mass, sensor frame, m.
    """

    def __init__(self, mass: float, center_of_mass) -> None:
        self.mass = check_number("mass", mass, 0.0, 10.0)
        self.center_of_mass = np.array(check_vector("center_of_mass", center_of_mass, bound=1.0))
        self.reading = np.zeros(6)
        self.load = np.zeros(6)
        self.taken = False

    @classmethod
    def of(cls, config: SensorConfig) -> Tare:
        """A tare for a sensor's configured fingertip."""
        return cls(config.mass, config.center_of_mass)

    def gravity(self, rotation: np.ndarray) -> np.ndarray:
        """(6,) the fingertip's weight as read at a commanded rotation (sensor to world)."""
        return gravity_wrench(rotation, self.mass, self.center_of_mass)

    def take(self, readings: np.ndarray, rotation: np.ndarray) -> None:
        """Tare on readings taken in free air at a commanded rotation.

        Args:
            readings: (6,) one reading or (n, 6) readings taken holding still, sensor frame.
            rotation: (3, 3) the commanded rotation they were taken at, sensor to world.
        """
        readings = np.asarray(readings, dtype=float)
        if readings.shape[-1:] != (6,) or readings.ndim not in (1, 2) or readings.size == 0:
            raise ValueError(f"readings must have shape (6,) or (n, 6), got {readings.shape}")
        if not np.all(np.isfinite(readings)):
            raise ValueError("readings must be finite")
        self.reading = readings if readings.ndim == 1 else readings.mean(axis=0)
        self.load = self.gravity(rotation)
        self.taken = True

    def compensate(self, reading: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """(6,) a reading, tared and gravity-compensated, at the commanded rotation."""
        return reading - self.reading - (self.gravity(rotation) - self.load)
