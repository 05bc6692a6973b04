"""The six-axis force/torque sensor under the fingertip: its noise and bias.

The one place the sensor-noise defaults are written: the simulator draws its readings with
them and ``estimate_contact`` predicts its errors with them.

Conventions (DESIGN.md section 4): SI units (newtons, newton-metres); biases in the sensor
frame (origin at the F/T sensor, z along the finger axis). NumPy only, so real robots can
reuse it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

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
        for name, unit in (("force_noise_std", "N"), ("moment_noise_std", "N m")):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0:
                raise ValueError(f"{name} must be a finite number >= 0 {unit}, got {value!r}")
        for name in ("force_bias", "moment_bias"):
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ValueError(f"{name} must be 3 finite numbers, got {getattr(self, name)!r}")
