"""Analytic collision primitives for the skin: rounded boxes and the table plane.

Each primitive has a pose in the world frame (``center``, ``rotation`` whose columns are its
local axes) and a signed distance in its *local* frame (negative inside). The skin's kernels
(``tactile_gym/sim/_kernels.py``) evaluate nodes in the primitive's local frame; the functions
here serve the broad phase's set-up and tests. The signed distance tells whether a node is
inside; which surface presses it, and how deep, is the skin's business (near an edge it is
the face the node came through, not the nearest one: ``tactile_gym/sim/skin.py``). Units:
metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Plane", "RoundedBox", "rounded_box_sdf"]


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

    def world_aabb(self) -> tuple[np.ndarray, np.ndarray]:
        big = 1e9
        return np.array([-big, -big, -big]), np.array([big, big, self.height])

    def signed_distance_world(self, x: np.ndarray) -> np.ndarray:
        return np.atleast_2d(x)[:, 2] - self.height
