"""What the soft skin's kernels hand back: the candidate nodes of a control step
(:class:`Selection`) and the contact of one evaluation (:class:`Contact`), both views of the
kernels' arrays (:mod:`tactile_gym.sim._kernels`), and the empty contact. The skin itself,
which makes them, is :class:`tactile_gym.sim.skin.SoftSkin`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_gym.sim import _kernels

__all__ = ["EMPTY_CONTACT", "Contact", "Selection"]


@dataclass
class Selection:
    """Candidate nodes for one control step, sorted by their starting distance.

    Attributes:
        nodes: (M,) indices of candidate nodes.
        points: (M, 3) their positions, sensor frame, m.
        areas: (M,) their areas, m^2.
        distance: (M,) ascending signed distance to the nearest primitive at selection, m.
        prims: indices (into the primitive list) of primitives near the fingertip.
        reach: motion bound (plus margin) the selection covers, m; without candidates, the
            clearance of every node from every primitive if that is larger.
        shapes, prim_info: those primitives' shapes and (index, kind), as the kernels take
            them (:mod:`tactile_gym.sim._kernels`).
        prim_rows: (P,) int64, ``prims`` as an array.
        poses: (P + 1, 4, 3) buffer for the poses of each evaluation.
        kernel_args: the arguments of ``_kernels.substep`` that are fixed while this
            selection is in use (built once: a substep's call is then one tuple).
    """

    nodes: np.ndarray
    points: np.ndarray
    areas: np.ndarray
    distance: np.ndarray
    prims: list[int]
    reach: float
    shapes: np.ndarray
    prim_info: np.ndarray
    prim_rows: np.ndarray
    poses: np.ndarray
    kernel_args: tuple = ()


class Contact:
    """The skin's contact after one evaluation (not yet committed).

    Per-node arrays hold only the nodes in contact (K of them); vectors are columns (3, K).
    They are views of the kernel's output: read them, do not write them.

    Attributes:
        nodes: (K,) indices of nodes in contact.
        prim: (K,) index of the primitive each node touches (into the primitive list).
        local: (3, K) node positions in their primitive's frame, m.
        normal: (3, K) outward surface normals at the anchors (before this step's slip),
            primitive frame.
        delta: (K,) penetration, m.
        pressure: (K,) normal pressure, Pa.
        anchor: (3, K) anchors after this step, on the primitive's surface, its frame, m.
        force_local: (3, K) force on the skin at each node, primitive frame, N.
        point_local: (3, K) contact points (deformed skin), primitive frame, m.
        wrench: (6,) force on the skin and moment about the sensor origin, sensor frame.
        force_norm: |wrench[:3]|, N.
        prim_wrench: {primitive index: (6,) wrench from that primitive}, sensor frame.
        frames: {primitive index: (A, b)} with x_primitive = A x_sensor + b.
        n_active: K.
        max_penetration: largest penetration, m (0 without contact).
        shell_contact: some penetration exceeds the skin thickness (the rigid shell).
    """

    __slots__ = (
        "_node_data",
        "_node_ids",
        "_prim_data",
        "_prim_index",
        "_prim_rows",
        "_prim_wrench",
        "force_norm",
        "max_penetration",
        "n_active",
        "shell_contact",
        "wrench",
    )

    def __init__(
        self,
        count: int,
        max_penetration: float,
        shell_contact: bool,
        force_norm: float,
        wrench: np.ndarray,
        prim_data: np.ndarray,
        node_data: np.ndarray,
        node_ids: np.ndarray,
        prim_index: list[int],
        prim_rows: np.ndarray,
    ) -> None:
        self.n_active = count
        self.max_penetration = max_penetration
        self.shell_contact = shell_contact
        self.force_norm = force_norm
        self.wrench = wrench
        self._prim_data = prim_data
        self._node_data = node_data
        self._node_ids = node_ids
        self._prim_index = prim_index
        self._prim_rows = prim_rows
        self._prim_wrench: dict[int, np.ndarray] | None = None

    @property
    def prim_wrench(self) -> dict[int, np.ndarray]:
        if self._prim_wrench is None:
            k = _kernels.WRENCH
            self._prim_wrench = {
                j: self._prim_data[i, k : k + 6]
                for i, j in enumerate(self._prim_index)
                if self._prim_data[i, _kernels.COUNT]
            }
        return self._prim_wrench

    def reaction(self, prim: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Force and torque the skin exerts on primitive ``prim`` (minus its share of
        ``wrench``), world frame, torque about the primitive's centre; None if not touched."""
        for i, j in enumerate(self._prim_index):
            if j == prim and self._prim_data[i, _kernels.COUNT]:
                r = self._prim_data[i, _kernels.REACTION : _kernels.REACTION + 6]
                return r[:3], r[3:]
        return None

    @property
    def frames(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        f = self._prim_data[:, _kernels.FRAME : _kernels.FRAME + 12]
        return {j: (f[i, :9].reshape(3, 3), f[i, 9:]) for i, j in enumerate(self._prim_index)}

    @property
    def nodes(self) -> np.ndarray:
        return self._node_ids[: self.n_active, 0]

    @property
    def prim(self) -> np.ndarray:
        return self._node_ids[: self.n_active, 1]

    def _vectors(self, column: int) -> np.ndarray:
        return self._node_data[: self.n_active, column : column + 3]

    @property
    def local(self) -> np.ndarray:
        return self._vectors(_kernels.LOCAL).T

    @property
    def normal(self) -> np.ndarray:
        return self._vectors(_kernels.NORMAL).T

    @property
    def anchor(self) -> np.ndarray:
        return self._vectors(_kernels.ANCHOR).T

    @property
    def force_local(self) -> np.ndarray:
        return self._vectors(_kernels.FORCE).T

    @property
    def point_local(self) -> np.ndarray:
        return self._vectors(_kernels.POINT).T

    @property
    def delta(self) -> np.ndarray:
        return self._node_data[: self.n_active, _kernels.DELTA]

    @property
    def pressure(self) -> np.ndarray:
        return self._node_data[: self.n_active, _kernels.PRESSURE]

    def _to_sensor(self, column: int, is_point: bool) -> np.ndarray:
        values = self._vectors(column)
        out = np.empty((self.n_active, 3))
        for j, (a, b) in self.frames.items():
            m = self.prim == j
            out[m] = ((values[m] - b) if is_point else values[m]) @ a
        return out

    def points_sensor(self) -> np.ndarray:
        """(K, 3) contact points (deformed skin, on the object), sensor frame, m."""
        return self._to_sensor(_kernels.POINT, True)

    def forces_sensor(self) -> np.ndarray:
        """(K, 3) force on the skin at each contact node, sensor frame, N."""
        return self._to_sensor(_kernels.FORCE, False)


#: The contact of a skin touching nothing (read-only).
EMPTY_CONTACT = Contact(
    count=0,
    max_penetration=0.0,
    shell_contact=False,
    force_norm=0.0,
    wrench=np.zeros(6),
    prim_data=np.zeros((0, _kernels.PRIM_COLS)),
    node_data=np.zeros((0, _kernels.NODE_COLS)),
    node_ids=np.zeros((0, 2), dtype=np.int64),
    prim_index=[],
    prim_rows=np.zeros(0, dtype=np.int64),
)
EMPTY_CONTACT.wrench.flags.writeable = False
