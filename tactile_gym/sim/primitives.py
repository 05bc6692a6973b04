"""Analytic collision primitives for the skin: rounded boxes and the table plane.

Each primitive has a pose in the world frame (``center``, ``rotation`` whose columns are its
local axes) and a signed distance in its *local* frame (negative inside). The skin's kernels
(``tactile_gym/sim/_kernels.py``) evaluate nodes in the primitive's local frame; the functions
here serve tests (the kernels restate them). The signed distance tells whether a node is
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
        body_id: PyBullet id of the body it belongs to (-1: none, a shape on its own).
        link: the body's link it belongs to (-1: the base).
    """

    half_extents: np.ndarray
    radius: float
    center: np.ndarray
    rotation: np.ndarray
    body_id: int = -1
    link: int = -1

    def __post_init__(self) -> None:
        self.half_extents = np.asarray(self.half_extents, dtype=float)
        self.inner_half = self.half_extents - self.radius

    def local_sdf(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance and normal for (N, 3) points in the box frame."""
        return rounded_box_sdf(x, self.half_extents, self.radius)


@dataclass
class Plane:
    """The half-space z <= height of the world frame (the table).

    Attributes:
        height: the table top's z, world frame, m.
        body_id: PyBullet id of the table's body (-1: none).
        link: -1, the table body's base.
    """

    height: float = 0.0
    body_id: int = -1
    link: int = -1

    # The local frame is the world frame (the height enters the distance), so the skin's
    # stick-slip anchors on the table are world points.
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def local_sdf(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (height above the plane) and normal for (N, 3) local points."""
        n = np.zeros_like(x)
        n[:, 2] = 1.0
        return x[:, 2] - self.height, n
