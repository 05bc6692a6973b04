"""The six-axis force/torque sensor under the fingertip: its noise, its bias, and a touch.

The one place the sensor-noise defaults are written: the simulator draws its readings with
them and ``estimate_contact`` predicts its errors with them. ``TOUCH_FORCE`` is the one
threshold at which a reading counts as a touch, for the sensing, the gate, the press and the
skills alike, with ``RELEASE_FORCE`` its hysteresis (``docs/design.md`` 5).

Conventions (``docs/design.md``, "Frames and units"): SI units (newtons, newton-metres);
biases in the sensor frame (origin at the F/T sensor, z along the finger axis). NumPy only, so
real robots can reuse it.
"""

from __future__ import annotations

from dataclasses import dataclass

from tactile_gym.validation import check_number, check_vector

__all__ = ["RELEASE_FORCE", "TOUCH_FORCE", "SensorConfig"]

#: |f| of a reading, N, at or above which the skin counts as touching: 10 standard deviations
#: of the default per-axis force noise, so noise alone (|f| about 0.035 N) never reads as one.
TOUCH_FORCE = 0.2
#: |f|, N, below which a touch has ended: half of ``TOUCH_FORCE`` (hysteresis), so that a lift
#: leaves the skin unloaded before the next press, and a reading that hovers at the threshold
#: does not end a touch and start another.
RELEASE_FORCE = 0.5 * TOUCH_FORCE


@dataclass(frozen=True)
class SensorConfig:
    """Six-axis force/torque sensor noise and bias.

    The noise is typical of a Nano17-class sensor (ATI Nano17 resolution ~1/320 N and
    ~1/64 N mm; the paper used a BL AUTOTEC NANO 5/4 of similar class), taken a few times
    larger to cover drift and electrical noise.

    Attributes:
        force_noise_std: per-axis Gaussian force noise, N; >= 0.
        moment_noise_std: per-axis Gaussian moment noise, N m; >= 0.
        force_bias: constant force offset, sensor frame, N.
        moment_bias: constant moment offset, sensor frame, N m.
    """

    force_noise_std: float = 0.02
    moment_noise_std: float = 5e-4
    force_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    moment_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        check_number("sensor.force_noise_std", self.force_noise_std, 0.0, 10.0)
        check_number("sensor.moment_noise_std", self.moment_noise_std, 0.0, 1.0)
        for name, bound in (("force_bias", 100.0), ("moment_bias", 10.0)):
            object.__setattr__(
                self, name, check_vector(f"sensor.{name}", getattr(self, name), bound=bound)
            )
