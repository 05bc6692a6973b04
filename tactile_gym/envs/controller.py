"""Maps normalised actions to fingertip pose targets (world frame, metres, radians).

An action ``a`` in [-1, 1]^6 asks for a translation ``a[:3] * max_translation`` along the
world axes and a rotation ``a[3:] * max_rotation`` given as a rotation vector in the world
frame. The rotation turns the fingertip about the centre of its hemisphere, so a pure rotation
rocks the tip in place rather than swinging it round the sensor. Orientations are rotation
matrices, sensor to world (``tactile_gym.spatial``'s conventions; ``docs/design.md`` 2, 7.6).
"""

from __future__ import annotations

import numpy as np

from tactile_gym.spatial import rotvec_to_matrix

__all__ = ["DeltaPoseController"]


class DeltaPoseController:
    """Turns a normalised 6-D action into the next fingertip pose target.

    Args:
        max_translation: translation for an action of 1 on one axis, m.
        max_rotation: rotation for an action of 1 on one axis, rad.
        pivot: the point the rotation turns about, in the sensor frame, m.
    """

    def __init__(self, max_translation: float, max_rotation: float, pivot: np.ndarray) -> None:
        self.max_translation = float(max_translation)
        self.max_rotation = float(max_rotation)
        self.pivot = np.asarray(pivot, dtype=float)

    def target(
        self, action: np.ndarray, position: np.ndarray, rotation: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pose target (position, m; (3, 3) rotation) after applying ``action`` to the pose.

        Args:
            action: (6,) normalised action.
            position: (3,) sensor origin, world frame, m.
            rotation: (3, 3) fingertip rotation, sensor to world.
        """
        translation = np.asarray(action[:3], dtype=float) * self.max_translation
        rotvec = np.asarray(action[3:6], dtype=float) * self.max_rotation
        pivot_world = position + rotation @ self.pivot
        arm = position - pivot_world
        if not rotvec.any():
            # No turn (``rotvec_to_matrix`` gives the identity, whose products change nothing).
            return pivot_world + arm + translation, rotation.copy()
        turn = rotvec_to_matrix(rotvec)
        return pivot_world + turn @ arm + translation, turn @ rotation
