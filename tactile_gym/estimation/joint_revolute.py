"""The revolute joint model: each edge line turned about one axis, which the axis fits give
(docs/design.md 6.10; the models' common frame is :mod:`.joint_models`)."""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import AxisEstimate
from tactile_gym.estimation.joint_models import (
    LineModel,
    LineState,
    ModelFit,
    mean_lines,
    normalise,
    rotations,
    small_motions,
)
from tactile_gym.estimation.joint_prior import EZ, JointTypePrior
from tactile_gym.estimation.lines import EDGE_STD_FLOOR, LineData
from tactile_gym.estimation.online import COVARIANCES, JointAxisEstimator
from tactile_gym.estimation.prior import PIN_STD_FLOOR
from tactile_gym.estimation.problem import PriorTerm, basis
from tactile_gym.estimation.robust import check_loss
from tactile_gym.vec3 import cross_rows

__all__ = ["RevoluteModel"]


class RevoluteModel(LineModel):
    """Edge lines turn about the axis (paper eq. 8: each keeps its distance and angle to it).

    The axis and its covariance reported are the axis fits' (:class:`JointAxisEstimator`,
    with the prior's axis prior, fed the measurements of the edge line measured most often).
    The evidence is the Laplace approximation at the mode of the whole model: the lines,
    the turns and the axis (with its prior) refined together from that estimate, so that the
    lines the axis fit did not see count too (docs/design.md 6.10). The refined axis only
    places the evidence; it is not reported.

    Args:
        mode: ``"planar"`` (vertical axis) or ``"3d"``.
        prior: the priors.
        loss: the axis fit's loss (one of ``LOSSES``).
        covariance: what the axis fit takes the handed noise for (``COVARIANCES``:
            ``"independent"`` or ``"calibrated"``, :class:`JointAxisEstimator`).
    """

    joint_type = "revolute"

    def __init__(
        self,
        mode: str = "3d",
        prior: JointTypePrior | None = None,
        loss: str = "soft_l1",
        covariance: str = "independent",
    ) -> None:
        check_loss(loss)
        if covariance not in COVARIANCES:
            raise ValueError(f"covariance must be one of {COVARIANCES}, got {covariance!r}")
        self.loss = loss
        self.covariance = covariance
        super().__init__(mode, prior)
        self.motion_range = self.prior.turn_range

    def reset(self) -> None:
        super().reset()
        self._axis_fit: JointAxisEstimator | None = None
        self._primary = -1
        self._fed = 0

    def _axis(self, data: LineData) -> AxisEstimate:
        """The axis fits' estimate from the measurements of the line measured most often
        (ties: the earliest)."""
        primary = int(np.argmax(np.bincount(data.line)))
        if self._axis_fit is None or primary != self._primary:
            prior = self.prior.axis_prior(self.mode, data.x[0])
            self._axis_fit = JointAxisEstimator(
                self.mode, self.loss, prior=prior, covariance=self.covariance
            )
            self._primary, self._fed = primary, 0
        idx = np.flatnonzero(data.line == primary)
        for i in idx[self._fed :]:
            # The noise as the line residuals take it, floors included.
            e = data.e[i]
            floor = EDGE_STD_FLOOR**2 * (np.eye(3) - np.outer(e, e))
            self._axis_fit.add(
                data.x[i],
                e,
                data.sx[i],
                math.hypot(data.edge_total_std[i], math.sqrt(2.0) * EDGE_STD_FLOOR),
                edge_cov=data.edge_cov[i] + floor,
            )
        self._fed = idx.size
        est = self._axis_fit.estimate()
        if est.degenerate:
            # Only input that overflows the axis fit gets here: the prior's axis then.
            return self._axis_fit.prior.estimate(planar=self.mode == "planar")
        return est

    def _n_joint(self) -> int:
        return 2 if self.mode == "planar" else 4

    def _n_joint_angles(self) -> int:
        return 0 if self.mode == "planar" else 2

    def _axis_frame(self, start):
        """The directions the axis's local coordinates turn its direction along (none in
        ``"planar"``) and move its point along."""
        if "axis_frame" not in start.memo:
            if self.mode == "planar":
                start.memo["axis_frame"] = np.zeros((0, 3)), np.eye(3)[:2]
            else:
                b = np.array(basis(start.joint[0]))
                start.memo["axis_frame"] = b, b
        return start.memo["axis_frame"]

    def _joint_value(self, start, xj, eps):
        u0, p0 = start.joint
        turn, move = self._axis_frame(start)
        nt = turn.shape[0]
        u = normalise(u0 + xj[:nt] @ turn) if nt else u0
        return u, p0 + xj[nt:] @ move

    def _predict(self, data, state):
        u, p = state.joint
        rot = rotations(u, state.q[data.config])
        eps = np.einsum("iab,ib->ia", rot, state.eps[data.line])
        a = p + np.einsum("iab,ib->ia", rot, state.a[data.line] - p)
        return eps, a, rot

    def _motion_rows(self, data, state, eps_p, a_p):
        u, p = state.joint
        uu = np.broadcast_to(u, eps_p.shape)
        return cross_rows(uu, eps_p), cross_rows(uu, a_p - p)

    def _joint_rows(self, data, state, eps_p, a_p, rot, start, xj):
        u, p = state.joint
        turn, move = self._axis_frame(start)
        q = state.q[data.config]
        s, c = np.sin(q)[:, None], (1.0 - np.cos(q))[:, None]
        eps, y = state.eps[data.line], state.a[data.line] - p
        deps, da = [], []
        if turn.shape[0]:
            # d u = (I - u u^T) b / |u0 + B alpha| =: t, normal to u; then
            # d(R x) = (t x x) sin q + (t (u . x) + u (t . x)) (1 - cos q).
            tang = (turn - np.outer(turn @ u, u)) / np.linalg.norm(
                _unnormalised_axis(start, turn, xj)
            )
            for t in tang:
                tt = np.broadcast_to(t, eps.shape)
                for v, out in ((eps, deps), (y, da)):
                    out.append(
                        cross_rows(tt, v) * s + (t * (v @ u)[:, None] + u * (v @ t)[:, None]) * c
                    )
        for dp in move:
            deps.append(np.zeros_like(eps))
            da.append(dp - np.einsum("iab,b->ia", rot, dp))
        return np.stack(deps, axis=1), np.stack(da, axis=1)

    def _joint_prior(self, state, start, xj):
        """The axis prior as Gaussian residuals in the axis's local coordinates
        (``"planar"``: on the pin's x and y)."""
        u, p = state.joint
        prior = self._axis_prior
        if self.mode == "planar":
            chol = np.linalg.cholesky(prior.pin_cov[:2, :2] + PIN_STD_FLOOR**2 * np.eye(2))
            winv = np.linalg.inv(chol)
            log_det = 2.0 * float(np.sum(np.log(np.diag(chol))))
            r = winv @ (p[:2] - prior.pin[:2])
            return np.zeros(2), -math.log(2.0 * math.pi) - 0.5 * log_det, r, winv
        # Whitened for the start's axis, held during a solve as the axis fits hold it.
        if "prior_term" not in start.memo:
            term = PriorTerm(prior, np.zeros(3))
            term.set_axis(start.joint[0])
            start.memo["prior_term"] = term
        term = start.memo["prior_term"]
        z, ju, jp = term.residuals(u, p)
        turn, move = self._axis_frame(start)
        tang = (turn - np.outer(turn @ u, u)) / np.linalg.norm(_unnormalised_axis(start, turn, xj))
        jac = np.column_stack([ju @ tang[0], ju @ tang[1], jp @ move[0], jp @ move[1]])
        # Direction: variance angle_std^2 / 2 per normal direction; position: the pin's
        # covariance projected normal to the axis.
        var_d = 0.5 * prior.effective_angle_std**2
        log_det = 2.0 * math.log(var_d) + math.log(
            np.linalg.det(prior.projected_pin_cov(np.array(basis(start.joint[0]))))
        )
        return np.zeros(4), -2.0 * math.log(2.0 * math.pi) - 0.5 * log_det, z, jac

    def _screw(self, data: LineData) -> tuple[np.ndarray, np.ndarray] | None:
        """(u, p) of the zero-pitch screw that best spans the configurations' small
        motions (:func:`small_motions`), or None when they do not turn."""
        _, _, omega, tau, centre = small_motions(data, turns=True, planar=self.mode == "planar")
        if not omega.size:
            return None
        # Rank one in (omega, tau / L), L the contacts' spread: twists theta_k (u, -u x p).
        length = max(float(np.sqrt(np.mean(np.sum((data.x - centre) ** 2, axis=1)))), 1e-3)
        xi = np.linalg.svd(np.hstack([omega, tau / length]))[2][0]
        w0, t0 = xi[:3], xi[3:] * length
        norm2 = float(w0 @ w0)
        if not norm2 > 1e-12:
            return None
        u = w0 / math.sqrt(norm2) if self.mode == "3d" else EZ
        return u, centre + np.cross(w0, t0) / norm2

    def _cold(self, data: LineData, u: np.ndarray, p: np.ndarray) -> LineState:
        """Turns from the azimuths about the axis of each measured line (its direction and
        the foot of its common normal with the axis), spread over the graph of lines and
        configurations from each group's reference; lines as the mean of the measured lines
        turned back."""
        b = np.array(basis(u))
        w = data.x - p
        e = data.e
        eperp = e - (e @ u)[:, None] * u
        # The foot of the common normal on each line: minimise |(x + t e - p) x u|.
        t = -np.einsum("ij,ij->i", w, eperp) / np.maximum(
            np.einsum("ij,ij->i", eperp, eperp), 1e-12
        )
        foot = w + t[:, None] * e
        radial = foot - (foot @ u)[:, None] * u
        ve = eperp @ b.T / data.edge_std[:, None]
        vr = radial @ b.T / data.sx[:, None]
        q = np.full(data.n_configs, np.nan)
        q[data.reference] = 0.0
        anchor = np.full(data.n_lines, -1)  # the measurement each line's azimuth is read from
        changed = True
        while changed:
            changed = False
            for i in range(data.n):
                k, j = data.config[i], data.line[i]
                if anchor[j] < 0 and not np.isnan(q[k]):
                    anchor[j] = i
                    changed = True
                elif anchor[j] >= 0 and np.isnan(q[k]):
                    m = anchor[j]
                    cross = ve[m, 0] * ve[i, 1] - ve[m, 1] * ve[i, 0]
                    cross += vr[m, 0] * vr[i, 1] - vr[m, 1] * vr[i, 0]
                    turn = q[data.config[m]] + math.atan2(cross, ve[m] @ ve[i] + vr[m] @ vr[i])
                    q[k] = turn if math.isfinite(turn) else 0.0
                    changed = True
        q = np.nan_to_num(q)
        eps, a = mean_lines(data, (rotations(u, -q[data.config]), p))
        return LineState(eps, a, q, (u, p))

    def fit(self, data: LineData, rigid: ModelFit | None = None) -> ModelFit:
        log_rigid = self._rigid_log_evidence(data, rigid)
        axis = self._axis(data)
        self._axis_prior = self._axis_fit.prior
        u = axis.direction if self.mode == "3d" else EZ
        start = self._cold(data, u, axis.point)
        if self._state is not None:
            state = self._solve(data, self._warm(start))
        else:
            # Over small turns the axis fit is badly conditioned (docs/design.md 6.3) and
            # the refinement can end far from the mode: start from the screw of the
            # configurations' small motions too, and keep the better.
            states = [self._solve(data, start)]
            screw = self._screw(data)
            if screw is not None:
                states.append(self._solve(data, self._cold(data, *screw)))
            state = min(states, key=lambda st: self._cost(data, st))
        self._state = state
        ev, info = self._evidence(data, state, log_rigid)
        params = np.concatenate([axis.point, axis.direction, [axis.distance]])
        # Identified when the axis fit's spread is at most half the prior's.
        before = self._axis_prior.estimate(planar=self.mode == "planar")
        identified = axis.position_std <= 0.5 * before.position_std and (
            self.mode == "planar" or axis.angle_std <= 0.5 * before.angle_std
        )
        return self._model_fit(data, ev, info, params, axis.covariance, identified, axis)


def _unnormalised_axis(start: LineState, turn: np.ndarray, xj: np.ndarray) -> np.ndarray:
    """The unnormalised turned axis direction ``u0 + B alpha`` of the local coordinates."""
    return start.joint[0] + xj[: turn.shape[0]] @ turn
