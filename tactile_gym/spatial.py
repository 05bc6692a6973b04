"""Rotations and undirected line directions: the one place the package writes them.

NumPy only (no pybullet, no scipy), so that ``tactile_gym.sensing`` and
``tactile_gym.estimation`` can use it on a real robot.

Conventions:

* Angles in radians.
* A rotation matrix ``R`` maps a vector from a body frame into the reference frame:
  ``x_ref = R @ x_body``. Its columns are the body axes in the reference frame.
* Quaternions are ``(x, y, z, w)`` (PyBullet's and scipy's order) and unit length. Functions
  that return one return the representative with ``w >= 0``.
* A rotation vector ``v`` turns by ``|v|`` about ``v / |v|`` (right-hand rule).
* Composition: ``R_a @ R_b`` applies ``R_b`` first. ``rotvec_to_matrix(v) @ R`` turns the frame
  ``R`` by ``v`` expressed in the reference frame.

Undirected lines (the edge of an object has no preferred sign) are oriented by
:func:`orient_like`: every part of the package that needs a sign for an edge calls it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "SIGN_LOOKBACK",
    "checked_point",
    "checked_rotation",
    "matrix_to_quaternion",
    "matrix_to_rotvec",
    "orient_edges",
    "orient_like",
    "quaternion_to_matrix",
    "rotation_z",
    "rotvec_to_matrix",
    "z_to",
]

#: How many previous edges :func:`orient_edges` compares a new edge with.
SIGN_LOOKBACK = 3


def quaternion_to_matrix(q) -> np.ndarray:
    """3x3 rotation matrix of a quaternion ``(x, y, z, w)`` (normalised here)."""
    x, y, z, w = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quaternion(r) -> np.ndarray:
    """Unit quaternion ``(x, y, z, w)`` of a 3x3 rotation matrix, with ``w >= 0``."""
    m = np.asarray(r, dtype=float)
    t = float(np.trace(m))
    if t > 0:
        s = 2.0 * math.sqrt(t + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i] = s / 4
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
    q = np.asarray(q)
    q = q / np.linalg.norm(q)
    return -q if q[3] < 0 else q


def rotvec_to_matrix(v) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues' formula)."""
    v = np.asarray(v, dtype=float)
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return np.eye(3)
    k = v / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)


def matrix_to_rotvec(r) -> np.ndarray:
    """Rotation vector of a rotation matrix, angle in [0, pi]."""
    q = matrix_to_quaternion(r)
    s = float(np.linalg.norm(q[:3]))
    if s < 1e-12:
        return np.zeros(3)
    return q[:3] / s * 2.0 * math.atan2(s, q[3])


def rotation_z(angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the z axis."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def z_to(direction) -> np.ndarray:
    """The smallest rotation that turns +z onto ``direction`` (any length > 0)."""
    d = np.asarray(direction, dtype=float)
    norm = float(np.linalg.norm(d))
    if not (d.shape == (3,) and math.isfinite(norm) and norm > 0.0):
        raise ValueError(f"direction must be a finite non-zero 3-vector, got {direction!r}")
    d = d / norm
    axis = np.array([-d[1], d[0], 0.0])  # z x d
    sin_angle = float(np.linalg.norm(axis))
    angle = math.atan2(sin_angle, float(d[2]))
    if sin_angle < 1e-12:
        return np.eye(3) if d[2] > 0 else rotvec_to_matrix([math.pi, 0.0, 0.0])
    return rotvec_to_matrix(axis / sin_angle * angle)


def _flips(e: list[float], references: list[list[float]]) -> bool:
    """Whether ``e`` must flip to agree with its best-aligned reference (see orient_like)."""
    best = 0.0
    for r in references:
        dot = e[0] * r[0] + e[1] * r[1] + e[2] * r[2]
        if abs(dot) > abs(best):
            best = dot
    if best == 0.0:
        mags = [abs(v) for v in e]
        best = e[mags.index(max(mags))]
    return best < 0.0


def orient_like(edge, references) -> np.ndarray:
    """Sign an undirected line direction like the reference it is most nearly parallel to.

    Args:
        edge: (3,) direction (any length; returned with its length).
        references: (K, 3) directions already signed (any K >= 0), e.g. the last few edges.

    Returns:
        ``edge`` or ``-edge``: the one whose dot product with the best-aligned reference (the
        largest ``|dot|``) is positive. Comparing with the best-aligned of several references,
        not only the last one, keeps one wild edge from flipping every edge after it. With no
        reference, or none that is not perpendicular, the sign is canonical instead: the
        component of largest magnitude is made positive (ties go to the earlier component).
    """
    e = np.array(edge, dtype=float)
    refs = np.asarray(references, dtype=float).reshape(-1, 3).tolist()
    return -e if _flips(e.tolist(), refs) else e


def orient_edges(edges, lookback: int = SIGN_LOOKBACK) -> np.ndarray:
    """Sign a sequence of edges (N, 3) consistently: each as :func:`orient_like` signs it
    against the ``lookback`` edges before it (as already signed). The first edge keeps its
    sign."""
    e = np.array(edges, dtype=float)
    if e.ndim != 2 or e.shape[1] != 3:
        raise ValueError(f"edges must have shape (N, 3), got {e.shape}")
    if lookback < 1:
        raise ValueError(f"lookback must be >= 1, got {lookback!r}")
    rows = e.tolist()
    for i in range(1, len(rows)):
        if _flips(rows[i], rows[max(0, i - lookback) : i]):
            rows[i] = [-v for v in rows[i]]
            e[i] *= -1.0
    return e


def checked_rotation(value, name: str) -> np.ndarray:
    """A (3, 3) rotation matrix, sensor to world, from a matrix or a quaternion (x, y, z, w)."""
    r = np.asarray(value, dtype=float)
    if r.shape == (3, 3):
        # Scalar checks: this runs every control step, and NumPy's per-call cost would be
        # most of it. NaN and inf fail the comparisons.
        (a, b, c), (d, e, f), (g, h, i) = r.tolist()
        gram = (
            a * a + d * d + g * g - 1.0,
            b * b + e * e + h * h - 1.0,
            c * c + f * f + i * i - 1.0,
            a * b + d * e + g * h,
            a * c + d * f + g * i,
            b * c + e * f + h * i,
        )
        det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
        if not (all(abs(x) <= 1e-6 for x in gram) and det > 0.0):
            raise ValueError(f"{name} must be a rotation matrix (orthonormal, det +1), got {r}")
        return r
    length = float(np.linalg.norm(r)) if r.shape == (4,) else 0.0
    if not (math.isfinite(length) and length >= 1e-9):
        raise ValueError(
            f"{name} must be a (3, 3) rotation matrix or a finite non-zero quaternion "
            f"(x, y, z, w), got {r}"
        )
    return quaternion_to_matrix(r / length)


def checked_point(v, name: str) -> np.ndarray:
    """A point as 3 finite numbers (m, world frame), or a ``ValueError`` naming ``name``."""
    v = np.asarray(v, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be 3 finite numbers (m, world frame), got {v}")
    return v
