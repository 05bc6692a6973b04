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
free parameters and the Laplace evidence under the priors of :class:`JointTypePrior`.
"""

from __future__ import annotations

import dataclasses
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from scipy.stats import chi2 as chi2_dist

from tactile_gym.estimation.axis import COVARIANCE_LAYOUT, AxisEstimate, canonical_direction
from tactile_gym.estimation.lines import (
    DOF_PER_MEASUREMENT,
    EDGE_STD_FLOOR,
    Evidence,
    LineData,
    laplace_evidence,
    line_residuals,
    line_rows,
)
from tactile_gym.estimation.online import COVARIANCES, JointAxisEstimator
from tactile_gym.estimation.prior import PIN_STD_FLOOR, AxisPrior
from tactile_gym.estimation.problem import PriorTerm, basis
from tactile_gym.estimation.robust import check_loss
from tactile_gym.vec3 import cross_rows

__all__ = [
    "JOINT_TYPES",
    "PARAMETER_LAYOUTS",
    "JointModel",
    "JointTypePrior",
    "ModelFit",
    "PrismaticModel",
    "RevoluteModel",
    "RigidModel",
    "minimise",
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

_EZ = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class JointTypePrior:
    """What is known before touching: the priors of the joint-type models (docs/design.md 6.10).

    Attributes:
        type_probabilities: prior probabilities of rigid, revolute and prismatic (> 0; they
            are normalised with ``none_probability``).
        none_probability: prior probability that no model holds (every measurement its own
            line: inconsistent data), in (0, 1).
        axis: Gaussian prior of a revolute axis, e.g. the reset distribution's
            (:meth:`AxisPrior.from_samples`); None: a broad one centred on the first contact
            (pin std ``workspace / sqrt(2 pi)`` per axis; ``"3d"``: direction z with an RMS
            angle of sqrt(2) rad, the tangent-plane Gaussian whose peak is the uniform
            density on the hemisphere).
        workspace: side of the region the edge lines lie in, m: an edge line's position has a
            uniform prior over ``workspace^2`` normal to it.
        turn_range: range of a revolute joint's angle, rad: a configuration's turn has a
            uniform prior of density ``1 / turn_range``.
        travel_range: range of a prismatic joint's travel, m: likewise for its shift.
        stuck_probability: chance that a change of configuration left the link where it
            was (held by its friction, or not pushed), in [0, 1), each independently: a
            jointed link that never moved over k changes (probability ``stuck^k``) looks
            rigid; otherwise its motions are uniform over their range.
        along_edge_probability: chance that a prismatic joint slides along one of the
            measured edge lines (drawers slide along their sides), in [0, 1); otherwise its
            direction is uniform (hemisphere; ``"planar"``: half circle).

    Raises:
        ValueError: on a value out of its range.
    """

    type_probabilities: tuple[float, float, float] = (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0)
    none_probability: float = 0.01
    axis: AxisPrior | None = None
    workspace: float = 1.0
    turn_range: float = math.pi
    travel_range: float = 0.2
    stuck_probability: float = 0.5
    along_edge_probability: float = 0.5

    def __post_init__(self) -> None:
        probs = tuple(float(p) for p in self.type_probabilities)
        if len(probs) != 3 or not all(math.isfinite(p) and p > 0 for p in probs):
            raise ValueError(
                "type_probabilities must be three finite numbers > 0 (rigid, revolute, "
                f"prismatic), got {self.type_probabilities!r}"
            )
        object.__setattr__(self, "type_probabilities", probs)
        _check_range("none_probability", self.none_probability, 0.0, 1.0, open_low=True)
        for name in ("workspace", "turn_range", "travel_range"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                unit = "rad" if name == "turn_range" else "m"
                raise ValueError(f"{name} must be a finite number > 0 {unit}, got {value!r}")
        _check_range("stuck_probability", self.stuck_probability, 0.0, 1.0)
        _check_range("along_edge_probability", self.along_edge_probability, 0.0, 1.0)
        if self.axis is not None and not isinstance(self.axis, AxisPrior):
            raise ValueError(f"axis must be an AxisPrior or None, got {type(self.axis).__name__}")

    @property
    def log_outcome_priors(self) -> np.ndarray:
        """(4,) log prior probabilities of rigid, revolute, prismatic and none."""
        p = np.array(self.type_probabilities)
        p = p / p.sum() * (1.0 - self.none_probability)
        return np.log(np.append(p, self.none_probability))

    def axis_prior(self, mode: str, first_point: np.ndarray) -> AxisPrior:
        """The revolute axis prior: ``axis``, or the broad default about ``first_point``."""
        if self.axis is not None:
            return self.axis
        var = self.workspace**2 / (2.0 * math.pi)
        if mode == "planar":
            return AxisPrior(first_point, np.diag([var, var, 0.0]), _EZ, 0.0)
        return AxisPrior(first_point, var * np.eye(3), _EZ, math.sqrt(2.0))


def _check_range(name: str, value: float, low: float, high: float, open_low=False) -> None:
    v = float(value)
    ok = (v > low if open_low else v >= low) and v < high
    if not (math.isfinite(v) and ok):
        bracket = "(" if open_low else "["
        raise ValueError(f"{name} must be in {bracket}{low}, {high}), got {value!r}")


@dataclass(frozen=True)
class ModelFit:
    """One joint-type model fitted to the measurements.

    Attributes:
        joint_type: ``"rigid"``, ``"revolute"`` or ``"prismatic"``.
        log_evidence: ``ln p(measurements | type)``: the Laplace approximation over every
            parameter (lines, motions, joint) under the :class:`JointTypePrior`, with its
            mixtures (a link that did not move; a slide along a measured edge).
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
        self._state: _LineState | None = None

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
class _LineState:
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


def _rotations(u: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations by angles q about the unit axis u (Rodrigues)."""
    k = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def _normalise(v: np.ndarray) -> np.ndarray:
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
    eps, a = _mean_lines(data)
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
    eps_ref = _normalise(eps + np.einsum("jm,jmk->jk", lines[:, :2], frame))
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


def _mean_lines(data: LineData, back=None):
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


class _LineModel(JointModel):
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
    def _predict(self, data: LineData, state: _LineState):
        """(eps_p, a_p, rot): each measurement's predicted line (N, 3), and the rotation of
        its line (N, 3, 3), None where lines only translate."""

    def _motion_rows(self, data, state, eps_p, a_p):
        """(deps, da), each (N, 3): the change of each prediction per unit of its motion."""
        zero = np.zeros((data.n, 3))
        return zero, zero

    def _n_joint(self) -> int:
        """Number of the joint's parameters."""
        return 0

    def _joint_value(self, start: _LineState, xj: np.ndarray, eps: np.ndarray):
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

    def _frame(self, state: _LineState) -> np.ndarray:
        """(J, 2, 3) bases normal to the line directions: a line's local coordinates turn
        its direction and move its point along them."""
        return np.array([basis(v) for v in state.eps]).reshape(-1, 2, 3)

    def _unpack(self, data, start, frame, x) -> _LineState:
        j = start.eps.shape[0]
        lines = x[: 4 * j].reshape(j, 4)
        eps = _normalise(start.eps + np.einsum("jm,jmk->jk", lines[:, :2], frame))
        a = start.a + np.einsum("jm,jmk->jk", lines[:, 2:], frame)
        q = start.q.copy()
        free = data.free_configs
        q[free] += x[4 * j : 4 * j + free.size]
        return _LineState(eps, a, q, self._joint_value(start, x[4 * j + free.size :], eps))

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

    def _problem(self, data: LineData, start: _LineState):
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

    def _solve(self, data: LineData, start: _LineState) -> _LineState:
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

    def _angle_coords(self, data: LineData, start: _LineState) -> np.ndarray:
        """Indices of the local coordinates that turn a direction (the lines' first two,
        then the joint's ``_n_joint_angles``)."""
        j = start.eps.shape[0]
        lines = (4 * np.arange(j)[:, None] + np.arange(2)).ravel()
        first = 4 * j + data.free_configs.size
        return np.concatenate([lines, first + np.arange(self._n_joint_angles())])

    def _n_joint_angles(self) -> int:
        """How many of the joint's leading local coordinates turn a direction."""
        return 0

    def _cost(self, data: LineData, state: _LineState) -> float:
        """The residuals' and the Gaussian priors' cost at a state."""
        fun, _, precision, _ = self._problem(data, state)
        r = fun(np.zeros(precision.size))
        return float(r @ r)

    def _evidence(self, data: LineData, state: _LineState, rigid_log_evidence=None):
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

    def _warm(self, cold: _LineState) -> _LineState:
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


class RigidModel(_LineModel):
    """The edge lines do not move. Parameters: none beyond the lines."""

    joint_type = "rigid"

    def _predict(self, data, state):
        return state.eps[data.line], state.a[data.line], None

    def fit(self, data: LineData, rigid: ModelFit | None = None) -> ModelFit:
        # No motions: every configuration is its own reference.
        flat = dataclasses.replace(data, reference=np.ones(data.n_configs, dtype=bool))
        eps, a = _mean_lines(flat)
        state = self._solve(flat, self._warm(_LineState(eps, a, np.zeros(data.n_configs))))
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
    state = _LineState(data.e.copy(), data.x.copy(), np.zeros(data.n))
    return model._evidence(own, state)[1]["log_evidence"]


class PrismaticModel(_LineModel):
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
            return np.cross(_EZ, v)[None]
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
        return _normalise(start.joint + xj @ self._tangents(start.joint))

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

    def _cold(self, data: LineData) -> _LineState:
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
        return _LineState(eps, a, q, v)

    def along_lines(self, data: LineData, state: _LineState) -> list[tuple[int, list[int]]]:
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

    def _edge_direction(self, state: _LineState, ev: Evidence) -> tuple[np.ndarray, np.ndarray]:
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


class RevoluteModel(_LineModel):
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
        u = _normalise(u0 + xj[:nt] @ turn) if nt else u0
        return u, p0 + xj[nt:] @ move

    def _predict(self, data, state):
        u, p = state.joint
        rot = _rotations(u, state.q[data.config])
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
        u = w0 / math.sqrt(norm2) if self.mode == "3d" else _EZ
        return u, centre + np.cross(w0, t0) / norm2

    def _cold(self, data: LineData, u: np.ndarray, p: np.ndarray) -> _LineState:
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
        eps, a = _mean_lines(data, (_rotations(u, -q[data.config]), p))
        return _LineState(eps, a, q, (u, p))

    def fit(self, data: LineData, rigid: ModelFit | None = None) -> ModelFit:
        log_rigid = self._rigid_log_evidence(data, rigid)
        axis = self._axis(data)
        self._axis_prior = self._axis_fit.prior
        u = axis.direction if self.mode == "3d" else _EZ
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


def _unnormalised_axis(start: _LineState, turn: np.ndarray, xj: np.ndarray) -> np.ndarray:
    """The unnormalised turned axis direction ``u0 + B alpha`` of the local coordinates."""
    return start.joint[0] + xj[: turn.shape[0]] @ turn
