"""Hinged two-link objects built in a :class:`~tactile_gym.sim.world.World`.

Frames (see :class:`~tactile_gym.sim.config.ObjectConfig`):

* world: z up, table top at z = 0;
* hinge frame H: origin at the pin centre, z_H along the joint axis, x_H where the free link
  points at joint angle 0; fixed in the world (the fixed link's frame);
* free-link frame: H turned by the joint angle about z_H.

The object is one PyBullet multibody built with ``createMultiBody`` (no URDF file, and no
``createCollisionShapeArray``, which silently keeps only 16 children): a static base (the
fixed link, mass 0) and one revolute child (the free link). PyBullet collisions of the object
are switched off: the skin computes contact itself, and link-on-table friction would be an
uncontrolled second source of joint friction. The joint's holding friction is a
zero-velocity motor with a small max force (docs/design.md 3.3) plus viscous damping.
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from tactile_gym.sim import _pose_kernels
from tactile_gym.sim.config import ObjectConfig
from tactile_gym.sim.primitives import RoundedBox
from tactile_gym.sim.world import World
from tactile_gym.spatial import matrix_to_quaternion, rotation_z

__all__ = ["HingedObject"]


class HingedObject:
    """Two links and one revolute joint, from an :class:`ObjectConfig`.

    Args:
        world: the world to build in.
        config: geometry, joint and friction parameters.
        joint_angle: initial joint angle, rad.
    """

    def __init__(self, world: World, config: ObjectConfig, joint_angle: float = 0.0) -> None:
        self.world = world
        self.config = config
        self._cid = world.client_id
        cid = self._cid
        self.hinge_rotation = config.hinge_rotation()
        self.pin = np.asarray(config.joint_position, dtype=float)
        self.axis = self.hinge_rotation[:, 2].copy()
        free = np.asarray(config.free_link_size, dtype=float)
        fixed = np.asarray(config.fixed_link_size, dtype=float)
        self.free_half = free / 2.0
        self.fixed_half = fixed / 2.0
        # Box centres in their link frames (origin at the pin).
        self.free_center_local = np.array([free[0] / 2.0 - config.pin_overlap, 0.0, 0.0])
        self.fixed_center_local = np.array([-(fixed[0] / 2.0 - config.pin_overlap), 0.0, 0.0])

        def box(half: np.ndarray, center: np.ndarray, rgba: list[float]) -> tuple[int, int]:
            col = p.createCollisionShape(
                p.GEOM_BOX,
                halfExtents=half.tolist(),
                collisionFramePosition=center.tolist(),
                physicsClientId=cid,
            )
            vis = p.createVisualShape(
                p.GEOM_BOX,
                halfExtents=half.tolist(),
                visualFramePosition=center.tolist(),
                rgbaColor=rgba,
                physicsClientId=cid,
            )
            return col, vis

        col_fixed, vis_fixed = box(self.fixed_half, self.fixed_center_local, [0.3, 0.3, 0.35, 1])
        col_free, vis_free = box(self.free_half, self.free_center_local, [0.85, 0.25, 0.2, 1])
        self.body_id = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=col_fixed,
            baseVisualShapeIndex=vis_fixed,
            basePosition=self.pin.tolist(),
            baseOrientation=matrix_to_quaternion(self.hinge_rotation).tolist(),
            linkMasses=[config.free_link_mass],
            linkCollisionShapeIndices=[col_free],
            linkVisualShapeIndices=[vis_free],
            linkPositions=[[0.0, 0.0, 0.0]],
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]],
            linkInertialFramePositions=[self.free_center_local.tolist()],
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]],
            linkParentIndices=[0],
            linkJointTypes=[p.JOINT_REVOLUTE],
            linkJointAxis=[[0.0, 0.0, 1.0]],
            physicsClientId=cid,
        )
        for link in (-1, 0):
            p.setCollisionFilterGroupMask(self.body_id, link, 0, 0, physicsClientId=cid)
        p.changeDynamics(
            self.body_id,
            0,
            linearDamping=0.0,
            angularDamping=0.0,
            jointDamping=config.damping,
            jointLowerLimit=config.lower_limit,
            jointUpperLimit=config.upper_limit,
            physicsClientId=cid,
        )
        p.setJointMotorControl2(
            self.body_id,
            0,
            p.VELOCITY_CONTROL,
            targetVelocity=0.0,
            force=config.holding_torque,
            physicsClientId=cid,
        )
        self.free_box = RoundedBox(
            self.free_half,
            config.edge_radius,
            self.pin.copy(),
            self.hinge_rotation.copy(),
            body_id=self.body_id,
            link=0,
        )
        self.fixed_box = RoundedBox(
            self.fixed_half,
            config.edge_radius,
            self.pin + self.hinge_rotation @ self.fixed_center_local,
            self.hinge_rotation.copy(),
            body_id=self.body_id,
            link=-1,
        )
        #: (5, 3) the free link for the compiled kernels: ``hinge_rotation`` (rows 0-2), the
        #: pin, the free box's centre in the link frame (``_pose_kernels.link_pose``).
        self.link = np.concatenate([self.hinge_rotation, [self.pin, self.free_center_local]])
        #: (8,) the joint's dynamics for ``_step_kernels.hinge_step``: the link's inertia
        #: about the axis as PyBullet has it (its inertia about the centre of mass, which is
        #: the box's centre, plus m r^2), damping, holding torque, limits, weight.
        mass, _, inertia, com = p.getDynamicsInfo(self.body_id, 0, physicsClientId=cid)[:4]
        self.hinge = np.array(
            [
                inertia[2] + mass * (com[0] ** 2 + com[1] ** 2),
                config.damping,
                config.holding_torque,
                config.lower_limit,
                config.upper_limit,
                *(mass * np.asarray(world.gravity)),
            ]
        )
        self._angle = 0.0
        self._velocity = 0.0
        self.reset(joint_angle)

    # --- state -------------------------------------------------------------------------

    def reset(self, joint_angle: float) -> None:
        """Teleport the joint to ``joint_angle`` (rad) at rest."""
        lo, hi = self.config.lower_limit, self.config.upper_limit
        if not lo <= joint_angle <= hi:
            raise ValueError(f"joint_angle must be in [{lo}, {hi}] rad, got {joint_angle!r}")
        p.resetJointState(self.body_id, 0, float(joint_angle), 0.0, physicsClientId=self._cid)
        self.sync()

    def sync(self) -> None:
        """Read the joint state from PyBullet and update the free link's primitive."""
        self._angle, self._velocity = p.getJointState(self.body_id, 0, physicsClientId=self._cid)[
            :2
        ]
        # The pose the kernels give the free box at this angle, to the last bit.
        self._pose_free_box(_pose_kernels.link_pose(self.link, self._angle))

    def set_state(self, angle: float, velocity: float, pose: np.ndarray) -> None:
        """Take the joint's state from an integrator other than PyBullet's (the v3 step,
        ``docs/design.md`` 3.6) and hand it to PyBullet, so that its link is where the skin
        saw it (rendering, ``getLinkState``).

        Args:
            angle, velocity: rad, rad/s.
            pose: (4, 3) the free box's pose at ``angle`` (``_pose_kernels.link_pose``).
        """
        if angle == self._angle and velocity == self._velocity:
            return  # a held link: PyBullet and the free box have it already
        self._angle, self._velocity = angle, velocity
        p.resetJointState(self.body_id, 0, angle, velocity, physicsClientId=self._cid)
        self._pose_free_box(pose.copy())

    def _pose_free_box(self, pose: np.ndarray) -> None:
        self.free_box.rotation = pose[:3]
        self.free_box.center = pose[3]

    @property
    def joint_angle(self) -> float:
        """Joint angle, rad (0: free link along ``link_direction``)."""
        return float(self._angle)

    @property
    def joint_velocity(self) -> float:
        """Joint velocity, rad/s."""
        return float(self._velocity)

    @property
    def link_rotation(self) -> np.ndarray:
        """Free-link frame axes as columns, world frame."""
        return self.hinge_rotation @ rotation_z(self._angle)

    @property
    def true_axis(self) -> tuple[np.ndarray, np.ndarray]:
        """(pin centre point, unit axis direction), world frame."""
        return self.pin.copy(), self.axis.copy()

    @property
    def edge_line(self) -> tuple[np.ndarray, np.ndarray]:
        """Probed edge of the free link: (point, unit direction), world frame.

        The point is where the edge passes the pin's x_H = 0 plane; the line is the sharp
        corner of the top (+z_H) face and the ``edge_side`` face, ignoring the rounding.
        """
        r = self.link_rotation
        local = np.array([0.0, self.config.edge_side * self.free_half[1], self.free_half[2]])
        return self.pin + r @ local, r[:, 0].copy()

    @property
    def primitives(self) -> list[RoundedBox]:
        """The free and fixed links' rounded boxes, world frame (call ``sync`` first)."""
        return [self.free_box, self.fixed_box]

    def apply_wrench(self, force: np.ndarray, torque: np.ndarray) -> None:
        """Apply a force at the free link's COM and a torque, both world frame, for one step.

        PyBullet clears external forces after each ``stepSimulation``.
        """
        cid = self._cid
        p.applyExternalForce(
            self.body_id,
            0,
            force.tolist(),
            self.free_box.center.tolist(),
            p.WORLD_FRAME,
            physicsClientId=cid,
        )
        p.applyExternalTorque(self.body_id, 0, torque.tolist(), p.WORLD_FRAME, physicsClientId=cid)

    def remove(self) -> None:
        """Remove the body from the world (if still connected)."""
        if self.world.connected:
            p.removeBody(self.body_id, physicsClientId=self._cid)
