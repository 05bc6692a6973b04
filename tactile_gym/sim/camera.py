"""A pinhole camera that frames a box, with PyBullet's view and projection matrices.

``ProbeScene.render`` frames the probed region with it (``docs/design.md`` 7.10) and
``tactile_gym.envs.render`` projects world points with the same matrices PyBullet rendered
with, so that overlays land on the pixels of what they mark.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Camera", "frame_box"]

#: Unit vector from the framed box's centre toward the camera: in front of the scissors'
#: link (world -y), a little to its tip side (+x), 50 deg above the table.
VIEW_DIRECTION = np.array([0.25, -0.6, 0.95]) / np.linalg.norm([0.25, -0.6, 0.95])
#: Vertical field of view, deg.
FOV = 40.0
#: Fraction of the half-width and half-height the framed box may fill.
FILL = 0.9
NEAR = 0.01


@dataclass(frozen=True, eq=False)
class Camera:
    """A camera of ``width`` x ``height`` pixels.

    Attributes:
        view, projection: 4x4 matrices (world to eye, eye to clip), acting on column vectors.
        width, height: image size, pixels.
        target: the point the camera looks at (the framed box's centre), world, m.
        radius: half the framed box's diagonal, m (a length scale for overlays).
    """

    view: np.ndarray
    projection: np.ndarray
    width: int
    height: int
    target: np.ndarray
    radius: float

    @property
    def view_list(self) -> list[float]:
        """The view matrix as PyBullet takes it (16 floats, column-major)."""
        return self.view.T.reshape(-1).tolist()

    @property
    def projection_list(self) -> list[float]:
        """The projection matrix as PyBullet takes it (16 floats, column-major)."""
        return self.projection.T.reshape(-1).tolist()

    def project(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates of world points.

        Args:
            points: (3,) or (N, 3), world, m.

        Returns:
            (N, 2) pixel coordinates (x right, y down; pixel centres at integers + 0.5) and
            (N,) whether each point is in front of the near plane (the others' pixels are
            meaningless).
        """
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        clip = np.c_[pts, np.ones(len(pts))] @ (self.projection @ self.view).T
        w = clip[:, 3]
        in_front = w > NEAR
        safe = np.where(in_front, w, 1.0)
        x = (clip[:, 0] / safe + 1.0) * 0.5 * self.width
        y = (1.0 - clip[:, 1] / safe) * 0.5 * self.height
        return np.c_[x, y], in_front


def frame_box(lo, hi, width: int, height: int) -> Camera:
    """The camera, looking along ``-VIEW_DIRECTION`` at the box's centre, from the distance at
    which the box's corners fill ``FILL`` of the image.

    Args:
        lo, hi: (3,) opposite corners of an axis-aligned box, world, m.
        width, height: image size, pixels.
    """
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    target = 0.5 * (lo + hi)
    back = VIEW_DIRECTION
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    corners = np.array(np.meshgrid(*zip(lo, hi))).reshape(3, -1).T
    rel = corners - target
    tan_v = np.tan(np.radians(FOV) / 2.0) * FILL
    tan_h = tan_v * width / height
    # A corner at (x, y, z) in camera axes (z toward the camera) is at depth distance - z;
    # it fits when |x| <= (distance - z) tan_h and |y| <= (distance - z) tan_v.
    z = rel @ back
    need = np.maximum(np.abs(rel @ right) / tan_h, np.abs(rel @ up) / tan_v) + z
    distance = max(float(need.max()), 2.0 * NEAR + float(z.max()))
    eye = target + distance * back
    view = np.eye(4)
    view[:3, :3] = np.array([right, up, back])
    view[:3, 3] = -view[:3, :3] @ eye
    far = distance + 2.0 * float(np.linalg.norm(hi - lo)) + 1.0
    f = 1.0 / np.tan(np.radians(FOV) / 2.0)
    projection = np.array(
        [
            [f * height / width, 0.0, 0.0, 0.0],
            [0.0, f, 0.0, 0.0],
            [0.0, 0.0, (far + NEAR) / (NEAR - far), 2.0 * far * NEAR / (NEAR - far)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    return Camera(view, projection, int(width), int(height), target, radius)
