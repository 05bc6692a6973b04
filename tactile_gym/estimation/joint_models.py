"""One model per joint type: rigid, revolute, prismatic, each fitted to the same edge lines.

World frame, metres, radians (docs/design.md 6.10). Every model explains each measurement's
edge line (:mod:`.lines`) as a line of the link, moved by the joint to the measurement's
configuration:

* rigid: the lines do not move;
* prismatic: line j at configuration k is line j shifted by ``s_k v`` (v the unit joint
  direction, 2 dof; ``"planar"``: in the table plane, 1 dof);
* revolute: line j at configuration k is line j turned by ``theta_k`` about the axis
  (``"planar"``: a vertical axis). The axis comes from the axis fits
  (:class:`~tactile_gym.estimation.online.JointAxisEstimator`, fed the measurements of the
  line measured most often); this module only fits the lines and the turns to it.

Every model has the same nuisance parameters: each edge line (direction and position, 4 dof)
and each configuration's motion (one number, relative to the first configuration of its
connected group of lines and configurations). Each :class:`JointModel` returns a
:class:`ModelFit`: its parameters and their covariance, the log-likelihood, the number of
free parameters and the Laplace evidence under the priors of
:class:`~tactile_gym.estimation.joint_prior.JointTypePrior`.
"""

from __future__ import annotations

import dataclasses
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from scipy.stats import chi2 as chi2_dist

from tactile_gym.estimation.axis import COVARIANCE_LAYOUT, AxisEstimate
from tactile_gym.estimation.joint_prior import JointTypePrior
from tactile_gym.estimation.lines import (
    DOF_PER_MEASUREMENT,
    Evidence,
    LineData,
    laplace_evidence,
    line_residuals,
    line_rows,
)
from tactile_gym.estimation.problem import basis

__all__ = [
    "JOINT_TYPES",
    "MODES",
    "PARAMETER_LAYOUTS",
    "JointModel",
    "LineModel",
    "LineState",
    "ModelFit",
    "RigidModel",
    "mean_lines",
    "minimise",
    "normalise",
    "rotations",
    "saturated_evidence",
    "small_motions",
]

JOINT_TYPES = ("rigid", "revolute", "prismatic")
"""The joint types, in the order of their codes (0 rigid, 1 revolute, 2 prismatic)."""

PARAMETER_LAYOUTS = {
    "rigid": (),
    "revolute": COVARIANCE_LAYOUT,
    "prismatic": ("direction_x", "direction_y", "direction_z"),
}
"""The order of :attr:`ModelFit.parameters` (and its covariance) per joint type."""

MODES = ("planar", "3d")

# The posterior of a joint parameter counts as set by the data when, in every direction,
# the prior gives at most this share of its information (the posterior std at most half the
# prior's).
_PRIOR_SHARE = 0.25


@dataclass(frozen=True)
class ModelFit:
    """One joint-type model fitted to the measurements.

    Attributes:
        joint_type: ``"rigid"``, ``"revolute"`` or ``"prismatic"``.
        log_evidence: ``ln p(measurements | type)``: the Laplace approximation over every
            parameter (lines, motions, joint) under the
            :class:`~tactile_gym.estimation.joint_prior.JointTypePrior`, with its mixtures (a
            link that did not move; a slide along a measured edge).
        log_likelihood: ``ln p(measurements | type, fitted parameters)`` (densities of the 4
            degrees of freedom of each measurement).
        chi2: sum of the squared whitened residuals at the fit.
        dof: residual degrees of freedom, ``4 N - effective_params``.
        n_params: number of free parameters: 4 per edge line, one motion per configuration
            after the first of each connected group, and the joint's (rigid 0; prismatic 2,
            planar 1; revolute 4, planar 2).
        effective_params: how many of them the measurements determine (each counted by the
            share of its posterior information that comes from the measurements).
        parameters: the joint's parameters in ``PARAMETER_LAYOUTS[joint_type]`` order:
            rigid none; revolute the axis estimate's point, direction and distance (as
            :class:`~tactile_gym.estimation.axis.AxisEstimate`); prismatic the unit
            direction, its largest-magnitude component positive.
        covariance: their covariance (revolute: the axis estimate's; prismatic: (3, 3) of
            the direction, rad^2, singular along it).
        identified: whether the measurements, not the prior, set the joint's parameters
            (in every direction the prior gives at most a quarter of the information).
        axis: the revolute model's axis estimate, else None.
    """

    joint_type: str
    log_evidence: float
    log_likelihood: float
    chi2: float
    dof: float
    n_params: int
    effective_params: float
    parameters: np.ndarray
    covariance: np.ndarray | None
    identified: bool
    axis: AxisEstimate | None = None

    @property
    def fit_probability(self) -> float:
        """Chi-square goodness of fit: the chance of a chi2 at least this large if the model
        and the stated noise hold."""
        return float(chi2_dist.sf(self.chi2, max(self.dof, 1.0)))


class JointModel(ABC):
    """A joint-type model fitted to edge-line measurements, refitted as they are appended.

    Args:
        mode: ``"planar"`` (revolute axis vertical, prismatic direction horizontal) or
            ``"3d"``.
        prior: the priors.
    """

    joint_type: ClassVar[str]

    def __init__(self, mode: str = "3d", prior: JointTypePrior | None = None) -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        if prior is not None and not isinstance(prior, JointTypePrior):
            raise ValueError(f"prior must be a JointTypePrior or None, got {prior!r}")
        self.mode = mode
        self.prior = JointTypePrior() if prior is None else prior
        self.reset()

    def reset(self) -> None:
        """Forget every earlier fit."""
        self.reset_start()

    def reset_start(self) -> None:
        """Start the next fit afresh, not from the last one."""
        self._state: LineState | None = None

    @abstractmethod
    def fit(self, data: LineData, rigid: ModelFit | None = None) -> ModelFit:
        """Fit to the measurements, from the last fit where its lines and configurations
        carry over (measurements are only ever appended).

        Args:
            data: the measurements.
            rigid: the rigid model's fit to them: a joint that did not move is the rigid
                model (fitted here when not given; the rigid model ignores it).
        """


# ------------------------------------------------------------------------- line models


@dataclass
class LineState:
    """Edge lines at the reference configurations, motions, and the joint.

    ``eps`` (J, 3) unit directions, ``a`` (J, 3) points (m), ``q`` (M,) motions (m or rad; 0
    at references); ``joint`` the prismatic direction (3,), or the revolute axis
    ``(u, p)``; None for rigid. ``memo`` holds what a solve about this state as its start
    computes once (bases, the prior's whitening).
    """

    eps: np.ndarray
    a: np.ndarray
    q: np.ndarray
    joint: object = None
    memo: dict = field(default_factory=dict, repr=False, compare=False)


def rotations(u: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations by angles q about the unit axis u (Rodrigues)."""
    k = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def normalise(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


_SOLVER_MAX_ITER = 50
# A solve starts again from where it got once a direction turned by more than this (rad),
# at most _MAX_RECENTRES times.
_RECENTRE = 0.3
_MAX_RECENTRES = 5


def minimise(fun, jac, precision: np.ndarray) -> np.ndarray:
    """Levenberg-Marquardt on ``|fun(x)|^2 + sum(precision x^2)`` from x = 0.

    The second term is the flat priors' curvature about the start (as in the evidence): it
    keeps the directions the data do not determine at the start instead of letting them
    wander, and moves the others by a negligible share. Nielsen's damping from 0 (pure
    Gauss-Newton: a good start needs nothing else); a step is kept only when the cost drops,
    and the solve stops once a step gains less than 1e-4 of the cost.
    Why not ``scipy.optimize.least_squares``: docs/design.md 6.10.

    Args:
        fun: residuals (M,) at x.
        jac: their Jacobian (M, P) at x.
        precision: (P,) the priors' precisions.

    Returns:
        (P,) the minimiser.
    """
    x = np.zeros(precision.size)
    r = fun(x)
    cost = float(r @ r)
    lam, nu = 0.0, 2.0
    for _ in range(_SOLVER_MAX_ITER):
        j = jac(x)
        g = j.T @ r + precision * x
        h = j.T @ j
        h[np.diag_indices_from(h)] += precision
        dh = np.diag(h).copy()
        while True:
            try:
                step = np.linalg.solve(h + np.diag(lam * dh), -g)
            except np.linalg.LinAlgError:
                step = np.linalg.lstsq(h + np.diag(lam * dh), -g, rcond=None)[0]
            xn = x + step
            rn = fun(xn)
            new = float(rn @ rn) + float(precision @ (xn * xn))
            if new <= cost:
                pred = -float(step @ g) - 0.5 * float(step @ (h @ step))
                ratio = (cost - new) / (2.0 * pred) if pred > 0 else 1.0
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
                nu = 2.0
                break
            lam = max(lam * nu, 1e-6)
            nu *= 2.0
            if lam > 1e10:
                return x
        # Wrong models have large residuals, where Gauss-Newton converges linearly: stop
        # once a step gains less than 1e-4 of the cost (the evidence's quadratic step takes
        # what is left; on the benchmark's draws no probability moved).
        done = cost - new <= 1e-4 * (1.0 + cost)
        x, r, cost = xn, rn, new
        if done:
            break
    return x


def small_motions(data: LineData, turns: bool, planar: bool):
    """Each line at its reference and each configuration's small motion, by linear least
    squares: the starts of the jointed models.

    A configuration's motion is taken as a twist: the link's points move by
    ``omega x (y - c) + tau`` (c the contact points' centroid), its directions by
    ``omega x e``. To first order in the twists and in the lines' corrections about their
    mean (``eps``, ``a``), every measurement is linear in them: its edge's part normal to
    ``eps`` is ``d_eps + B^T (omega x eps)``, its contact's part
    ``d_a + B^T (omega x (a - c) + tau) + t (d_eps + B^T (omega x eps))``, t the contact's
    place along the edge (B a basis normal to ``eps``). A revolute joint makes the twists
    one zero-pitch screw scaled, a prismatic one a translation scaled.

    Args:
        data: the measurements.
        turns: whether the twists turn (else translations only, omega = 0).
        planar: turns about z only.

    Returns:
        ``(eps, a, omega, tau, centre)``: the lines at their references (J, 3), the free
        configurations' twists (F, 3) each, and c (3,).
    """
    eps, a = mean_lines(data)
    centre = data.x.mean(axis=0)
    j, free = data.n_lines, data.free_configs
    frame = np.array([basis(v) for v in eps]).reshape(-1, 2, 3)
    n_rot = (1 if planar else 3) if turns else 0
    per_config = n_rot + 3
    col = np.full(data.n_configs, -1)
    col[free] = 4 * j + per_config * np.arange(free.size)
    mat = np.zeros((data.n, 4, 4 * j + per_config * free.size))
    rhs = np.zeros((data.n, 4))
    for i in range(data.n):
        li, k = data.line[i], col[data.config[i]]
        b, e_bar, a_bar = frame[li], eps[li], a[li]
        w = data.x[i] - a_bar
        t = float(w @ e_bar)
        rhs[i, :2] = b @ (data.e[i] - e_bar) / data.edge_std[i]
        rhs[i, 2:] = b @ w / data.sx[i]
        mat[i, 0:2, 4 * li : 4 * li + 2] = np.eye(2) / data.edge_std[i]
        mat[i, 2:4, 4 * li : 4 * li + 2] = t * np.eye(2) / data.sx[i]
        mat[i, 2:4, 4 * li + 2 : 4 * li + 4] = np.eye(2) / data.sx[i]
        if k < 0:
            continue
        if n_rot:
            # omega x v = -[v]x omega.
            rot_e = -b @ _skew(e_bar)
            rot_a = -b @ _skew(a_bar - centre) + t * rot_e
            if planar:
                rot_e, rot_a = rot_e[:, 2:], rot_a[:, 2:]
            mat[i, 0:2, k : k + n_rot] = rot_e / data.edge_std[i]
            mat[i, 2:4, k : k + n_rot] = rot_a / data.sx[i]
        mat[i, 2:4, k + n_rot : k + per_config] = b / data.sx[i]
    sol = np.linalg.lstsq(mat.reshape(4 * data.n, -1), rhs.ravel(), rcond=None)[0]
    lines = sol[: 4 * j].reshape(j, 4)
    eps_ref = normalise(eps + np.einsum("jm,jmk->jk", lines[:, :2], frame))
    a_ref = a + np.einsum("jm,jmk->jk", lines[:, 2:], frame)
    motion = sol[4 * j :].reshape(free.size, per_config)
    omega = np.zeros((free.size, 3))
    if planar and n_rot:
        omega[:, 2] = motion[:, 0]
    else:
        omega[:, :n_rot] = motion[:, :n_rot]
    return eps_ref, a_ref, omega, motion[:, n_rot:], centre


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def mean_lines(data: LineData, back=None):
    """Each line's mean direction and mean point over its measurements, after ``back``
    (rotations (N, 3, 3) about a centre (3,)) undid each measurement's motion."""
    e, x = data.e, data.x
    if back is not None:
        rot, centre = back
        e = np.einsum("iab,ib->ia", rot, e)
        x = centre + np.einsum("iab,ib->ia", rot, x - centre)
    j = data.n_lines
    count = np.bincount(data.line, minlength=j)
    eps = np.zeros((j, 3))
    np.add.at(eps, data.line, e)
    a = np.zeros((j, 3))
    np.add.at(a, data.line, x)
    a /= count[:, None]
    norm = np.linalg.norm(eps, axis=1)
    # Opposite edges given one label cancel: then the first one's direction.
    first = e[[int(np.flatnonzero(data.line == i)[0]) for i in range(j)]]
    ok = norm > 1e-6 * count
    eps = np.where(ok[:, None], eps / np.where(ok, norm, 1.0)[:, None], first)
    return eps, a


class LineModel(JointModel):
    """What the three models share: the lines, the motions and the joint's parameters
    fitted together by :func:`minimise`, the Laplace evidence, and the mixture of a link that
    did not move.

    Subclasses say how the joint moves a line (:meth:`_predict`, :meth:`_motion_rows`) and
    what its parameters are (:meth:`_n_joint`, :meth:`_joint_value`, :meth:`_joint_rows`,
    :meth:`_joint_prior`), each in local coordinates about a start.
    """

    motion_range: float = 1.0  # m or rad: the range of a configuration's motion

    # --- what a subclass says

    @abstractmethod
    def _predict(self, data: LineData, state: LineState):
        """(eps_p, a_p, rot): each measurement's predicted line (N, 3), and the rotation of
        its line (N, 3, 3), None where lines only translate."""

    def _motion_rows(self, data, state, eps_p, a_p):
        """(deps, da), each (N, 3): the change of each prediction per unit of its motion."""
        zero = np.zeros((data.n, 3))
        return zero, zero

    def _n_joint(self) -> int:
        """Number of the joint's parameters."""
        return 0

    def _joint_value(self, start: LineState, xj: np.ndarray, eps: np.ndarray):
        """The joint at local coordinates xj about ``start.joint`` (``eps``: the lines'
        directions there)."""
        return start.joint

    def _joint_rows(self, data, state, eps_p, a_p, rot, start, xj):
        """(deps, da), each (N, K, 3): the change of each prediction per unit of each of the
        joint's K local coordinates, at xj about ``start.joint``."""
        zero = np.zeros((data.n, 0, 3))
        return zero, zero

    def _joint_prior(self, state, start, xj):
        """The joint's prior at xj about ``start.joint``: (precisions (K,) of its flat
        part, its log density up to the Gaussian part's quadratic term, the Gaussian part's
        whitened residuals (R,) and their Jacobian (R, K) in xj, or None, None)."""
        return np.zeros(0), 0.0, None, None

    # --- the machinery

    def _frame(self, state: LineState) -> np.ndarray:
        """(J, 2, 3) bases normal to the line directions: a line's local coordinates turn
        its direction and move its point along them."""
        return np.array([basis(v) for v in state.eps]).reshape(-1, 2, 3)

    def _unpack(self, data, start, frame, x) -> LineState:
        j = start.eps.shape[0]
        lines = x[: 4 * j].reshape(j, 4)
        eps = normalise(start.eps + np.einsum("jm,jmk->jk", lines[:, :2], frame))
        a = start.a + np.einsum("jm,jmk->jk", lines[:, 2:], frame)
        q = start.q.copy()
        free = data.free_configs
        q[free] += x[4 * j : 4 * j + free.size]
        return LineState(eps, a, q, self._joint_value(start, x[4 * j + free.size :], eps))

    def _jacobian(self, data, start, frame, x, state) -> np.ndarray:
        """(6N, P) Jacobian of the measurements' residuals in the local coordinates x about
        start (lines, free motions, joint)."""
        eps_p, a_p, rot = self._predict(data, state)
        j = start.eps.shape[0]
        free = data.free_configs
        n_joint = self._n_joint()
        p = 4 * j + free.size + n_joint
        jac = np.zeros((data.n, 6, p))
        # d eps / d delta_m = (I - eps eps^T) b_m / |eps0 + B delta|; d a / d alpha_m = b_m.
        raw = start.eps + np.einsum("jm,jmk->jk", x[: 4 * j].reshape(j, 4)[:, :2], frame)
        f = frame[data.line]
        e_line = state.eps[data.line]
        deps = f - np.einsum("imk,ik->im", f, e_line)[:, :, None] * e_line[:, None, :]
        deps /= np.linalg.norm(raw, axis=1)[data.line][:, None, None]
        deps = np.concatenate([deps, np.zeros_like(f)], axis=1)
        da = np.concatenate([np.zeros_like(f), f], axis=1)
        if rot is not None:
            deps = np.einsum("iab,imb->ima", rot, deps)
            da = np.einsum("iab,imb->ima", rot, da)
        rows = line_rows(data, eps_p, a_p, deps, da)
        idx = np.arange(data.n)
        for m in range(4):
            jac[idx, :, 4 * data.line + m] = rows[:, :, m]
        if free.size:
            col = np.full(data.n_configs, -1)
            col[free] = 4 * j + np.arange(free.size)
            moved = col[data.config] >= 0
            dq_eps, dq_a = self._motion_rows(data, state, eps_p, a_p)
            qrows = line_rows(data, eps_p, a_p, dq_eps[:, None], dq_a[:, None])[:, :, 0]
            jac[idx[moved], :, col[data.config][moved]] = qrows[moved]
        if n_joint:
            xj = x[4 * j + free.size :]
            deps_j, da_j = self._joint_rows(data, state, eps_p, a_p, rot, start, xj)
            jac[:, :, p - n_joint :] = line_rows(data, eps_p, a_p, deps_j, da_j)
        return jac.reshape(6 * data.n, p)

    def _residuals(self, data, state) -> np.ndarray:
        eps_p, a_p, _ = self._predict(data, state)
        return line_residuals(data, eps_p, a_p).ravel()

    def _problem(self, data: LineData, start: LineState):
        """(fun, jac, precisions, unpack) in local coordinates about start: the
        measurements' residuals followed by the joint prior's Gaussian ones."""
        frame = self._frame(start)
        j = start.eps.shape[0]
        free = data.free_configs
        k = self._n_joint()
        n_x = 4 * j + free.size + k

        def unpack(x):
            return self._unpack(data, start, frame, x)

        def fun(x):
            state = unpack(x)
            r = self._residuals(data, state)
            prior_r = self._joint_prior(state, start, x[n_x - k :])[2]
            return r if prior_r is None else np.concatenate([r, prior_r])

        def jac(x):
            state = unpack(x)
            jm = self._jacobian(data, start, frame, x, state)
            _, _, prior_r, prior_j = self._joint_prior(state, start, x[n_x - k :])
            if prior_r is None:
                return jm
            rows = np.zeros((prior_r.size, n_x))
            rows[:, n_x - k :] = prior_j
            return np.concatenate([jm, rows])

        w2 = self.prior.workspace**2
        precision = np.concatenate(
            [
                np.tile([0.5, 0.5, 2.0 * math.pi / w2, 2.0 * math.pi / w2], j),
                np.full(free.size, 2.0 * math.pi / self.motion_range**2),
                self._joint_prior(start, start, np.zeros(k))[0],
            ]
        )
        return fun, jac, precision, unpack

    def _solve(self, data: LineData, start: LineState) -> LineState:
        """The lines, motions and joint that minimise the residuals and the priors' cost.

        A direction's local coordinates describe it well near the start only: when one has
        turned by more than ``_RECENTRE`` rad, the solve starts again from where it got.
        """
        for _ in range(_MAX_RECENTRES):
            fun, jac, precision, unpack = self._problem(data, start)
            x = minimise(fun, jac, precision)
            state = unpack(x)
            if not np.abs(x[self._angle_coords(data, start)]).max(initial=0.0) > _RECENTRE:
                break
            start = state
        return state

    def _angle_coords(self, data: LineData, start: LineState) -> np.ndarray:
        """Indices of the local coordinates that turn a direction (the lines' first two,
        then the joint's ``_n_joint_angles``)."""
        j = start.eps.shape[0]
        lines = (4 * np.arange(j)[:, None] + np.arange(2)).ravel()
        first = 4 * j + data.free_configs.size
        return np.concatenate([lines, first + np.arange(self._n_joint_angles())])

    def _n_joint_angles(self) -> int:
        """How many of the joint's leading local coordinates turn a direction."""
        return 0

    def _cost(self, data: LineData, state: LineState) -> float:
        """The residuals' and the Gaussian priors' cost at a state."""
        fun, _, precision, _ = self._problem(data, state)
        r = fun(np.zeros(precision.size))
        return float(r @ r)

    def _evidence(self, data: LineData, state: LineState, rigid_log_evidence=None):
        """(Evidence, info) at a fitted state; the log evidence in ``info`` includes the
        mixture of a link that did not move (given the rigid model's evidence)."""
        fun, jac, precision, _ = self._problem(data, state)
        x0 = np.zeros(precision.size)
        r_all, j_all = fun(x0), jac(x0)
        m = 6 * data.n
        prior_r = j_prior = None
        if r_all.size > m:
            prior_r, j_prior = r_all[m:], j_all[m:]
        j = state.eps.shape[0]
        free = data.free_configs
        k = self._n_joint()
        # Flat priors: a line's direction uniform on the sphere (4 pi) and its position over
        # workspace^2; a motion uniform over its range.
        log_prior = -j * (math.log(4.0 * math.pi) + 2.0 * math.log(self.prior.workspace))
        log_prior -= free.size * math.log(self.motion_range)
        log_prior += self._joint_prior(state, state, np.zeros(k))[1]
        ev = laplace_evidence(data, r_all[:m], j_all[:m], precision, log_prior, prior_r, j_prior)
        log_z = ev.log_evidence
        if self.prior.stuck_probability > 0.0 and free.size and rigid_log_evidence is not None:
            log_z = self._with_stuck(log_z, free.size, rigid_log_evidence)
        info = {
            "log_evidence": log_z,
            "joint_cols": np.arange(precision.size - k, precision.size),
            "prior_jac": j_prior,
            "precision": precision,
        }
        return ev, info

    def _with_stuck(self, log_moving: float, k: int, rigid_log_evidence: float) -> float:
        """The evidence when each of the k configuration changes failed to move the link
        with the stuck probability: with all of them failed (``stuck^k``) the joint never
        moved and the evidence is the rigid model's, exactly (its lines have the same
        priors); otherwise the motions are uniform over their range (``log_moving``)."""
        log_still = k * math.log(self.prior.stuck_probability)
        return float(
            np.logaddexp(
                math.log(-math.expm1(log_still)) + log_moving, log_still + rigid_log_evidence
            )
        )

    def _identified(self, ev: Evidence, info: dict) -> bool:
        """Whether the measurements, not the prior, set the joint: in every direction the
        prior gives at most ``_PRIOR_SHARE`` of the posterior information."""
        cols = info["joint_cols"]
        if cols.size == 0:
            return True
        lam = np.diag(info["precision"][cols])
        if info["prior_jac"] is not None:
            pj = info["prior_jac"][:, cols]
            lam = lam + pj.T @ pj
        share = np.linalg.eigvals(lam @ ev.covariance[np.ix_(cols, cols)]).real
        return bool(share.max() <= _PRIOR_SHARE)

    def _model_fit(self, data, ev, info, parameters, covariance, identified, axis=None):
        return ModelFit(
            joint_type=self.joint_type,
            log_evidence=info["log_evidence"],
            log_likelihood=ev.log_likelihood,
            chi2=ev.chi2,
            dof=DOF_PER_MEASUREMENT * data.n - ev.effective_params,
            n_params=info["precision"].size,
            effective_params=ev.effective_params,
            parameters=parameters,
            covariance=covariance,
            identified=identified,
            axis=axis,
        )

    # --- starts

    def _warm(self, cold: LineState) -> LineState:
        """The cold start with the last fit's lines, motions and joint where they exist."""
        old = self._state
        if old is None:
            return cold
        j = min(old.eps.shape[0], cold.eps.shape[0])
        m = min(old.q.shape[0], cold.q.shape[0])
        cold.eps[:j], cold.a[:j], cold.q[:m] = old.eps[:j], old.a[:j], old.q[:m]
        cold.joint = old.joint
        return cold

    def _rigid_log_evidence(self, data: LineData, rigid: ModelFit | None) -> float:
        if rigid is None:
            rigid = RigidModel(self.mode, self.prior).fit(data)
        return rigid.log_evidence


class RigidModel(LineModel):
    """The edge lines do not move. Parameters: none beyond the lines."""

    joint_type = "rigid"

    def _predict(self, data, state):
        return state.eps[data.line], state.a[data.line], None

    def fit(self, data: LineData, rigid: ModelFit | None = None) -> ModelFit:
        # No motions: every configuration is its own reference.
        flat = dataclasses.replace(data, reference=np.ones(data.n_configs, dtype=bool))
        eps, a = mean_lines(flat)
        state = self._solve(flat, self._warm(LineState(eps, a, np.zeros(data.n_configs))))
        self._state = state
        ev, info = self._evidence(flat, state)
        return self._model_fit(data, ev, info, np.zeros(0), None, True)


def saturated_evidence(data: LineData, prior: JointTypePrior) -> float:
    """Log evidence that no joint model holds: every measurement its own edge line.

    The rigid model with one line per measurement fits each exactly, so this is the
    measurements' likelihood maximum less the price of a free line for every one of them
    (docs/design.md 6.10).
    """
    own = dataclasses.replace(
        data,
        line=np.arange(data.n),
        config=np.arange(data.n),
        reference=np.ones(data.n, dtype=bool),
    )
    model = RigidModel("3d", prior)
    state = LineState(data.e.copy(), data.x.copy(), np.zeros(data.n))
    return model._evidence(own, state)[1]["log_evidence"]
