"""A PyBullet world that owns its own physics client.

Frames: world frame, z up, the table top is the plane z = 0. Units: SI.

Each :class:`World` connects its own client (DIRECT unless ``gui=True``) with
``pybullet.connect`` and keeps the id it returns, so several worlds in one process never see
each other's bodies. Every call goes straight to ``pybullet`` with that ``physicsClientId``:
no ``BulletClient`` wrapper, whose ``__getattr__`` builds a ``functools.partial`` on every call
(dearer than a ``stepSimulation`` of this small scene) and whose ``__del__`` would disconnect
on its own.
"""

from __future__ import annotations

import pybullet as p

__all__ = ["SUBSTEPS", "TIME_STEP", "World"]

#: Default physics step, s (PyBullet's own).
TIME_STEP = 1.0 / 240.0
#: Default physics steps per control step: 20 Hz control at ``TIME_STEP``.
SUBSTEPS = 12


class World:
    """Physics client, time step, table and save/restore.

    Args:
        time_step: physics step, s.
        substeps: physics steps per control step (used by the scene's controller).
        gui: open the PyBullet GUI instead of a headless client.
        gravity: gravity vector, world frame, m/s^2.
    """

    def __init__(
        self,
        time_step: float = TIME_STEP,
        substeps: int = SUBSTEPS,
        gui: bool = False,
        gravity: tuple[float, float, float] = (0.0, 0.0, -9.81),
    ) -> None:
        if not time_step > 0:
            raise ValueError(f"time_step must be > 0 s, got {time_step!r}")
        if int(substeps) != substeps or substeps < 1:
            raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
        self.time_step = float(time_step)
        self.substeps = int(substeps)
        self.gui = bool(gui)
        #: Gravity, world frame, m/s^2.
        self.gravity = tuple(float(g) for g in gravity)
        self._connected = False
        #: PyBullet's id of this world's client (``physicsClientId`` of every call).
        self.client_id: int = p.connect(p.GUI if gui else p.DIRECT)
        if self.client_id < 0:
            raise RuntimeError("could not connect a PyBullet client")
        self._connected = True
        cid = self.client_id
        p.setTimeStep(self.time_step, physicsClientId=cid)
        p.setGravity(*gravity, physicsClientId=cid)
        if gui:
            p.configureDebugVisualizer(p.COV_ENABLE_GUI, 0, physicsClientId=cid)
        self.table_id = self._make_table()

    def _make_table(self) -> int:
        cid = self.client_id
        col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid)
        vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=[0.3, 0.3, 0.001],
            visualFramePosition=[0.0, 0.0, -0.001],
            rgbaColor=[0.75, 0.72, 0.65, 1.0],
            physicsClientId=cid,
        )
        body = p.createMultiBody(
            baseMass=0.0,
            baseCollisionShapeIndex=col,
            baseVisualShapeIndex=vis,
            basePosition=[0.0, 0.0, 0.0],
            physicsClientId=cid,
        )
        # The skin computes table contact itself; PyBullet contacts stay out of it.
        p.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=cid)
        return body

    @property
    def connected(self) -> bool:
        """Whether the client is still open."""
        return self._connected

    def _require(self) -> int:
        if not self._connected:
            raise RuntimeError("this World is closed")
        return self.client_id

    def step(self) -> None:
        """Advance the physics by one ``time_step``."""
        p.stepSimulation(physicsClientId=self._require())

    def save_state(self) -> int:
        """Snapshot the physics state in memory; returns its id for ``restore_state``."""
        return p.saveState(physicsClientId=self._require())

    def restore_state(self, state_id: int) -> None:
        """Restore a snapshot taken with ``save_state`` (same bodies must exist)."""
        p.restoreState(stateId=state_id, physicsClientId=self._require())

    def close(self) -> None:
        """Disconnect the client; safe to call more than once."""
        if not self._connected:
            return
        self._connected = False
        try:
            p.disconnect(physicsClientId=self.client_id)
        except p.error:
            pass  # the server is already gone (a GUI window closed by hand)

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:
            pass
