"""The six-axis force/torque sensor under the fingertip: its noise and bias.

The one place the sensor-noise defaults are written: the simulator draws its readings with
them and ``estimate_contact`` predicts its errors with them.

Conventions (``docs/design.md``, "Frames and units"): SI units (newtons, newton-metres);
biases in the sensor frame (origin at the F/T sensor, z along the finger axis). NumPy only, so
real robots can reuse it.
"""

from __future__ import annotations

from dataclasses import dataclass

from tactile_gym.validation import check_number, check_vector

__all__ = ["SensorConfig"]


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
