"""The probing scene: table, hinged object, soft fingertip on an F/T sensor.

Frames (docs/design.md 2):

* world: z up, table top at z = 0; object poses, the true axis, the edge line, the fingertip
  pose and the contact centroid are in the world frame;
* sensor: origin at the F/T sensor, z along the finger axis, hemisphere centre at
  (0, 0, L); the wrench is in the sensor frame, moments about the sensor origin.

The fingertip pose (position, quaternion x y z w) maps the sensor frame to the world frame:
x_world = R(q) x_sensor + position.

Each physics step: the skin forces are computed at the fingertip's new pose against
the current object pose (:mod:`tactile_gym.sim.skin`), their reaction is applied to the free
link with ``applyExternalForce``/``applyExternalTorque`` (world frame; PyBullet clears them
after every ``stepSimulation``), then PyBullet steps the rigid bodies. The table and the fixed
link are static. The fingertip is kinematic, like the paper's coordinate-measuring machine:
it moves at constant velocity toward the commanded pose over the substeps (speed-limited), and
a guarded move refuses any substep that would raise |f| above ``force_limit`` by advancing
into the object; retreating is always allowed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from tactile_gym.sensing import FingertipGeometry, SensorConfig, SensorErrors
from tactile_gym.sim.config import ObjectConfig, SkinConfig
from tactile_gym.sim.objects import FREE_BODY, HingedObject
from tactile_gym.sim.primitives import Plane
from tactile_gym.sim.skin import Contact, SoftSkin
from tactile_gym.sim.world import SUBSTEPS, TIME_STEP, World
from tactile_gym.spatial import (
    matrix_to_quaternion,
    matrix_to_rotvec,
    quaternion_to_matrix,
    rotvec_to_matrix,
)

__all__ = ["FORCE_LIMIT", "ProbeScene", "StepInfo"]

#: Default guarded-move limit on |f|, N.
FORCE_LIMIT = 8.0


@dataclass(frozen=True)
class StepInfo:
    """What happened during one control step.

    Attributes:
        force_limited: the guarded move held the fingertip back at least once.
        shell_contact: some node's penetration exceeded the skin thickness (the object
            reached the rigid shell; forces are then underestimated).
        max_penetration: largest node penetration over the substeps, m.
        n_active_nodes: nodes in contact after the last substep.
        max_force: largest |f| over the substeps, N.
    """

    force_limited: bool
    shell_contact: bool
    max_penetration: float
    n_active_nodes: int
    max_force: float


def _unit_quaternion(q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-9:
        raise ValueError(f"orientation must be a finite non-zero quaternion (x, y, z, w), got {q}")
    return q / np.linalg.norm(q)


def _point(v, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be 3 finite numbers (m, world frame), got {v}")
    return v


class ProbeScene:
    """A soft fingertip probing a hinged object on a table.

    Args:
        object_config: the hinged object.
        skin_config: skin stiffness, friction, node spacing.
        sensor_config: the F/T sensor (default ``SensorConfig.ideal()``: white noise only;
            the env and the Table I protocol choose theirs).
        geometry: fingertip shape.
        time_step: physics step, s.
        substeps: physics steps per ``control_step``.
        force_limit: guarded-move limit on |f|, N.
        gui: open the PyBullet GUI.
        max_speed: fingertip speed limit, m/s.
        max_angular_speed: fingertip angular speed limit, rad/s.
    """

    def __init__(
        self,
        object_config: ObjectConfig,
        skin_config: SkinConfig = SkinConfig(),  # noqa: B008 - frozen dataclasses
        sensor_config: SensorConfig = SensorConfig.ideal(),  # noqa: B008
        geometry: FingertipGeometry = FingertipGeometry(),  # noqa: B008
        *,
        time_step: float = TIME_STEP,
        substeps: int = SUBSTEPS,
        force_limit: float = FORCE_LIMIT,
        gui: bool = False,
        max_speed: float = 0.25,
        max_angular_speed: float = 3.0,
    ) -> None:
        if not force_limit > 0:
            raise ValueError(f"force_limit must be > 0 N, got {force_limit!r}")
        if not (max_speed > 0 and max_angular_speed > 0):
            raise ValueError("max_speed (m/s) and max_angular_speed (rad/s) must be > 0")
        self._world = World(time_step=time_step, substeps=substeps, gui=gui)
        self._object_config = object_config
        self._skin_config = skin_config
        self._sensor_config = sensor_config
        self._geometry = geometry
        self.force_limit = float(force_limit)
        self.max_speed = float(max_speed)
        self.max_angular_speed = float(max_angular_speed)
        # At rest at angle 0, or at the nearest limit for joints whose range excludes 0.
        rest = float(np.clip(0.0, object_config.lower_limit, object_config.upper_limit))
        self._object = HingedObject(self._world, object_config, rest)
        self._table = Plane(0.0)
        self._skin = SoftSkin(geometry, skin_config)
        self._sensor = SensorErrors(sensor_config, time_step * substeps)
        self._pos = np.array([0.0, 0.0, 0.2])
        self._rot = np.eye(3)
        self._fingertip_visual = self._make_fingertip_visual()
        self._closed = False
        self.last_reaction: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._free_reach = float(
            np.linalg.norm(np.abs(self._object.free_center_local) + self._object.free_half)
        )

    # --- construction ----------------------------------------------------------------------

    def _make_fingertip_visual(self) -> int:
        g = self._geometry
        cid = self._world.client_id
        r, length = g.outer_radius, g.cylinder_length
        vis = p.createVisualShapeArray(
            shapeTypes=[p.GEOM_CYLINDER, p.GEOM_SPHERE],
            radii=[r, r],
            lengths=[length, 0.0],
            visualFramePositions=[[0, 0, length / 2], [0, 0, length]],
            rgbaColors=[[0.9, 0.85, 0.6, 1.0], [0.9, 0.85, 0.6, 1.0]],
            physicsClientId=cid,
        )
        # No collision shape: the visual body never takes part in PyBullet contacts.
        return p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=-1,
            baseVisualShapeIndex=vis,
            basePosition=self._pos.tolist(),
            physicsClientId=cid,
        )

    def _primitives(self) -> list:
        return [self._object.free_box, self._object.fixed_box, self._table]

    # --- episode -------------------------------------------------------------------------

    def reset(
        self,
        joint_angle: float,
        fingertip_position,
        fingertip_orientation,
        object_config: ObjectConfig | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        """Set the joint angle and teleport the fingertip; clears the skin state.

        Args:
            joint_angle: rad.
            fingertip_position: (3,) sensor origin, world frame, m.
            fingertip_orientation: (4,) quaternion x y z w, sensor to world.
            object_config: rebuild the object from this config if it differs.
            rng: a new episode of the sensor: draw its offset with it (None: keep the state,
                as when the hand moves the object mid-trial).
        """
        self._check_open()
        pos = _point(fingertip_position, "fingertip_position")
        quat = _unit_quaternion(fingertip_orientation)
        if object_config is not None and object_config != self._object_config:
            self._object.remove()
            self._object = HingedObject(self._world, object_config, float(joint_angle))
            self._object_config = object_config
            self._free_reach = float(
                np.linalg.norm(np.abs(self._object.free_center_local) + self._object.free_half)
            )
        self._object.reset(float(joint_angle))
        self._pos = pos
        self._rot = quaternion_to_matrix(quat)
        self._skin.reset()
        if rng is not None:
            self._sensor.reset(rng)
        prims = self._primitives()
        sel = self._skin.select(prims, self._rot, self._pos, 0.0)
        contact = self._skin.evaluate(sel, prims, self._rot, self._pos, self.time_step)
        self._skin.commit(contact)

    def control_step(self, target_position, target_orientation) -> StepInfo:
        """Move the fingertip toward a target pose over ``substeps`` physics steps.

        Args:
            target_position: (3,) sensor origin target, world frame, m.
            target_orientation: (4,) quaternion x y z w target, sensor to world.

        Returns:
            StepInfo for the substeps.
        """
        self._check_open()
        target = _point(target_position, "target_position")
        r_target = quaternion_to_matrix(_unit_quaternion(target_orientation))
        n = self._world.substeps
        dt = self._world.time_step
        horizon = n * dt

        dp = target - self._pos
        dist = float(np.linalg.norm(dp))
        if dist > self.max_speed * horizon:
            dp *= self.max_speed * horizon / dist
            dist = self.max_speed * horizon
        rv = matrix_to_rotvec(r_target @ self._rot.T)
        ang = float(np.linalg.norm(rv))
        if ang > self.max_angular_speed * horizon:
            rv *= self.max_angular_speed * horizon / ang
            ang = self.max_angular_speed * horizon
        step_p = dp / n
        step_r = rotvec_to_matrix(rv / n)
        moving_rot = ang > 0.0

        obj = self._object
        skin = self._skin
        prims = self._primitives()
        reach_obj = self._free_reach
        obj.sync()
        # Bound on any node's displacement per substep (translation + rotation x lever).
        step_len = float(np.linalg.norm(step_p)) + ang / n * skin.reach + 1e-9
        obj_budget = abs(obj.joint_velocity) * horizon * reach_obj + 1e-3
        sel = skin.select(prims, self._rot, self._pos, n * step_len + obj_budget)
        q_sel = obj.joint_angle
        tip_moved = 0.0

        limited = shell = False
        max_pen = max_force = 0.0
        f_prev = skin.contact.force_norm
        limit = self.force_limit
        cid = self._world.client_id
        body = obj.body_id
        for k in range(n):
            if not len(sel.nodes):
                # Nothing within reach: skip the skin until the motion could close the gap.
                angle = p.getJointState(body, 0, physicsClientId=cid)[0]
                if tip_moved + step_len + abs(angle - q_sel) * reach_obj < sel.reach:
                    if skin.contact.n_active:
                        skin.commit(skin.evaluate(sel, prims, self._rot, self._pos, dt))
                    self._pos = self._pos + step_p
                    if moving_rot:
                        self._rot = step_r @ self._rot
                    tip_moved += step_len
                    self.last_reaction = None
                    self._world.step()
                    f_prev = 0.0
                    continue
            if k:
                obj.sync()
            moved = tip_moved + step_len + abs(obj.joint_angle - q_sel) * reach_obj
            if moved >= sel.reach:
                # Moved further than the broad phase allowed for (the link sped up): select
                # again for what is left of this control step.
                obj_budget = abs(obj.joint_velocity) * (n - k) * dt * reach_obj + 1e-3
                sel = skin.select(prims, self._rot, self._pos, (n - k) * step_len + obj_budget)
                q_sel = obj.joint_angle
                tip_moved = 0.0
                moved = step_len
            pos_new = self._pos + step_p
            rot_new = step_r @ self._rot if moving_rot else self._rot
            contact = skin.evaluate(sel, prims, rot_new, pos_new, dt, moved)
            f_new = contact.force_norm
            if f_new > limit and f_new > f_prev:
                limited = True
                # Keep the sideways part of the translation and only the fraction of the
                # advancing part that linear interpolation puts at the limit; no rotation.
                f_dir = self._rot @ contact.wrench[:3] / f_new
                push = min(float(step_p @ f_dir), 0.0)
                frac = 0.9 * max(0.0, (limit - f_prev) / (f_new - f_prev))
                pos_new = self._pos + step_p - (1.0 - frac) * push * f_dir
                rot_new = self._rot
                contact = skin.evaluate(sel, prims, rot_new, pos_new, dt, moved)
                f_new = contact.force_norm
                if f_new > limit and f_new > f_prev:
                    pos_new = self._pos
                    contact = skin.evaluate(sel, prims, rot_new, pos_new, dt, moved)
                    f_new = contact.force_norm
            skin.commit(contact)
            if rot_new is self._rot:
                tip_moved += float(np.linalg.norm(pos_new - self._pos))
            else:
                tip_moved += step_len
            self._pos, self._rot = pos_new, rot_new
            self._apply_reaction(contact)
            self._world.step()
            f_prev = f_new
            max_pen = max(max_pen, contact.max_penetration)
            shell = shell or contact.shell_contact
            max_force = max(max_force, f_new)
        obj.sync()
        return StepInfo(
            force_limited=limited,
            shell_contact=shell,
            max_penetration=max_pen,
            n_active_nodes=skin.contact.n_active,
            max_force=max_force,
        )

    def _apply_reaction(self, contact: Contact) -> None:
        reaction = contact.reaction(FREE_BODY)
        if reaction is None:
            self.last_reaction = None
            return
        force, torque = reaction
        com = self._object.free_box.center.copy()
        self._object.apply_wrench(force, torque)
        #: (force, torque about the COM, COM) last applied to the free link, world frame.
        self.last_reaction = (force, torque, com)

    # --- sensing -------------------------------------------------------------------------

    def read_wrench(self, rng: np.random.Generator, samples: int = 1) -> np.ndarray:
        """F/T reading [fx, fy, fz, mx, my, mz], sensor frame, N and N m: the contact wrench
        plus the fingertip's weight, bias, offset, drift and noise (``SensorErrors``; one
        reading per control step).

        Args:
            rng: the only source of randomness (the env's ``np_random``).
            samples: sensor samples averaged within the control period (a tare's).
        """
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        return self._sensor.read(self.true_wrench, self._rot, rng, samples)

    @property
    def true_wrench(self) -> np.ndarray:
        """Noise-free wrench on the skin: (6,) force, N, and moment about the sensor origin,
        N m, sensor frame."""
        return self._skin.contact.wrench.copy()

    @property
    def contact(self) -> Contact:
        """The skin's last contact (per-node detail, for tests and diagnostics)."""
        return self._skin.contact

    @property
    def skin(self) -> SoftSkin:
        return self._skin

    @property
    def object(self) -> HingedObject:
        return self._object

    @property
    def world(self) -> World:
        return self._world

    # --- poses and ground truth ----------------------------------------------------------

    @property
    def fingertip_position(self) -> np.ndarray:
        """(3,) sensor origin, world frame, m."""
        return self._pos.copy()

    @property
    def fingertip_orientation(self) -> np.ndarray:
        """(4,) quaternion x y z w, sensor to world."""
        return matrix_to_quaternion(self._rot)

    @property
    def fingertip_rotation(self) -> np.ndarray:
        """(3, 3) rotation, sensor to world."""
        return self._rot.copy()

    def sensor_to_world_point(self, points) -> np.ndarray:
        """Points (3,) or (N, 3) from the sensor frame to the world frame, m."""
        return np.asarray(points, dtype=float) @ self._rot.T + self._pos

    def sensor_to_world_vector(self, vectors) -> np.ndarray:
        """Directions (3,) or (N, 3) from the sensor frame to the world frame."""
        return np.asarray(vectors, dtype=float) @ self._rot.T

    def world_to_sensor_point(self, points) -> np.ndarray:
        """Points (3,) or (N, 3) from the world frame to the sensor frame, m."""
        return (np.asarray(points, dtype=float) - self._pos) @ self._rot

    def world_to_sensor_vector(self, vectors) -> np.ndarray:
        """Directions (3,) or (N, 3) from the world frame to the sensor frame."""
        return np.asarray(vectors, dtype=float) @ self._rot

    @property
    def joint_angle(self) -> float:
        """Joint angle of the free link, rad."""
        return self._object.joint_angle

    @property
    def true_axis(self) -> tuple[np.ndarray, np.ndarray]:
        """(hinge pin centre, unit axis direction), world frame."""
        return self._object.true_axis

    @property
    def edge_line(self) -> tuple[np.ndarray, np.ndarray]:
        """Probed edge of the free link: (point, unit direction), world frame."""
        return self._object.edge_line

    @property
    def contact_centroid(self) -> np.ndarray | None:
        """Normal-force-weighted centroid of the contact points (deformed skin, on the
        object surface), world frame, m; None without contact."""
        c = self._skin.contact
        if not c.n_active:
            return None
        w = c.pressure * self._skin.areas[c.nodes]
        if w.sum() <= 0:
            w = np.ones_like(w)
        pts = self.sensor_to_world_point(c.points_sensor())
        return (w[:, None] * pts).sum(0) / w.sum()

    # --- plain attributes ----------------------------------------------------------------

    @property
    def object_config(self) -> ObjectConfig:
        return self._object_config

    @property
    def skin_config(self) -> SkinConfig:
        return self._skin_config

    @property
    def sensor_config(self) -> SensorConfig:
        return self._sensor_config

    @property
    def geometry(self) -> FingertipGeometry:
        return self._geometry

    @property
    def time_step(self) -> float:
        return self._world.time_step

    @property
    def substeps(self) -> int:
        return self._world.substeps

    # --- rendering and teardown ----------------------------------------------------------

    def render(self, width: int = 320, height: int = 240) -> np.ndarray:
        """RGB image (height, width, 3), uint8, from a camera looking at the object."""
        self._check_open()
        cid = self._world.client_id
        p.resetBasePositionAndOrientation(
            self._fingertip_visual,
            self._pos.tolist(),
            self.fingertip_orientation.tolist(),
            physicsClientId=cid,
        )
        target = self._object.pin + 0.5 * (self._object.free_box.center - self._object.pin)
        view = p.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=target.tolist(),
            distance=0.3,
            yaw=30.0,
            pitch=-40.0,
            roll=0.0,
            upAxisIndex=2,
            physicsClientId=cid,
        )
        proj = p.computeProjectionMatrixFOV(
            fov=50.0, aspect=width / height, nearVal=0.01, farVal=2.0, physicsClientId=cid
        )
        _, _, rgba, _, _ = p.getCameraImage(
            width, height, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=cid
        )
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this ProbeScene is closed")

    def close(self) -> None:
        """Disconnect the physics client; safe to call more than once."""
        if self._closed:
            return
        self._closed = True
        self._world.close()

    def __enter__(self) -> ProbeScene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
