"""Elastic-foundation (Winkler) skin of the soft fingertip.

Frames and units (docs/design.md 2 and 3): node positions, normals and the wrench are
in the sensor frame (origin at the F/T sensor, z along the finger axis); each primitive is
evaluated in its own local frame; the fingertip pose (``rotation``, ``position``) maps the
sensor frame to the world frame. SI units: m, N, N m, s.

Model, per node i with area A_i on the undeformed outer surface:

* each node in contact has an anchor a_i on the surface of the primitive that presses it
  (object boxes with rounded edges, table plane), where it touched it; it is pressed by the
  tangent plane there: penetration delta_i = (a_i - x_i) . n_i below that plane, with n_i
  the surface's outward normal at a_i, which is the interface normal of a soft skin pressed
  by a rigid body. Of several primitives, the one that penetrates the node most presses it;
* normal pressure p_i = max(0, k_n delta_i + c d(delta_i)/dt) (no adhesion);
* tangential stick-slip spring: traction -k_t u_i with u_i the node's tangential offset from
  its anchor, capped at mu p_i by moving the anchor toward the node along the surface (slip);
* the force on the skin, A_i (p_i n_i - k_t u_i), acts at the deformed point
  x_i + delta_i n_i (on the object's surface for a face): that point, not the undeformed
  node, is where the object touches the skin, so the wrench carries the indentation offset
  the real sensor sees.

Why anchors rather than the signed distance (docs/design.md 3.2): the box's signed
distance pushes a node out through the *nearest* face. Near an edge a node that came in
through the top face soon lies nearer the side face than the top, and its force then
points sideways and cancels the tilt that a truncated patch gives the wrench, which is what
makes a plain press on an edge reveal the edge. A node is pressed by the surface it came
through: the face, the rounded edge or the side face. For a face, the tangent plane is the
face's plane wherever the anchor slides on it, so the node is pressed along the face normal
by its depth below the face, however deep it goes and whichever face is nearer. On a
rounded edge (radius ``ObjectConfig.edge_radius``) the plane turns with the anchor: where
the rounding is shallower than the friction angle the node sticks and is pressed along the
normal where it touched; on its steep part the anchor slips down onto the side face. The
anchor moves continuously, so the penetration does as a node crosses from a rounding into
the inner box. A box is convex, so the plane's penetration is never below the node's depth
inside the box, and a node is in contact exactly while it is inside the box: one that leaves
through another face than it came in by drops its load there, as a real edge's support ends.

Where a node first touches: its path since the last committed pose (the primitives'
frames are kept at every commit and at ``select``) is taken as straight, and its anchor is
where that path entered the box (a slab test on the un-rounded box, then a few steps of
sphere tracing onto a rounding), so a node that arrives deep in one step (fast motion, about
1 mm per substep) still gets the face it came through. Only without that history, after a
teleport (``select`` then ``evaluate`` at the same pose) with the node already inside, it
falls back to the nearest surface point. The table plane anchors where the node is, on the
plane.

A node whose penetration exceeds the skin thickness has reached the rigid shell: that is
reported (``Contact.shell_contact``), never hidden; the spring law continues linearly.

Broad phase, once per control step (``select``): the fingertip's bounding sphere is tested
against each primitive; for near primitives, node clusters (bounding spheres of ~4 mm voxels
of the node set) and then nodes are kept if their signed distance is below the motion bound
plus ``margin``, sorted by that distance. Signed distances are 1-Lipschitz, so a node
that started at distance d cannot touch before the fingertip and object have moved d
relative to each other: each substep (``evaluate``) evaluates only the prefix of candidates
whose starting distance is below the motion so far. The same bounds give a selection without
candidates its clearance: no node can touch anything before that much relative motion, so
the scene keeps it over several control steps (docs/design.md 3.5). The v3 step keeps a
selection with candidates too and makes it again from its own candidates (``narrow``) once
the fingertip has moved (docs/design.md 3.6).

The broad phase, the per-substep node loop (narrow phase, forces, stick-slip, wrench) and
committing the state are compiled kernels (:mod:`tactile_gym.sim._kernels`): a few hundred
nodes are too few to amortise NumPy's per-call cost. ``substep`` runs a whole physics
substep of the skin (the fingertip's motion, the guarded move, evaluation, commit) in one
call (docs/design.md 3.5). ``Contact`` (:mod:`tactile_gym.sim.skin_contact`) keeps the
kernel's output and builds its per-node views and dictionaries on demand; the committed one
is built only when asked for.
"""

from __future__ import annotations

import copy

import numpy as np

from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sim import _kernels, _step_kernels
from tactile_gym.sim.config import SkinConfig
from tactile_gym.sim.primitives import Plane, RoundedBox
from tactile_gym.sim.skin_contact import EMPTY_CONTACT, Contact, Selection

__all__ = ["SoftSkin"]

_CLUSTER_CELL = 0.004  # m, voxel size that groups nodes for the broad phase


def _shape(prim) -> tuple[list[float], int]:
    """A primitive's row of ``shapes`` and its kind, for the kernels."""
    if isinstance(prim, RoundedBox):
        return [*prim.inner_half, prim.radius], _kernels.BOX
    if isinstance(prim, Plane):
        return [0.0, 0.0, 0.0, prim.height], _kernels.PLANE
    raise TypeError(f"the skin handles RoundedBox and Plane primitives, got {type(prim).__name__}")


def _fill_poses(poses: np.ndarray, primitives, rotation, position) -> None:
    poses[0, :3] = rotation
    poses[0, 3] = position
    for i, prim in enumerate(primitives, start=1):
        poses[i, :3] = prim.rotation
        poses[i, 3] = prim.center


class SoftSkin:
    """Winkler skin on a :class:`FingertipGeometry`, with stick-slip friction.

    Args:
        geometry: fingertip shape (sensor frame).
        config: stiffness, damping, friction, node spacing.
    """

    def __init__(self, geometry: FingertipGeometry, config: SkinConfig) -> None:
        self.geometry = geometry
        self.config = config
        s = geometry.sample_surface(config.node_spacing, z_min=config.z_min)
        pts = s.points
        # Group nodes into voxels so the broad phase can reject whole clusters.
        keys = np.floor(pts / _CLUSTER_CELL).astype(np.int64)
        _, inverse = np.unique(keys, axis=0, return_inverse=True)
        inverse = inverse.ravel()
        order = np.argsort(inverse, kind="stable")
        self.points = np.ascontiguousarray(pts[order], dtype=float)
        self.normals = np.ascontiguousarray(s.normals[order], dtype=float)
        self.areas = np.ascontiguousarray(s.areas[order], dtype=float)
        labels = inverse[order]
        bounds = np.flatnonzero(np.diff(labels)) + 1
        self._cl_start = np.concatenate([[0], bounds, [len(labels)]]).astype(np.int64)
        spans = list(zip(self._cl_start[:-1], self._cl_start[1:], strict=True))
        centers = np.array([self.points[a:b].mean(0) for a, b in spans])
        self._cl_center = np.ascontiguousarray(centers)
        self._cl_radius = np.array(
            [
                np.linalg.norm(self.points[a:b] - c, axis=1).max()
                for (a, b), c in zip(spans, centers, strict=True)
            ]
        )
        lo, hi = self.points.min(0), self.points.max(0)
        self.bound_center = (lo + hi) / 2.0
        self.bound_radius = float(np.linalg.norm(self.points - self.bound_center, axis=1).max())
        #: Largest distance of a node from the sensor origin, m.
        self.reach = float(np.linalg.norm(self.points, axis=1).max())
        self.k_n = float(config.normal_stiffness)
        self.k_t = float(config.k_t)
        self.c_n = float(config.damping)
        self.mu = float(config.friction)
        self.thickness = float(geometry.skin_thickness)
        n = len(self.points)
        # Committed state per node: primitive touched (-1: none), anchor on its surface in
        # its frame, penetration. Only the nodes of ``contact`` have one.
        self._prim = np.full(n, -1, dtype=np.int64)
        self._anchor = np.zeros((n, 3))
        self._delta = np.zeros(n)
        self._slot = np.full(n, -1, dtype=np.int64)  # scratch of the broad phase
        # Frames (x_primitive = A x_sensor + b) of every primitive at the last committed
        # pose (or ``select``): where a node came from, to find where it entered a box.
        self._prev_frames = np.zeros((0, 4, 3))
        # The primitives ``_shapes`` and ``_prim_info`` describe (``_kernel_shapes``).
        self._shapes_of: list = []
        self._shapes = np.zeros((0, 4))
        self._prim_info = np.zeros((0, 2), dtype=np.int64)
        # The committed contact: a Contact, or the kernel's raw output (built on demand).
        self._contact: Contact | None = EMPTY_CONTACT
        self._raw: tuple | None = None
        self._raw_prims: tuple[list[int], np.ndarray] = ([], EMPTY_CONTACT._prim_rows)
        self._ids = EMPTY_CONTACT._node_ids
        #: Nodes in contact in the committed contact.
        self.n_active = 0
        #: |force| of the committed contact, N.
        self.force_norm = 0.0

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def contact(self) -> Contact:
        """The committed contact."""
        if self._contact is None:
            self._contact = Contact(*self._raw, *self._raw_prims)
            self._raw = None
        return self._contact

    def _set(self, contact: Contact) -> None:
        self._contact, self._raw = contact, None
        self._ids, self.n_active, self.force_norm = (
            contact._node_ids,
            contact.n_active,
            contact.force_norm,
        )

    def reset(self) -> None:
        """Forget all contact state (anchors, previous penetration)."""
        self._prim.fill(-1)
        self._delta.fill(0.0)
        self._set(EMPTY_CONTACT)

    # --- broad phase ---------------------------------------------------------------------

    def select(
        self,
        primitives: list,
        rotation: np.ndarray,
        position: np.ndarray,
        motion_bound: float,
    ) -> Selection:
        """Pre-select nodes that may touch a primitive during the coming substeps.

        The pose is taken as committed: nodes that first touch a box later in this control
        step come in from where they are now.

        Args:
            primitives: :class:`~tactile_gym.sim.primitives.RoundedBox` and
                :class:`~tactile_gym.sim.primitives.Plane` objects, posed now.
            rotation, position: fingertip pose now (sensor to world).
            motion_bound: largest relative displacement of any node with respect to any
                primitive expected before the next ``select``, m.
        """
        reach = float(motion_bound + self.config.margin)
        shapes, prim_info = self._kernel_shapes(primitives)
        poses = np.empty((len(primitives) + 1, 4, 3))
        _fill_poses(poses, primitives, rotation, position)
        nodes, points, areas, dist, hits, frames, clearance = _kernels.select(
            self.points,
            self.areas,
            self._cl_center,
            self._cl_radius,
            self._cl_start,
            self.bound_center,
            self.bound_radius,
            poses,
            shapes,
            prim_info,
            reach,
            self._slot,
        )
        # The pose here is committed (the scene selects between control steps, or after a
        # teleport, where every node then lacks a history).
        self._prev_frames = frames
        near = np.flatnonzero(hits)
        near_poses = poses[np.concatenate(([0], near + 1))]  # the fingertip's, then theirs
        sel = Selection(
            nodes=nodes,
            points=points,
            areas=areas,
            distance=dist,
            prims=near.tolist(),
            # Without candidates, no node can touch before the motion reaches the clearance.
            reach=reach if len(nodes) else max(reach, clearance),
            shapes=shapes[near],
            prim_info=prim_info[near],
            prim_rows=near.astype(np.int64),
            poses=near_poses,
        )
        self._set_kernel_args(sel)
        return sel

    def _set_kernel_args(self, sel: Selection) -> None:
        sel.kernel_args = (
            sel.points,
            sel.areas,
            sel.nodes,
            sel.distance,
            sel.poses,
            self._prev_frames,
            sel.shapes,
            sel.prim_info,
            sel.prim_rows,
            self._prim,
            self._anchor,
            self._delta,
            self.k_n,
            self.k_t,
            self.mu,
            self.thickness,
        )

    def narrow(
        self,
        selection: Selection,
        primitives: list,
        rotation: np.ndarray,
        position: np.ndarray,
        reach: float,
    ) -> Selection:
        """The broad phase ``selection`` made afresh at the current poses, from its own
        candidates (``_step_kernels.narrow``): valid for a ``reach`` up to the selection's
        reach less the relative motion since it was made.

        Args:
            selection: from ``select`` or ``narrow``.
            primitives: the list given to ``select``, posed now.
            rotation, position: fingertip pose now (sensor to world).
            reach: distance bound, m.
        """
        poses = selection.poses
        _fill_poses(poses, [primitives[j] for j in selection.prims], rotation, position)
        nodes, points, areas, dist = _step_kernels.narrow(
            selection.points,
            selection.areas,
            selection.nodes,
            poses,
            selection.shapes,
            selection.prim_info,
            float(reach),
        )
        sel = copy.copy(selection)  # dataclasses.replace runs __init__: 4x the time
        sel.nodes, sel.points, sel.areas = nodes, points, areas
        sel.distance, sel.reach = dist, reach
        self._set_kernel_args(sel)
        return sel

    def _kernel_shapes(self, primitives: list) -> tuple[np.ndarray, np.ndarray]:
        """``shapes`` and ``prim_info`` of the primitives for the kernels. A primitive's shape
        does not change, so they are built again only for other primitives (the scene
        selects with the same list every control step)."""
        known = self._shapes_of
        if len(known) != len(primitives) or any(a is not b for a, b in zip(known, primitives)):
            rows, kinds = zip(*(_shape(prim) for prim in primitives), strict=True)
            self._shapes = np.array(rows, dtype=float)
            self._prim_info = np.array(list(enumerate(kinds)), dtype=np.int64)
            self._shapes_of = list(primitives)
        return self._shapes, self._prim_info

    # --- narrow phase and forces ---------------------------------------------------------

    def evaluate(
        self,
        selection: Selection,
        primitives: list,
        rotation: np.ndarray,
        position: np.ndarray,
        dt: float,
        moved: float | None = None,
    ) -> Contact:
        """Contact forces at a fingertip pose; does not change the skin state.

        Args:
            selection: from ``select``.
            primitives: the same list given to ``select``, posed now.
            rotation, position: fingertip pose (sensor to world).
            dt: time since the last committed evaluation, s (for damping).
            moved: bound on the relative motion of any node and primitive since
                ``select``, m; None evaluates every candidate.
        """
        if not len(selection.nodes):
            return EMPTY_CONTACT
        poses = selection.poses
        _fill_poses(poses, [primitives[j] for j in selection.prims], rotation, position)
        out = _kernels.evaluate(
            selection.points,
            selection.areas,
            selection.nodes,
            selection.distance,
            np.inf if moved is None else float(moved),
            poses,
            self._prev_frames,
            selection.shapes,
            selection.prim_info,
            self._prim,
            self._anchor,
            self._delta,
            self.k_n,
            self.c_n / dt,
            self.k_t,
            self.mu,
            self.thickness,
        )
        # Kept also without contact: committing it records the primitives' frames.
        return Contact(*out, selection.prims, selection.prim_rows)

    def commit(self, contact: Contact) -> None:
        """Make ``contact`` the skin's state (anchors, penetration) for the next step."""
        _kernels.commit(
            self._prim,
            self._anchor,
            self._delta,
            self._prev_frames,
            self._ids,
            self.n_active,
            contact._node_ids,
            contact._node_data,
            contact.n_active,
            contact._prim_data,
            contact._prim_rows,
        )
        self._set(contact)

    def substep(
        self,
        selection: Selection,
        pose: np.ndarray,
        motion: np.ndarray,
        turning: bool,
        step_len: float,
        moved: float,
        link: np.ndarray,
        link_row: int,
        angle: float,
        limit: float,
        dt: float,
        reaction: np.ndarray,
    ) -> tuple[bool, float, bool, float, bool, float]:
        """One physics substep in one compiled call (``_kernels.substep``): advance the
        fingertip ``pose`` by ``motion`` under the guarded move, evaluate and commit.

        Args:
            selection: from ``select``; its ``poses`` hold the primitives' poses.
            pose: (4, 3) fingertip rotation (sensor to world) and position, updated in place.
            motion: (4, 3) per-substep rotation (applied when ``turning``) and translation.
            step_len: bound on any node's displacement in one substep of ``motion``, m.
            moved: bound on the relative motion of any node and primitive since ``select``
                after this substep, m.
            link, link_row, angle: the primitive on the revolute link (row of the selection,
                -1 if not in it), posed at ``angle`` rad (``_pose_kernels.link_pose``).
            limit: guarded-move limit on |f|, N.
            dt: time since the last committed evaluation, s.
            reaction: (3, 3) out: force and torque on the link's primitive (world frame,
                about its centre) and its centre, when it is touched.

        Returns:
            (limited, travelled, pushed, max_penetration, shell_contact, force_norm): the
            guard held the fingertip back; the bound on node displacement this substep, m;
            the link's primitive is touched (``reaction``); the committed contact's largest
            penetration (m), shell contact and |f| (N).
        """
        out, limited, travelled, pushed = _kernels.substep(
            *selection.kernel_args,
            self._ids,
            self.n_active,
            moved,
            pose,
            motion,
            turning,
            step_len,
            link,
            link_row,
            angle,
            self.force_norm,
            limit,
            self.c_n / dt,
            reaction,
        )
        self._contact, self._raw = None, out
        self._raw_prims = (selection.prims, selection.prim_rows)
        self.n_active, self.force_norm, self._ids = out[0], out[3], out[7]
        return limited, travelled, pushed, out[1], out[2], out[3]

    def run(
        self,
        selection: Selection,
        pose: np.ndarray,
        motion: np.ndarray,
        turning: bool,
        step_len: float,
        substeps: int,
        link: np.ndarray,
        link_row: int,
        hinge: np.ndarray,
        joint: np.ndarray,
        link_pose: np.ndarray,
        q_selected: float,
        link_reach: float,
        limit: float,
        dt: float,
        reaction: np.ndarray,
        stats: np.ndarray,
    ) -> int:
        """Up to ``substeps`` substeps of the v3 step in one compiled call
        (``_step_kernels.control_step``: this skin's substeps and the hinge between them).

        Args:
            selection: from ``select``.
            pose, motion, turning, step_len: as in ``substep``.
            substeps: how many to run at most.
            link, link_row: the free link (``HingedObject.link``) and its row in the
                selection (-1: not in it).
            hinge, joint: ``HingedObject.hinge`` and the joint's (angle, velocity), in/out.
            link_pose: (4, 3) out: the free box's pose at the angle reached.
            q_selected, link_reach: the joint angle at ``select`` (rad) and the largest
                distance of a point of the free box from the pin (m).
            limit, dt: the guard's |f| limit (N), the time step (s).
            reaction: (3, 3) out, as in ``substep``.
            stats: (``_step_kernels.STATS_COLS``,) in/out (``_step_kernels.control_step``).

        Returns:
            The substeps run: fewer than ``substeps`` when the motion bound reached the
            selection's reach (select again and run the rest).
        """
        ran, released, evaluated, out = _step_kernels.control_step(
            selection.kernel_args,
            self._ids,
            self.n_active,
            self.force_norm,
            pose,
            motion,
            turning,
            step_len,
            substeps,
            link,
            link_row,
            hinge,
            joint,
            link_pose,
            q_selected,
            link_reach,
            selection.reach,
            limit,
            self.c_n / dt,
            dt,
            reaction,
            stats,
        )
        if evaluated:
            self._contact, self._raw = None, out
            self._raw_prims = (selection.prims, selection.prim_rows)
            self.n_active, self.force_norm, self._ids = out[0], out[3], out[7]
        elif released:
            self._set(EMPTY_CONTACT)
        return ran

    def release(self) -> None:
        """Let go: commit the empty contact (nothing is within reach)."""
        self.commit(EMPTY_CONTACT)
