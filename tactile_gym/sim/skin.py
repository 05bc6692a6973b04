"""Elastic-foundation (Winkler) skin of the soft fingertip, computed in NumPy.

Frames and units (DESIGN.md sections 2.4 and 4): node positions, normals and the wrench are
in the sensor frame (origin at the F/T sensor, z along the finger axis); each primitive is
evaluated in its own local frame; the fingertip pose (``rotation``, ``position``) maps the
sensor frame to the world frame. SI units: m, N, N m, s.

Model, per node i with area A_i on the undeformed outer surface:

* penetration delta_i = -signed distance of the node to the most penetrated primitive (object
  boxes with rounded edges, table plane); the normal n_i is that primitive's outward normal,
  which is the interface normal of a soft skin pressed by a rigid body;
* normal pressure p_i = max(0, k_n delta_i + c d(delta_i)/dt) (no adhesion);
* tangential stick-slip spring: an anchor fixed on the primitive where the node first touched;
  traction -k_t u_i with u_i the tangential offset from the anchor, capped at mu p_i by moving
  the anchor (slip);
* the force on the skin, A_i (p_i n_i - k_t u_i), acts at the deformed point
  x_i + delta_i n_i (on the object's surface): that point, not the undeformed node, is where
  the object touches the skin, so the wrench carries the indentation offset the real sensor
  sees.

A node whose penetration exceeds the skin thickness has reached the rigid shell: that is
reported (``Contact.shell_contact``), never hidden; the spring law continues linearly.

Broad phase, once per control step (``select``): the fingertip's bounding sphere is tested
against each primitive's AABB; for near primitives, node clusters (bounding spheres of ~4 mm
voxels of the node set) and then nodes are kept if their signed distance is below the motion
bound plus ``margin``, sorted by that distance. Signed distances are 1-Lipschitz, so a node
that started at distance d cannot touch before the fingertip and object have moved d
relative to each other: each substep (``evaluate``) evaluates only the prefix of candidates
whose starting distance is below the motion so far (a slice, no search).

Arrays inside the hot path hold points as columns, (3, N), so that reductions over x, y, z
are row operations (NumPy's reductions along a length-3 axis are slow).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.sensing.geometry import FingertipGeometry
from tactile_gym.sim.config import SkinConfig

__all__ = ["Contact", "Selection", "SoftSkin"]

_CLUSTER_CELL = 0.004  # m, voxel size that groups nodes for the broad phase


@dataclass
class Selection:
    """Candidate nodes for one control step, sorted by their starting distance.

    Attributes:
        nodes: (M,) indices of candidate nodes.
        points: (3, M) their positions, sensor frame, m.
        areas: (M,) their areas, m^2.
        distance: (M,) ascending signed distance to the nearest primitive at selection, m.
        prims: indices (into the primitive list) of primitives near the fingertip.
        reach: motion bound (plus margin) the selection covers, m.
    """

    nodes: np.ndarray
    points: np.ndarray
    areas: np.ndarray
    distance: np.ndarray
    prims: list[int]
    reach: float

    def count(self, moved: float) -> int:
        """How many candidates may touch after a relative motion of ``moved`` m."""
        return int(np.searchsorted(self.distance, moved, side="right"))


@dataclass
class Contact:
    """The skin's contact after one evaluation (not yet committed).

    Per-node arrays hold only the nodes in contact (K of them); vectors are columns (3, K).

    Attributes:
        nodes: (K,) indices of nodes in contact.
        prim: (K,) index of the primitive each node touches (into the primitive list).
        local: (3, K) node positions in their primitive's frame, m.
        normal: (3, K) primitive outward normals, primitive frame.
        delta: (K,) penetration, m.
        pressure: (K,) normal pressure, Pa.
        anchor: (3, K) tangential anchors after this step, primitive frame, m.
        force_local: (3, K) force on the skin at each node, primitive frame, N.
        point_local: (3, K) contact points (deformed skin), primitive frame, m.
        wrench: (6,) force on the skin and moment about the sensor origin, sensor frame.
        prim_wrench: {primitive index: (6,) wrench from that primitive}, sensor frame.
        frames: {primitive index: (A, b)} with x_primitive = A x_sensor + b.
    """

    nodes: np.ndarray
    prim: np.ndarray
    local: np.ndarray
    normal: np.ndarray
    delta: np.ndarray
    pressure: np.ndarray
    anchor: np.ndarray
    force_local: np.ndarray
    point_local: np.ndarray
    wrench: np.ndarray
    prim_wrench: dict[int, np.ndarray]
    frames: dict[int, tuple[np.ndarray, np.ndarray]]

    @property
    def max_penetration(self) -> float:
        return float(self.delta.max()) if len(self.delta) else 0.0

    @property
    def n_active(self) -> int:
        return len(self.nodes)

    def _to_sensor(self, values: np.ndarray, is_point: bool) -> np.ndarray:
        out = np.empty((len(self.nodes), 3))
        for j, (a, b) in self.frames.items():
            m = self.prim == j
            v = values[:, m].T
            out[m] = ((v - b) if is_point else v) @ a
        return out

    def points_sensor(self) -> np.ndarray:
        """(K, 3) contact points (deformed skin, on the object), sensor frame, m."""
        return self._to_sensor(self.point_local, True)

    def forces_sensor(self) -> np.ndarray:
        """(K, 3) force on the skin at each contact node, sensor frame, N."""
        return self._to_sensor(self.force_local, False)


def _empty_contact() -> Contact:
    z3 = np.zeros((3, 0))
    return Contact(
        nodes=np.zeros(0, dtype=np.intp),
        prim=np.zeros(0, dtype=np.intp),
        local=z3,
        normal=z3,
        delta=np.zeros(0),
        pressure=np.zeros(0),
        anchor=z3,
        force_local=z3,
        point_local=z3,
        wrench=np.zeros(6),
        prim_wrench={},
        frames={},
    )


def _pose_in(prim, rotation: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) with x_local = A x_sensor + b for the fingertip pose and a primitive."""
    rb = prim.rotation
    return rb.T @ rotation, rb.T @ (position - prim.center)


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
        self.points = np.ascontiguousarray(pts[order])
        self.normals = np.ascontiguousarray(s.normals[order])
        self.areas = np.ascontiguousarray(s.areas[order])
        self._points_t = np.ascontiguousarray(self.points.T)
        labels = inverse[order]
        bounds = np.flatnonzero(np.diff(labels)) + 1
        starts = np.concatenate([[0], bounds])
        ends = np.concatenate([bounds, [len(labels)]])
        self._cl_nodes = [np.arange(a, b) for a, b in zip(starts, ends, strict=True)]
        centers = np.array([self.points[i].mean(0) for i in self._cl_nodes])
        self._cl_center_t = np.ascontiguousarray(centers.T)
        self._cl_radius = np.array(
            [
                np.linalg.norm(self.points[i] - c, axis=1).max()
                for i, c in zip(self._cl_nodes, centers, strict=True)
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
        self._prim = np.full(n, -1, dtype=np.intp)
        self._anchor = np.zeros((3, n))
        self._delta = np.zeros(n)
        self.contact = _empty_contact()

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    def reset(self) -> None:
        """Forget all contact state (anchors, previous penetration)."""
        self._prim.fill(-1)
        self._delta.fill(0.0)
        self.contact = _empty_contact()

    # --- broad phase ---------------------------------------------------------------------

    def select(
        self,
        primitives: list,
        rotation: np.ndarray,
        position: np.ndarray,
        motion_bound: float,
    ) -> Selection:
        """Pre-select nodes that may touch a primitive during the coming substeps.

        Args:
            primitives: objects with ``center``, ``rotation``, ``world_aabb``,
                ``local_distance`` and ``local_normal``.
            rotation, position: fingertip pose now (sensor to world).
            motion_bound: largest relative displacement of any node with respect to any
                primitive expected before the next ``select``, m.
        """
        reach = motion_bound + self.config.margin
        prims: list[int] = []
        idx_chunks: list[np.ndarray] = []
        d_chunks: list[np.ndarray] = []
        center = rotation @ self.bound_center + position
        grow = self.bound_radius + reach
        for j, prim in enumerate(primitives):
            lo, hi = prim.world_aabb()
            if np.any(center < lo - grow) or np.any(center > hi + grow):
                continue
            a, b = _pose_in(prim, rotation, position)
            cc = a @ self._cl_center_t + b[:, None]
            near = np.flatnonzero(prim.local_distance(cc) < self._cl_radius + reach)
            if len(near) == 0:
                continue
            idx = np.concatenate([self._cl_nodes[k] for k in near])
            d = prim.local_distance(a @ self._points_t[:, idx] + b[:, None])
            keep = d < reach
            if keep.any():
                prims.append(j)
                idx_chunks.append(idx[keep])
                d_chunks.append(d[keep])
        if not idx_chunks:
            nodes = np.zeros(0, dtype=np.intp)
            dist = np.zeros(0)
        else:
            nodes = np.concatenate(idx_chunks)
            dist = np.concatenate(d_chunks)
            if len(idx_chunks) > 1:
                # A node near two primitives is kept once, with its smaller distance.
                order = np.lexsort((dist, nodes))
                nodes, dist = nodes[order], dist[order]
                first = np.concatenate([[True], nodes[1:] != nodes[:-1]])
                nodes, dist = nodes[first], dist[first]
            order = np.argsort(dist, kind="stable")
            nodes, dist = nodes[order], dist[order]
        # Nodes outside the selection cannot be in contact: drop their state.
        keep_all = np.zeros(self.n_nodes, dtype=bool)
        keep_all[nodes] = True
        self._prim[~keep_all] = -1
        return Selection(
            nodes=nodes,
            points=np.ascontiguousarray(self._points_t[:, nodes]),
            areas=self.areas[nodes],
            distance=dist,
            prims=prims,
            reach=reach,
        )

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
        m = len(selection.nodes) if moved is None else selection.count(moved)
        if m == 0:
            return _EMPTY
        pts = selection.points[:, :m]
        prims = selection.prims
        frames = {j: _pose_in(primitives[j], rotation, position) for j in prims}
        if len(prims) == 1:
            j = prims[0]
            a, b = frames[j]
            xl = a @ pts
            xl += b[:, None]
            d = primitives[j].local_distance(xl)
            hit = np.flatnonzero(d < 0.0)
            if len(hit) == 0:
                return _EMPTY
            xl = xl[:, hit]
            delta = -d[hit]
            n = primitives[j].local_normal(xl)
            prim = np.full(len(hit), j, dtype=np.intp)
        else:
            best_d = None
            for j in prims:
                a, b = frames[j]
                xj = a @ pts
                xj += b[:, None]
                dj = primitives[j].local_distance(xj)
                if best_d is None:
                    best_d, best_x = dj, xj
                    best_j = np.full(len(dj), j, dtype=np.intp)
                else:
                    better = dj < best_d
                    best_d = np.where(better, dj, best_d)
                    best_x = np.where(better, xj, best_x)
                    best_j = np.where(better, j, best_j)
            hit = np.flatnonzero(best_d < 0.0)
            if len(hit) == 0:
                return _EMPTY
            xl = best_x[:, hit]
            delta = -best_d[hit]
            prim = best_j[hit]
            n = np.empty_like(xl)
            for j in prims:
                sel = prim == j
                if sel.any():
                    n[:, sel] = primitives[j].local_normal(xl[:, sel])
        nodes = selection.nodes[hit]
        area = selection.areas[hit]

        same = self._prim[nodes] == prim
        delta_prev = np.where(same, self._delta[nodes], delta)
        # p = k_n delta + c d(delta)/dt, no adhesion; a new contact starts undamped.
        pressure = delta - delta_prev
        pressure *= self.c_n / dt
        pressure += self.k_n * delta
        np.maximum(pressure, 0.0, out=pressure)
        anchor = np.where(same, self._anchor[:, nodes], xl)
        u = xl - anchor
        u -= (u * n).sum(axis=0) * n
        u_sq = (u * u).sum(axis=0)
        cap = self.mu * pressure
        slip = np.flatnonzero(self.k_t**2 * u_sq > cap * cap)
        if len(slip):
            u[:, slip] *= cap[slip] / (self.k_t * np.sqrt(u_sq[slip]))
        anchor = xl - u
        f = n * (pressure * area)
        f -= u * (self.k_t * area)
        app = n * delta
        app += xl

        wrench = np.zeros(6)
        prim_wrench: dict[int, np.ndarray] = {}
        for j in prims:
            a, b = frames[j]
            if len(prims) == 1:
                fj, aj = f, app
            else:
                sel = prim == j
                if not sel.any():
                    continue
                fj, aj = f[:, sel], app[:, sel]
            force = fj.sum(axis=1)
            g = aj @ fj.T
            # sum (x - b) x f = antisymmetric part of sum x f^T, minus b x F.
            moment = np.array(
                [
                    g[1, 2] - g[2, 1] - (b[1] * force[2] - b[2] * force[1]),
                    g[2, 0] - g[0, 2] - (b[2] * force[0] - b[0] * force[2]),
                    g[0, 1] - g[1, 0] - (b[0] * force[1] - b[1] * force[0]),
                ]
            )
            w = np.concatenate([force @ a, moment @ a])
            prim_wrench[j] = w
            wrench += w
        return Contact(
            nodes=nodes,
            prim=prim,
            local=xl,
            normal=n,
            delta=delta,
            pressure=pressure,
            anchor=anchor,
            force_local=f,
            point_local=app,
            wrench=wrench,
            prim_wrench=prim_wrench,
            frames=frames,
        )

    def commit(self, contact: Contact) -> None:
        """Make ``contact`` the skin's state (anchors, penetration) for the next step."""
        old = self.contact.nodes
        if len(old):
            self._prim[old] = -1
        if contact.n_active:
            self._prim[contact.nodes] = contact.prim
            self._anchor[:, contact.nodes] = contact.anchor
            self._delta[contact.nodes] = contact.delta
        self.contact = contact


_EMPTY = _empty_contact()
