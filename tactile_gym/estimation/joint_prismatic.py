"""The prismatic joint model: each edge line shifted along one joint direction
(docs/design.md 6.10; the models' common frame is :mod:`.joint_models`)."""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import canonical_direction
from tactile_gym.estimation.joint_models import (
    LineModel,
    LineState,
    ModelFit,
    normalise,
    small_motions,
)
from tactile_gym.estimation.joint_prior import EZ, JointTypePrior
from tactile_gym.estimation.lines import Evidence, LineData, line_rows
from tactile_gym.estimation.problem import basis

__all__ = ["PrismaticModel"]


class PrismaticModel(LineModel):
    """Edge lines keep their direction and shift along the joint direction v.

    Parameters: the unit direction v (``"3d"``: 2 dof, uniform on the hemisphere;
    ``"planar"``: in the table plane, 1 dof, uniform on the half circle). With the prior's
    ``along_edge_probability``, v is instead along one of the measured edge lines (a model
    of its own for each direction, ``along``): a slide along an edge moves neither that
    edge's line nor those parallel to it (the edges of a face are parallel), so without
    this a slide along the only measured edge would count as proof of a rigid link.

    Args:
        mode: ``"planar"`` or ``"3d"``.
        prior: the priors.
        along: None (v fitted), or ``(j, parallel)``: v is line j's direction
            (``"planar"``: its part in the table plane), and the lines in ``parallel``
            (indices, j among them) do not move.
    """

    joint_type = "prismatic"

    def __init__(
        self,
        mode: str = "3d",
        prior: JointTypePrior | None = None,
        along: tuple[int, list[int]] | None = None,
    ) -> None:
        super().__init__(mode, prior)
        self.motion_range = self.prior.travel_range
        self.along = along

    def reset(self) -> None:
        super().reset()
        self._along: dict = {}

    def reset_start(self) -> None:
        super().reset_start()
        for model in getattr(self, "_along", {}).values():
            model.reset_start()

    def _moves(self, data: LineData) -> np.ndarray:
        """(N,) 1 where the measurement's line moves with the joint, 0 where it slides
        along itself."""
        if self.along is None:
            return np.ones(data.n)
        return 1.0 - np.isin(data.line, self.along[1])

    def _tangents(self, v: np.ndarray) -> np.ndarray:
        """(K, 3) directions normal to v that v's local coordinates move it along."""
        if self.mode == "planar":
            return np.cross(EZ, v)[None]
        return np.array(basis(v))

    def _n_joint(self) -> int:
        if self.along is not None:
            return 0
        return 1 if self.mode == "planar" else 2

    def _n_joint_angles(self) -> int:
        return self._n_joint()

    def _flatten(self, e: np.ndarray) -> tuple[np.ndarray, float]:
        """A line direction as a joint direction (``"planar"``: its part in the table
        plane, normalised), and the length it was divided by."""
        if self.mode == "planar":
            e = e * [1.0, 1.0, 0.0]
        n = float(np.linalg.norm(e))
        return e / n, n

    def _joint_value(self, start, xj, eps):
        if self.along is not None:
            return self._flatten(eps[self.along[0]])[0]
        return normalise(start.joint + xj @ self._tangents(start.joint))

    def _predict(self, data, state):
        q = state.q[data.config] * self._moves(data)
        return state.eps[data.line], state.a[data.line] + q[:, None] * state.joint, None

    def _motion_rows(self, data, state, eps_p, a_p):
        return np.zeros((data.n, 3)), self._moves(data)[:, None] * state.joint

    def _joint_rows(self, data, state, eps_p, a_p, rot, start, xj):
        # d v / d gamma_m = (I - v v^T) t_m / |v0 + T gamma|; the lines move by q dv.
        v, t = state.joint, self._tangents(start.joint)
        dv = (t - np.outer(t @ v, v)) / np.linalg.norm(start.joint + xj @ t)
        da = state.q[data.config][:, None, None] * dv[None]
        return np.zeros_like(da), da

    def _jacobian(self, data, start, frame, x, state):
        jac = super()._jacobian(data, start, frame, x, state)
        if self.along is None:
            return jac
        # v is line j's direction: its direction coordinates move the moving lines by q dv.
        j = self.along[0]
        e = state.eps[j]
        raw = start.eps[j] + x[4 * j : 4 * j + 2] @ frame[j]
        de = (frame[j] - np.outer(frame[j] @ e, e)) / np.linalg.norm(raw)  # (2, 3)
        v, n = self._flatten(e)
        flat = de * [1.0, 1.0, 0.0] if self.mode == "planar" else de
        dv = (flat - np.outer(flat @ v, v)) / n
        da = (state.q[data.config] * self._moves(data))[:, None, None] * dv[None]
        eps_p, a_p, _ = self._predict(data, state)
        rows = line_rows(data, eps_p, a_p, np.zeros_like(da), da)
        jac = jac.reshape(data.n, 6, -1)
        jac[:, :, 4 * j : 4 * j + 2] += rows
        return jac.reshape(6 * data.n, -1)

    def _joint_prior(self, state, start, xj):
        if self.along is not None:
            return np.zeros(0), 0.0, None, None
        # Uniform on the half circle (density 1 / pi) or on the hemisphere (1 / (2 pi)).
        if self.mode == "planar":
            return np.array([2.0 / math.pi]), -math.log(math.pi), None, None
        return np.ones(2), -math.log(2.0 * math.pi), None, None

    def _cold(self, data: LineData) -> LineState:
        """Each configuration's translation w_k (:func:`small_motions`); v their principal
        direction (or line ``along``'s) and ``s_k = w_k . v``."""
        eps, a, _, w, _ = small_motions(data, turns=False, planar=False)
        if self.along is not None:
            v = self._flatten(eps[self.along[0]])[0]
        else:
            if self.mode == "planar":
                w = w * [1.0, 1.0, 0.0]
            v = np.linalg.svd(w)[2][0] if w.size and np.abs(w).max() > 0 else np.eye(3)[0]
        q = np.zeros(data.n_configs)
        q[data.free_configs] = w @ v
        return LineState(eps, a, q, v)

    def along_lines(self, data: LineData, state: LineState) -> list[tuple[int, list[int]]]:
        """The fitted lines grouped by direction (either sign; within 1 deg or 4 edge stds
        per normal direction count as one), each group with its line measured most often
        (``"planar"``: only lines with a part in the table plane)."""
        count = np.bincount(data.line, minlength=state.eps.shape[0])
        tol = math.cos(max(math.radians(1.0), 4.0 * float(data.edge_std.max())))
        groups: list[list[int]] = []
        for j, e in enumerate(state.eps):
            if self.mode == "planar" and float(np.linalg.norm(e[:2])) < 0.1:
                continue
            for group in groups:
                if abs(float(e @ state.eps[group[0]])) >= tol:
                    group.append(j)
                    break
            else:
                groups.append([j])
        return [(max(group, key=lambda i: count[i]), group) for group in groups]

    def _fit_state(self, data: LineData, log_rigid: float):
        state = self._solve(data, self._warm(self._cold(data)))
        self._state = state
        return state, *self._evidence(data, state, log_rigid)

    def fit(self, data: LineData, rigid: ModelFit | None = None) -> ModelFit:
        """As ``JointModel.fit``; with ``along_edge_probability`` the evidence is the mixture
        of a fitted direction and a slide along each measured edge, the direction reported
        is that of its most probable component (the fitted one, or an edge's), and its
        covariance the mixture's about it: each component's, plus its direction's offset
        from the reported one, weighted by its posterior probability (``docs/design.md``
        6.10)."""
        log_rigid = self._rigid_log_evidence(data, rigid)
        state, ev, info = self._fit_state(data, log_rigid)
        v = state.joint
        cols = info["joint_cols"]
        t = self._tangents(v) if cols.size else np.zeros((0, 3))
        cov = t.T @ ev.covariance[np.ix_(cols, cols)] @ t
        identified = self._identified(ev, info)
        along = self.prior.along_edge_probability
        if self.along is None and along > 0.0:
            models = {}
            for group in self.along_lines(data, state):
                key = (group[0], tuple(group[1]))
                models[key] = self._along.get(key) or PrismaticModel(self.mode, self.prior, group)
            # Kept for the next fit to start from (lines and configurations carry over).
            self._along = models
            fixed = [model._fit_state(data, log_rigid) for model in models.values()]
            if fixed:
                log_w = [math.log1p(-along) + info["log_evidence"]]
                log_w += [
                    math.log(along) - math.log(len(fixed)) + f[2]["log_evidence"] for f in fixed
                ]
                info["log_evidence"] = float(np.logaddexp.reduce(log_w))
                parts = [(v, cov)]
                parts += [m._edge_direction(*f[:2]) for m, f in zip(models.values(), fixed)]
                w = np.exp(np.array(log_w) - info["log_evidence"])
                best = int(np.argmax(w))
                v = parts[best][0]
                identified = identified or best > 0
                cov = np.zeros((3, 3))
                normal = np.eye(3) - np.outer(v, v)
                for weight, (u, c) in zip(w, parts):
                    offset = normal @ (u * math.copysign(1.0, float(u @ v)))
                    cov += weight * (normal @ c @ normal + np.outer(offset, offset))
        direction, _ = canonical_direction(v)
        return self._model_fit(data, ev, info, direction, cov, identified)

    def _edge_direction(self, state: LineState, ev: Evidence) -> tuple[np.ndarray, np.ndarray]:
        """A slide along line j (``along``): its direction (``"planar"``: in the table
        plane) and covariance (3, 3), rad^2, from the line's direction's at the fit."""
        j = self.along[0]
        b = self._frame(state)[j]
        cov = b.T @ ev.covariance[4 * j : 4 * j + 2, 4 * j : 4 * j + 2] @ b
        v, n = self._flatten(state.eps[j])
        if self.mode == "planar":
            flat = np.diag([1.0, 1.0, 0.0])
            d = (flat - np.outer(v, v) @ flat) / n
            cov = d @ cov @ d.T
        return v, cov
