"""What a user knows about the joint axis before touching anything: the reset distribution.

The env's estimate at reset, and the baseline of its reward, is this prior: the mean hinge pin
and axis direction of the env's own reset distribution, with their spread. It is computed by
drawing scenarios from a fixed-seed generator at construction, so it follows the families,
ranges and overrides the env was made with, and it never looks at the episode's truth.

World frame, metres, radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.estimation import AxisEstimate
from tactile_gym.estimation.axis import canonical_direction, closest_point_to_origin

__all__ = ["AxisPrior", "prior_from_samples"]


@dataclass(frozen=True)
class AxisPrior:
    """A Gaussian-like summary of where the axis may be.

    Attributes:
        pin: (3,) mean hinge-pin centre, m.
        pin_cov: (3, 3) covariance of the pin centre, m^2.
        direction: (3,) mean axis direction (unit, canonical sign).
        angle_std: RMS angle between the axis directions and ``direction``, rad.
    """

    pin: np.ndarray
    pin_cov: np.ndarray
    direction: np.ndarray
    angle_std: float

    def estimate(self) -> AxisEstimate:
        """The prior as an axis estimate (the mean axis, with the spread as its stds)."""
        u = self.direction
        perp = np.eye(3) - np.outer(u, u)
        position_std = float(np.sqrt(max(np.trace(perp @ self.pin_cov @ perp), 0.0)))
        return AxisEstimate(
            point=closest_point_to_origin(self.pin, u),
            direction=u.copy(),
            distance=float("nan"),
            covariance=None,
            position_std=position_std,
            angle_std=self.angle_std,
            residual_rms=float("nan"),
            n_used=0,
            degenerate=False,
            condition_number=float("inf"),
            method="prior",
        )


def prior_from_samples(pins: np.ndarray, directions: np.ndarray) -> AxisPrior:
    """Summarise sampled axes (pins (N, 3), directions (N, 3), any sign) as an AxisPrior."""
    pins = np.asarray(pins, dtype=float)
    dirs = np.asarray(directions, dtype=float)
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    # Directions are lines: sign them like the principal direction before averaging.
    _, _, vt = np.linalg.svd(dirs, full_matrices=False)
    reference = vt[0]
    dirs = np.where((dirs @ reference < 0)[:, None], -dirs, dirs)
    mean, _ = canonical_direction(dirs.mean(axis=0) / np.linalg.norm(dirs.mean(axis=0)))
    cos = np.clip(np.abs(dirs @ mean), -1.0, 1.0)
    angle_std = float(np.sqrt(np.mean(np.arccos(cos) ** 2)))
    pin_cov = np.cov(pins.T) if len(pins) > 1 else np.zeros((3, 3))
    return AxisPrior(pins.mean(axis=0), pin_cov, mean, angle_std)
