"""Analytic collision primitives for the skin: rounded boxes and the table plane.

Each primitive has a pose in the world frame (``center``, ``rotation`` whose columns are its
local axes) and a signed distance in its *local* frame (negative inside). The skin evaluates
nodes in the primitive's local frame, so one 3x3 matrix product per primitive moves all nodes
there. Units: metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Plane", "RoundedBox", "rounded_box_distance", "rounded_box_sdf"]


def rounded_box_sdf(
    x: np.ndarray, half_extents: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance and outward unit normal of a box with rounded edges.

    Args:
        x: (N, 3) points in the box frame (box centred at the origin), m.
        half_extents: (3,) half sizes of the box including the rounding, m.
        radius: rounding radius of every edge and corner, m.

    Returns:
        (d, n): (N,) signed distances (negative inside), m; (N, 3) outward normals, box frame.
    """
    s = np.where(x < 0.0, -1.0, 1.0)
    q = np.abs(x) - (half_extents - radius)
    qp = np.maximum(q, 0.0)
    outer = np.sqrt(np.einsum("ij,ij->i", qp, qp))
    k = np.argmax(q, axis=1)
    qmax = q[np.arange(len(q)), k]
    d = outer + np.minimum(qmax, 0.0) - radius
    n = np.zeros_like(x)
    n[np.arange(len(q)), k] = 1.0
    has_outer = outer > 1e-12
    n[has_outer] = qp[has_outer] / outer[has_outer, None]
    return d, n * s


def rounded_box_distance(x: np.ndarray, inner_half: np.ndarray, radius: float) -> np.ndarray:
    """Signed distance only (faster than ``rounded_box_sdf``); ``inner_half`` = half - radius.

    Args:
        x: (N, 3) points in the box frame, m; not modified.
        inner_half: (3,) half extents minus the rounding radius, m.
        radius: rounding radius, m.
    """
    q = np.abs(x)
    q -= inner_half
    qmax = q.max(axis=1)
    np.maximum(q, 0.0, out=q)
    d = np.sqrt(np.einsum("ij,ij->i", q, q))
    d += np.minimum(qmax, 0.0)
    d -= radius
    return d


def rounded_box_distance_soa(x: np.ndarray, inner_half: np.ndarray, radius: float) -> np.ndarray:
    """``rounded_box_distance`` for points stored as columns: x is (3, N), box frame."""
    q = np.abs(x)
    q -= inner_half[:, None]
    qmax = np.maximum(np.maximum(q[0], q[1]), q[2])
    np.maximum(q, 0.0, out=q)
    q *= q
    d = np.sqrt(q.sum(axis=0))
    d += np.minimum(qmax, 0.0)
    d -= radius
    return d


def rounded_box_normal_soa(x: np.ndarray, inner_half: np.ndarray) -> np.ndarray:
    """Outward unit normals (3, N) of a rounded box at points (3, N) in the box frame.

    Outside the inner box the normal points from its nearest point; inside it, along the
    axis of the nearest face.
    """
    q = np.abs(x)
    q -= inner_half[:, None]
    qp = np.maximum(q, 0.0)
    outer = np.sqrt((qp * qp).sum(axis=0))
    face = (q == np.maximum(np.maximum(q[0], q[1]), q[2])).astype(float)
    rounded = outer > 1e-12
    n = np.where(rounded, qp / np.where(rounded, outer, 1.0), face)
    return np.copysign(n, x)


@dataclass
class RoundedBox:
    """A box with rounded edges, posed in the world frame.

    Attributes:
        half_extents: (3,) half sizes, box frame, m.
        radius: edge rounding, m.
        center: (3,) box centre, world frame, m.
        rotation: (3, 3) box axes as columns, world frame.
        body: index of the body this primitive belongs to (the scene's convention).
    """

    half_extents: np.ndarray
    radius: float
    center: np.ndarray
    rotation: np.ndarray
    body: int = 0

    def __post_init__(self) -> None:
        self.half_extents = np.asarray(self.half_extents, dtype=float)
        self.inner_half = self.half_extents - self.radius

    def local_sdf(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance and normal for (N, 3) points in the box frame."""
        return rounded_box_sdf(x, self.half_extents, self.radius)

    def local_distance(self, x: np.ndarray) -> np.ndarray:
        """Signed distance for (3, N) points (columns) in the box frame, m."""
        return rounded_box_distance_soa(x, self.inner_half, self.radius)

    def local_normal(self, x: np.ndarray) -> np.ndarray:
        """Outward unit normals (3, N) at (3, N) points in the box frame."""
        return rounded_box_normal_soa(x, self.inner_half)

    def world_aabb(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box in the world frame: (lower, upper), m."""
        ext = np.abs(self.rotation) @ self.half_extents
        return self.center - ext, self.center + ext

    def signed_distance_world(self, x: np.ndarray) -> np.ndarray:
        """Signed distance of (N, 3) world points, m."""
        d, _ = self.local_sdf((np.atleast_2d(x) - self.center) @ self.rotation)
        return d


@dataclass
class Plane:
    """The half-space z <= height of the world frame (the table)."""

    height: float = 0.0
    body: int = 2

    # The local frame is the world frame (the height enters the distance), so the skin's
    # stick-slip anchors on the table are world points.
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def local_sdf(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (height above the plane) and normal for (N, 3) local points."""
        n = np.zeros_like(x)
        n[:, 2] = 1.0
        return x[:, 2] - self.height, n

    def local_distance(self, x: np.ndarray) -> np.ndarray:
        """Signed distance for (3, N) local points (columns), m."""
        return x[2] - self.height

    def local_normal(self, x: np.ndarray) -> np.ndarray:
        """Outward unit normals (3, N): +z."""
        n = np.zeros_like(x)
        n[2] = 1.0
        return n

    def world_aabb(self) -> tuple[np.ndarray, np.ndarray]:
        big = 1e9
        return np.array([-big, -big, -big]), np.array([big, big, self.height])

    def signed_distance_world(self, x: np.ndarray) -> np.ndarray:
        return np.atleast_2d(x)[:, 2] - self.height
