"""Error of a joint-axis estimate against the truth (docs/design.md 6.7).

World frame, metres, radians.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import AxisEstimate

__all__ = ["axis_error"]


def _vec3(value: object, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be a finite (3,) vector, got {value!r}")
    return v


def axis_error(
    estimate: AxisEstimate | None,
    true_point: np.ndarray,
    true_direction: np.ndarray,
    reference_point: np.ndarray | None = None,
) -> tuple[float, float]:
    """Position and angle error of an estimated axis.

    Args:
        estimate: the estimate; None or a degenerate estimate count as a total miss.
        true_point: (3,) any point on the true axis, world frame, m.
        true_direction: (3,) true axis direction (any length > 0, any sign).
        reference_point: (3,) the true hinge pin's centre (the true axis point nearest the
            object), m. Defaults to ``true_point``. It is projected onto the true axis first.

    Returns:
        ``(position_m, angle_rad)``: the distance from the reference point to the estimated
        axis line, m, and the angle between the two directions ignoring sign, in
        [0, pi/2]. ``(inf, pi/2)`` for None or a degenerate estimate.

    Raises:
        ValueError: on malformed truth vectors (wrong shape, non-finite, zero direction).
    """
    p = _vec3(true_point, "true_point")
    u = _vec3(true_direction, "true_direction")
    norm = float(np.linalg.norm(u))
    if norm == 0.0:
        raise ValueError("true_direction must be non-zero")
    u = u / norm
    ref = p if reference_point is None else _vec3(reference_point, "reference_point")
    ref = p + ((ref - p) @ u) * u
    if estimate is None or estimate.degenerate:
        return math.inf, math.pi / 2
    position = float(estimate.distance_to(ref))
    cos = min(abs(float(estimate.direction @ u)), 1.0)
    # arctan2 of |cross| and |dot| stays accurate for tiny angles, where arccos does not.
    sin = float(np.linalg.norm(np.cross(estimate.direction, u)))
    return position, math.atan2(sin, cos)
