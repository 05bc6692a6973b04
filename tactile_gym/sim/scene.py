"""The probing scene: table, jointed object, soft fingertip on an F/T sensor.

Frames (docs/design.md 2):

* world: z up, table top at z = 0; object poses, the true axis, the edge line, the fingertip
  pose and the contact centroid are in the world frame;
* sensor: origin at the F/T sensor, z along the finger axis, hemisphere centre at
  (0, 0, L); the wrench is in the sensor frame, moments about the sensor origin.

The fingertip pose is a rotation matrix R (sensor to world) and a position inside:
x_world = R x_sensor + position. Targets may be given as a (3, 3) rotation or a quaternion
(x, y, z, w); quaternions appear only at that boundary and in ``fingertip_orientation``.

Each physics step: the skin forces are computed at the fingertip's new pose against
the current object pose (:mod:`tactile_gym.sim.skin`), their reaction is applied to the free
link with ``applyExternalForce``/``applyExternalTorque`` (world frame; PyBullet clears them
after every ``stepSimulation``), then PyBullet steps the rigid bodies. The skin's part of a
substep is one compiled call; a substep in which the broad phase proves that no node can
reach anything is the physics alone (docs/design.md 3.5). The table and the fixed
link are static. The fingertip is kinematic, like the paper's coordinate-measuring machine:
it moves at constant velocity toward the commanded pose over the substeps (speed-limited), and
a guarded move refuses any substep that would raise |f| above ``force_limit`` by advancing
into the object; retreating is always allowed.

That is the v2 step (``physics="v2"``, the default). The v3 step (``physics="v3"``,
docs/design.md 3.6) runs a control step's substeps in one compiled call that integrates the
hinge too, keeps its broad phase across control steps, and skips substeps that would repeat
the one before; it is held to bounds against the v2 step, not to its bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from tactile_gym.sensing import FingertipGeometry, SensorConfig, SensorErrors
from tactile_gym.sim import _pose_kernels, _step_kernels
from tactile_gym.sim.camera import Camera, frame_box
from tactile_gym.sim.config import ObjectConfig, SkinConfig
from tactile_gym.sim.objects import HingedObject
from tactile_gym.sim.primitives import Plane
from tactile_gym.sim.skin import SoftSkin
from tactile_gym.sim.skin_contact import Contact, Selection
from tactile_gym.sim.world import SUBSTEPS, TIME_STEP, World
from tactile_gym.spatial import (
    checked_point,
    checked_rotation,
    matrix_to_quaternion,
    matrix_to_rotvec,
    rotvec_to_matrix,
)
from tactile_gym.validation import check_choice
from tactile_gym.vec3 import norm

__all__ = ["FORCE_LIMIT", "PHYSICS", "ProbeScene", "StepInfo"]

#: Default guarded-move limit on |f|, N.
FORCE_LIMIT = 8.0
#: The contact steps (docs/design.md 3.5, 3.6): "v2", PyBullet integrates the hinge and the
#: broad phase is made afresh every control step in contact (the v1 and v2 ids' physics, kept
#: to the bit); "v3", one compiled call per control step integrates the hinge too and keeps
#: the broad phase while the motion stays within its reach.
PHYSICS = ("v2", "v3")
_IDENTITY = np.eye(3)
#: Least reach of a v3 broad phase beyond its margin, m: a press that moves less than this
#: keeps its broad phase (the evaluation takes only the candidates within the motion so far).
LEAN_REACH = 0.002
#: Fingertip motion of a v3 control step below which the fingertip stays where it is, m: the
#: rounding of the last steps toward a target would otherwise move it by an ulp or so every
#: control step, and a still fingertip lets the step skip the skin (docs/design.md 3.6).
LEAN_STILL = 1e-12
#: Motion since a v3 broad phase was made beyond which it is made afresh from its own
#: candidates before the next control step (``SoftSkin.narrow``), m.
LEAN_NARROW = 1e-4


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
        skin_substeps: substeps that evaluated the skin (the rest were the physics alone:
            nothing within reach, or, in the v3 step, nothing moved since an evaluation that
            left the skin as it was, docs/design.md 3.6).
    """

    force_limited: bool
    shell_contact: bool
    max_penetration: float
    n_active_nodes: int
    max_force: float
    skin_substeps: int


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
        physics: the contact step, one of ``PHYSICS``: ``"v2"`` (the default; the v1 and v2
            ids' outputs to the bit) or ``"v3"`` (the lean step, docs/design.md 3.6).
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
        physics: str = "v2",
    ) -> None:
        check_choice("physics", physics, PHYSICS)
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
        self.physics = physics
        # At rest at angle 0, or at the nearest limit for joints whose range excludes 0.
        rest = float(np.clip(0.0, object_config.lower_limit, object_config.upper_limit))
        self._object = HingedObject(self._world, object_config, rest)
        self._table = Plane(0.0, body_id=self._world.table_id)
        self._skin = SoftSkin(geometry, skin_config)
        self._sensor = SensorErrors(sensor_config, time_step * substeps)
        # Fingertip pose, sensor to world: rotation (rows 0-2), then position (row 3).
        self._pose = np.zeros((4, 3))
        self._pose[:3] = np.eye(3)
        self._pose[3] = [0.0, 0.0, 0.2]
        self._motion = np.zeros((4, 3))  # per-substep rotation and translation
        self._orientation_key = b""  # the rotation ``_orientation`` was converted from
        self._orientation = np.zeros(4)
        self._reaction = np.zeros((3, 3))  # on the free link: force, torque, centre
        # The v3 step's joint state (angle, velocity), the free box's pose and statistics.
        self._joint = np.zeros(2)
        self._link_pose = np.zeros((4, 3))
        self._stats = np.zeros(_step_kernels.STATS_COLS)
        self._fingertip_visual = self._make_fingertip_visual()
        self._closed = False
        self.last_reaction: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._use_object()

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
            basePosition=self._pose[3].tolist(),
            physicsClientId=cid,
        )

    def _use_object(self) -> None:
        """Primitives, free link and broad-phase state for the current object."""
        obj = self._object
        self._prims = [*obj.primitives, self._table]
        # The free link is the one primitive that moves, and takes the skin's reaction.
        self._free = next(i for i, prim in enumerate(self._prims) if prim is obj.free_box)
        self._link = obj.link
        self._free_reach = obj.reach
        self._selection: Selection | None = None
        self._tip_moved = 0.0  # bound on node motion since the selection, m
        self._q_sel = 0.0  # joint angle at the selection, rad
        self._link_row = -1  # the free link's row in the selection

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
            fingertip_orientation: (3, 3) rotation or (4,) quaternion x y z w, sensor to
                world.
            object_config: rebuild the object from this config if it differs.
            rng: a new episode of the sensor: draw its offset with it (None: keep the state,
                as when the hand moves the object mid-trial).
        """
        self._check_open()
        pos = checked_point(fingertip_position, "fingertip_position")
        rot = checked_rotation(fingertip_orientation, "fingertip_orientation")
        if object_config is not None and object_config != self._object_config:
            self._object.remove()
            self._object = HingedObject(self._world, object_config, float(joint_angle))
            self._object_config = object_config
        self._use_object()
        self._object.reset(float(joint_angle))
        self._joint[:] = (self._object.joint_angle, 0.0)
        self._pose[:3] = rot
        self._pose[3] = pos
        self._skin.reset()
        if rng is not None:
            self._sensor.reset(rng)
        prims = self._prims
        sel = self._skin.select(prims, rot, pos, 0.0)
        contact = self._skin.evaluate(sel, prims, rot, pos, self.time_step)
        self._skin.commit(contact)

    def control_step(self, target_position, target_orientation) -> StepInfo:
        """Move the fingertip toward a target pose over ``substeps`` physics steps.

        Each substep is one compiled call (``SoftSkin.substep``: the fingertip's motion, the
        guarded move, the skin and its commit), the reaction on the free link, and PyBullet's
        ``stepSimulation``. While the broad phase proves that no node can reach any
        primitive, a substep is the physics alone (docs/design.md 3.5).

        Args:
            target_position: (3,) sensor origin target, world frame, m.
            target_orientation: (3, 3) rotation or (4,) quaternion x y z w target, sensor
                to world.

        Returns:
            StepInfo for the substeps.
        """
        self._check_open()
        target = checked_point(target_position, "target_position")
        r_target = checked_rotation(target_orientation, "target_orientation")
        n = self._world.substeps
        dt = self._world.time_step
        horizon = n * dt
        pose = self._pose

        dp = target - pose[3]
        dist = norm(dp)
        if dist > self.max_speed * horizon:
            dp *= self.max_speed * horizon / dist
            dist = self.max_speed * horizon
        motion = self._motion
        motion[3] = dp / n
        ang = 0.0
        if (r_target == pose[:3]).all():
            # No turn. (The rotation vector of R R^T would be exactly 0: NumPy's product is
            # symmetric to the bit.)
            motion[:3] = _IDENTITY
        else:
            rv = matrix_to_rotvec(r_target @ pose[:3].T)
            ang = norm(rv)
            if ang > self.max_angular_speed * horizon:
                rv *= self.max_angular_speed * horizon / ang
                ang = self.max_angular_speed * horizon
            motion[:3] = rotvec_to_matrix(rv / n)
        turning = ang > 0.0
        if self.physics == "v3":
            return self._lean_step(motion, turning, norm(motion[3]) + ang / n * self._skin.reach)

        obj = self._object
        skin = self._skin
        reach_obj = self._free_reach
        obj.sync()
        angle = obj.joint_angle
        # Bound on any node's displacement per substep (translation + rotation x lever).
        step_len = norm(motion[3]) + ang / n * skin.reach + 1e-9
        obj_budget = abs(obj.joint_velocity) * horizon * reach_obj + 1e-3
        # An empty broad phase of an earlier step still holds while it covers this step's
        # motion too (no node has a history to keep: the next selection records the frames).
        # A non-empty one is selected afresh: the order of its candidates sets the order of
        # the force sums (docs/design.md 3.5).
        sel = self._selection
        if (
            sel is None
            or len(sel.nodes)
            or self._tip_moved + abs(angle - self._q_sel) * reach_obj + n * step_len + obj_budget
            >= sel.reach
        ):
            sel = self._select(n * step_len + obj_budget, angle)

        limited = shell = False
        max_pen = max_force = 0.0
        limit = self.force_limit
        cid = self._world.client_id
        body = obj.body_id
        reaction = self._reaction
        pushed = False
        pending = 0  # free-air substeps whose motion is not yet applied to ``pose``
        evaluated = 0
        for k in range(n):
            if k:
                angle = p.getJointState(body, 0, physicsClientId=cid)[0]
            moved = self._tip_moved + step_len + abs(angle - self._q_sel) * reach_obj
            if not len(sel.nodes) and moved < sel.reach:
                # Nothing within reach: the physics alone until the motion could close the gap.
                if skin.n_active:
                    skin.release()
                pending += 1
                self._tip_moved += step_len
                pushed = False
                p.stepSimulation(physicsClientId=cid)
                continue
            if pending:
                _pose_kernels.advance(pose, motion, turning, pending)
                pending = 0
            if moved >= sel.reach:
                # Moved further than the broad phase allowed for (the link sped up): select
                # again for what is left of this control step.
                obj.sync()
                obj_budget = abs(obj.joint_velocity) * (n - k) * dt * reach_obj + 1e-3
                sel = self._select((n - k) * step_len + obj_budget, angle)
                moved = step_len
            evaluated += 1
            step_limited, travelled, pushed, pen, step_shell, force = skin.substep(
                sel,
                pose,
                motion,
                turning,
                step_len,
                moved,
                self._link,
                self._link_row,
                angle,
                limit,
                dt,
                reaction,
            )
            self._tip_moved += travelled
            limited = limited or step_limited
            if pushed:
                on_link, torque, centre = reaction.tolist()
                p.applyExternalForce(body, 0, on_link, centre, p.WORLD_FRAME, physicsClientId=cid)
                p.applyExternalTorque(body, 0, torque, p.WORLD_FRAME, physicsClientId=cid)
            p.stepSimulation(physicsClientId=cid)
            max_pen = max(max_pen, pen)
            shell = shell or step_shell
            max_force = max(max_force, force)
        if pending:
            _pose_kernels.advance(pose, motion, turning, pending)
        #: (force, torque about the COM, COM) last applied to the free link, world frame.
        self.last_reaction = (
            (reaction[0].copy(), reaction[1].copy(), reaction[2].copy()) if pushed else None
        )
        obj.sync()
        return StepInfo(
            force_limited=limited,
            shell_contact=bool(shell),
            max_penetration=max_pen,
            n_active_nodes=skin.n_active,
            max_force=max_force,
            skin_substeps=evaluated,
        )

    def _lean_step(self, motion: np.ndarray, turning: bool, step_len: float) -> StepInfo:
        """The v3 control step (docs/design.md 3.6): the substeps in one compiled call
        (``_step_kernels.control_step``), which integrates the hinge too; PyBullet's joint
        is set to the result once. The broad phase is kept while the motion bound since it
        was made stays below its reach, with or without candidates."""
        n = self._world.substeps
        dt = self._world.time_step
        obj = self._object
        skin = self._skin
        joint = self._joint
        reach_obj = self._free_reach
        if not turning and step_len * n < LEAN_STILL:
            # Held still: a target a few ulps off is not chased, so the substeps can see that
            # nothing moves.
            motion[3] = 0.0
            step_len = 0.0
        step_len += 1e-9
        stats = self._stats
        stats.fill(0.0)
        sel = self._selection
        done = 0
        while done < n:
            left = n - done
            angle, velocity = joint.tolist()  # Python floats: NumPy scalars cost 10x per op
            budget = abs(velocity) * left * dt * reach_obj + 1e-3
            need = left * step_len + budget
            moved = self._tip_moved + abs(angle - self._q_sel) * reach_obj
            if sel is None or moved + need >= sel.reach:
                sel = self._select(max(need, LEAN_REACH), angle)
            elif moved > LEAN_NARROW and len(sel.nodes):
                # What the motion so far has brought within reach of the candidates: the
                # evaluations take every candidate within that motion of its primitives.
                sel = self._narrow(sel, sel.reach - moved, angle)
            stats[_step_kernels.TIP_MOVED] = self._tip_moved
            ran = skin.run(
                sel,
                self._pose,
                motion,
                turning,
                step_len,
                left,
                self._link,
                self._link_row,
                obj.hinge,
                joint,
                self._link_pose,
                self._q_sel,
                reach_obj,
                self.force_limit,
                dt,
                self._reaction,
                stats,
            )
            self._tip_moved = float(stats[_step_kernels.TIP_MOVED])
            done += ran
            if ran < left:
                # The link sped up past the bound: select again for the rest, with the link
                # where it is now.
                obj.set_state(*joint.tolist(), self._link_pose)
                sel = None
        obj.set_state(*joint.tolist(), self._link_pose)
        k = _step_kernels
        out = stats.tolist()
        reaction = self._reaction
        self.last_reaction = (
            (reaction[0].copy(), reaction[1].copy(), reaction[2].copy()) if out[k.PUSHED] else None
        )
        return StepInfo(
            force_limited=bool(out[k.LIMITED]),
            shell_contact=bool(out[k.SHELL]),
            max_penetration=out[k.MAX_PEN],
            n_active_nodes=skin.n_active,
            max_force=out[k.MAX_FORCE],
            skin_substeps=int(out[k.EVALUATED]),
        )

    def _narrow(self, selection: Selection, reach: float, angle: float) -> Selection:
        """The broad phase made afresh from ``selection``'s candidates (``SoftSkin.narrow``),
        at the committed pose and joint ``angle`` (the free link's primitive is posed there)."""
        sel = self._skin.narrow(selection, self._prims, self._pose[:3], self._pose[3], reach)
        self._selection = sel
        self._tip_moved = 0.0
        self._q_sel = angle
        return sel

    def _select(self, motion_bound: float, angle: float) -> Selection:
        """Broad phase at the committed pose; the free link's primitive as the object has it."""
        prims = self._prims
        sel = self._skin.select(prims, self._pose[:3], self._pose[3], motion_bound)
        self._selection = sel
        self._tip_moved = 0.0
        self._q_sel = angle
        self._link_row = sel.prims.index(self._free) if self._free in sel.prims else -1
        return sel

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
        return self._sensor.read(self.true_wrench, self._pose[:3], rng, samples)

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
    def fingertip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(position, rotation): ``fingertip_position`` and ``fingertip_rotation``."""
        return self.fingertip_position, self.fingertip_rotation

    @property
    def fingertip_position(self) -> np.ndarray:
        """(3,) sensor origin, world frame, m."""
        return self._pose[3].copy()

    @property
    def fingertip_orientation(self) -> np.ndarray:
        """(4,) quaternion x y z w, sensor to world."""
        # Converted again only when the rotation changed: the observation reads it every
        # control step, and most steps do not turn the fingertip.
        key = self._pose[:3].tobytes()
        if key != self._orientation_key:
            self._orientation = matrix_to_quaternion(self._pose[:3])
            self._orientation_key = key
        return self._orientation.copy()

    @property
    def fingertip_rotation(self) -> np.ndarray:
        """(3, 3) rotation, sensor to world."""
        return self._pose[:3].copy()

    def sensor_to_world_point(self, points) -> np.ndarray:
        """Points (3,) or (N, 3) from the sensor frame to the world frame, m."""
        return np.asarray(points, dtype=float) @ self._pose[:3].T + self._pose[3]

    def sensor_to_world_vector(self, vectors) -> np.ndarray:
        """Directions (3,) or (N, 3) from the sensor frame to the world frame."""
        return np.asarray(vectors, dtype=float) @ self._pose[:3].T

    def world_to_sensor_vector(self, vectors) -> np.ndarray:
        """Directions (3,) or (N, 3) from the world frame to the sensor frame."""
        return np.asarray(vectors, dtype=float) @ self._pose[:3]

    @property
    def joint_angle(self) -> float:
        """Joint coordinate of the free link: its angle, rad, or a slide's travel, m."""
        return self._object.joint_angle

    @property
    def true_joint_type(self) -> str:
        """The object's joint: ``"revolute"``, ``"prismatic"`` or ``"fixed"``."""
        return self._object.joint_type

    @property
    def true_axis(self) -> tuple[np.ndarray, np.ndarray]:
        """(hinge pin centre, unit axis direction), world frame; fresh copies. A slide's are
        its reference point and direction of travel (``true_joint_type``)."""
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

    def render(self, width: int, height: int) -> tuple[np.ndarray, Camera]:
        """RGB image (height, width, 3), uint8, of the probed region, and its camera.

        The camera frames the object's links and the fingertip's hemisphere
        (``camera.frame_box``), so that the object fills most of the image; it reads the
        simulator's state for that, as a picture for people may (``docs/design.md`` 7.10).
        """
        self._check_open()
        cid = self._world.client_id
        p.resetBasePositionAndOrientation(
            self._fingertip_visual,
            self._pose[3].tolist(),
            self.fingertip_orientation.tolist(),
            physicsClientId=cid,
        )
        body = self._object.body_id
        boxes = [np.array(p.getAABB(body, link, physicsClientId=cid)) for link in (-1, 0)]
        tip = self.sensor_to_world_point(self._geometry.sphere_center)
        radius = self._geometry.outer_radius
        lo = np.min([b[0] for b in boxes] + [tip - radius], axis=0)
        hi = np.max([b[1] for b in boxes] + [tip + radius], axis=0)
        camera = frame_box(lo, hi, width, height)
        _, _, rgba, _, _ = p.getCameraImage(
            width,
            height,
            camera.view_list,
            camera.projection_list,
            renderer=p.ER_TINY_RENDERER,
            # The segmentation mask is not used, and skipping it saves a third of the time.
            flags=p.ER_NO_SEGMENTATION_MASK,
            physicsClientId=cid,
        )
        image = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
        return image, camera

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
