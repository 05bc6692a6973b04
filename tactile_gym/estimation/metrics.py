"""Error of a joint-axis estimate against the truth (docs/design.md 6.7).

World frame, metres, radians.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import AxisEstimate

__all__ = ["axis_error", "axis_nees"]


def _vec3(value: object, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be a finite (3,) vector, got {value!r}")
    return v


def _true_axis(true_point: object, true_direction: object) -> tuple[np.ndarray, np.ndarray]:
    """Validated (point, unit direction) of the true axis."""
    p = _vec3(true_point, "true_point")
    u = _vec3(true_direction, "true_direction")
    norm = float(np.linalg.norm(u))
    if norm == 0.0:
        raise ValueError("true_direction must be non-zero")
    return p, u / norm


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
    p, u = _true_axis(true_point, true_direction)
    ref = p if reference_point is None else _vec3(reference_point, "reference_point")
    ref = p + ((ref - p) @ u) * u
    if estimate is None or estimate.degenerate:
        return math.inf, math.pi / 2
    position = float(estimate.distance_to(ref))
    cos = min(abs(float(estimate.direction @ u)), 1.0)
    # arctan2 of |cross| and |dot| stays accurate for tiny angles, where arccos does not.
    sin = float(np.linalg.norm(np.cross(estimate.direction, u)))
    return position, math.atan2(sin, cos)


def axis_nees(
    estimate: AxisEstimate | None,
    true_point: np.ndarray,
    true_direction: np.ndarray,
    reference_point: np.ndarray | None = None,
) -> tuple[float, float, float]:
    """Normalised estimation error squared of an axis estimate against the truth.

    The errors are taken in a basis (b1, b2) normal to the estimated direction d: of the
    direction, ``d - s u`` (s the sign that aligns the true direction u with d), and of the
    position, the estimated axis' crossing of the plane normal to d through the reference
    point minus the true axis' crossing of that plane. Each is weighed by the matching block
    of ``covariance`` carried to that plane (the position's covariance there includes the
    direction's, times the distance along the axis from the estimate's ``point``). For a
    consistent estimator their means are 4, 2 and 2 (chi-square degrees of freedom). The
    joint NEES does not depend on the reference point; the position's does.

    Args:
        estimate: the estimate, with a covariance.
        true_point: (3,) any point on the true axis, world frame, m.
        true_direction: (3,) true axis direction (any length > 0, any sign).
        reference_point: (3,) where the position error is taken, e.g. the true hinge pin's
            centre (where :func:`axis_error` takes it), m. Defaults to the estimate's
            ``point``.

    Returns:
        ``(joint, position, direction)``: the NEES of all four errors and of each pair.
        ``(inf, inf, inf)`` for None, a degenerate estimate or one without covariance. A
        direction the fit held fixed (zero variance: the planar fits) scores 0 when it is
        exact and inf otherwise, and the joint NEES is then the position's plus that.

    Raises:
        ValueError: on malformed truth vectors, or a true axis parallel to the estimate's
            normal plane.
    """
    p, u = _true_axis(true_point, true_direction)
    ref = None if reference_point is None else _vec3(reference_point, "reference_point")
    if estimate is None or estimate.degenerate or estimate.covariance is None:
        return math.inf, math.inf, math.inf
    d = estimate.direction
    along = float(u @ d)
    if abs(along) < 1e-12:
        raise ValueError(f"true_direction must not be normal to the estimate's, got {u.tolist()}")
    b = np.linalg.svd(d[None, :])[2][1:].T  # (3, 2) orthonormal, normal to d
    basis = np.zeros((6, 4))
    basis[:3, :2] = basis[3:, 2:] = b
    point = estimate.point
    if ref is not None:
        # The estimated axis at the reference's plane; as d turns by dd it moves by s dd.
        lever = float((ref - point) @ d)
        point = point + lever * d
        basis[3:, :2] = lever * b
    crossing = p + ((point - p) @ d) / along * u
    err = b.T @ np.concatenate(
        [(point - crossing)[:, None], (d - math.copysign(1.0, along) * u)[:, None]], axis=1
    )
    err = err.T.ravel()
    cov = basis.T @ estimate.covariance[:6, :6] @ basis
    position = float(err[:2] @ np.linalg.solve(cov[:2, :2], err[:2]))
    if not cov[2:, 2:].any():
        # A direction held fixed (the planar fits): right or infinitely wrong.
        direction = 0.0 if not err[2:].any() else math.inf
        return position + direction, position, direction
    return (
        float(err @ np.linalg.solve(cov, err)),
        position,
        float(err[2:] @ np.linalg.solve(cov[2:, 2:], err[2:])),
    )
