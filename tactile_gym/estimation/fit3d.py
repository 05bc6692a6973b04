"""3D joint-axis fit from contact points and edge directions (paper eq. 3, 8, 9-10).

:func:`fit_axis_3d` validates the input, resolves the edge signs and fits the general
model (:mod:`.general`), after a consensus with a robust loss (:mod:`.selection`), and the
parallel model (:mod:`.parallel`) when the edges call for it, choosing between them
(docs/design.md 6.2, 6.4). :class:`Fit3D` is the same fit behind the
:class:`~tactile_gym.estimation.interface.AxisFit` interface, with warm-started updates for
the online estimator.

Conventions: world frame, metres, radians; the result follows
:class:`~tactile_gym.estimation.axis.AxisEstimate` (``point . direction = 0``, direction with
its largest-magnitude component positive).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from tactile_gym.estimation.axis import (
    AxisEstimate,
    as_noise,
    as_points,
    as_unit_edges,
    as_weights,
    degenerate_estimate,
    isotropic_edge_covs,
)
from tactile_gym.estimation.general import (
    Solution,
    finish_general,
    fit_general,
    invariants,
    refine_general,
    refine_start,
    sign_norms,
    total_cost,
    whiten,
)
from tactile_gym.estimation.interface import AxisFit, Measurements
from tactile_gym.estimation.parallel import (
    fit_parallel,
)
from tactile_gym.estimation.prior import AxisPrior, check_prior
from tactile_gym.estimation.problem import (
    Noise,
    Problem,
)
from tactile_gym.estimation.robust import (
    CHI2_99,
    OUTLIER_GATE,
    check_loss,
    sign_flips,
)
from tactile_gym.estimation.selection import (
    line_consensus,
    parallel_fraction,
    prefer_parallel,
)
from tactile_gym.spatial import orient_edges

__all__ = ["Fit3D", "fit_axis_3d"]

_DEFAULT_PARALLEL_TOL = math.radians(1.0)

# From this many measurements on, a robust fit starts from a consensus (docs/design.md 6.4).
CONSENSUS_MIN_N = 6


def fit_axis_3d(
    points: np.ndarray,
    edges: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    point_std: np.ndarray | float | None = None,
    edge_std: np.ndarray | float | None = None,
    edge_cov: np.ndarray | None = None,
    loss: str = "linear",
    f_scale: float | None = None,
    parallel_tol: float = _DEFAULT_PARALLEL_TOL,
    resolve_signs: bool = True,
    prior: AxisPrior | None = None,
) -> AxisEstimate:
    """Fit a joint axis of any direction to contact points and edge directions.

    Args:
        points: (N, 3) contact points, world frame, m.
        edges: (N, 3) edge directions, world frame (normalised here; orientation resolved
            as described under ``resolve_signs``).
        weights: optional (N,) relative weights >= 0 (dimensionless multipliers of each
            measurement's inverse variance; 0 drops it).
        point_std: contact-point std per axis, m; scalar or (N,). With ``edge_std`` or
            ``edge_cov``.
        edge_std: total RMS angle error of each edge, rad; scalar or (N,). The noise is then
            isotropic about the edge: ``edge_cov = (edge_std^2 / 2) (I - e e^T)``.
        edge_cov: alternative to ``edge_std``: (N, 3, 3) covariance of the perturbation of
            each unit edge (normal to it), world frame, rad^2; ``edge_std^2`` is its trace.
            The part along the edge is ignored, and it holds for either sign of the edge.
        loss: ``"linear"`` (least squares) or a robust loss of scipy's least_squares:
            ``"soft_l1"``, ``"huber"``, ``"cauchy"``. With a robust loss and N >= 6 a
            RANSAC-style consensus over 3-line closed-form fits (fixed seed, adaptive
            number of trials, at most 24) first removes wild measurements; ``n_used``
            then counts the measurements kept.
        f_scale: residual level where the robust loss starts to bend, in standard
            deviations when stds are given (default 2), else in metres (default: 2 x a
            MAD-based noise estimate from the initial guess).
        parallel_tol: the model of edges parallel to the axis (eq. 9-10) is fitted too
            when all the edges (robust losses: two thirds) lie within
            ``max(parallel_tol, 4 * s)`` rad of their mean direction, where s is the median
            over the measurements of the edge std in its worst direction; it is chosen
            unless the general model explains more of the measurements it rejects than
            the other way round (at least two; see ``prefer_parallel``). Edges parallel
            to each other need not be parallel to the axis: measurements taken at one
            link angle.
        resolve_signs: orient each edge like the best-aligned of the previous
            ``SIGN_LOOKBACK`` (already oriented) edges; a wild edge then cannot flip all
            that follow. Pass False for edges already oriented consistently.
        prior: optional :class:`~tactile_gym.estimation.prior.AxisPrior`, fused as a
            Gaussian prior (maximum a posteriori; see that module): four residuals on the
            axis direction and on the offset of the prior pin from the axis line, whitened
            by the prior's spread and never robustified. Needs ``point_std``. The covariance
            then includes the prior. With no measurement the estimate is the prior's.

    Returns:
        The estimate, ``method="3d"`` or ``"3d-parallel"`` (``"prior"`` with a prior and
        no measurement). ``degenerate=True`` when the data do not determine the axis
        (without a prior): fewer than 3 measurements (general case: fewer than three
        distinct edge lines), identical measurements, collinear contact points in the
        parallel case, or a rank-deficient Jacobian.

    Raises:
        ValueError: on malformed input (shapes, non-finite values, zero edges, negative
            stds or weights, an edge_cov not symmetric positive semi-definite, unknown
            loss, f_scale <= 0, a prior that is not an AxisPrior or without stds).
    """
    x = as_points(points, "points", dims=(3,))
    n = x.shape[0]
    e = as_unit_edges(edges, n, dims=(3,))
    check_loss(loss, f_scale)
    if not (math.isfinite(parallel_tol) and 0 <= parallel_tol < math.pi / 2):
        raise ValueError(f"parallel_tol must be in [0, pi/2) rad, got {parallel_tol!r}")
    sx, se, cov = as_noise(point_std, edge_std, edge_cov, e)
    check_prior(prior, sx is not None)
    noise = None if sx is None else Noise(sx, isotropic_edge_covs(e, se) if cov is None else cov)
    w = np.ones(n) if weights is None else as_weights(weights, n)
    keep = w > 0
    if not keep.all():
        x, e, w = x[keep], e[keep], w[keep]
        if noise is not None:
            noise = noise.take(keep)
    if resolve_signs:
        e = orient_edges(e)
    return _fit_state(x, e, w, noise, loss, f_scale, parallel_tol, prior)[0]


def _fit_state(x, e, w, noise, loss, f_scale, parallel_tol, prior=None):
    """The estimate of validated, oriented data and the :class:`Solution` of a
    general-case fit (else None); with the :class:`AxisPrior` ``prior`` if given (it needs
    ``noise``), from one measurement on (none: the prior's estimate).

    When enough edges lie near their mean direction (all of them, robust losses: two
    thirds) the parallel model (eq. 9-10) is fitted too, and the models are compared (see
    :func:`prefer_parallel`): edges parallel to *each other* are not enough, as when most
    measurements were taken at one link angle.
    """
    n = x.shape[0]
    if prior is not None and n == 0:
        return prior.estimate(), None
    if prior is None and n < 3:
        return degenerate_estimate("3d", n, planar=False), None
    tol = parallel_tol
    if noise is not None:
        tol = max(tol, 4.0 * float(np.median(noise.worst_edge_std())))
    mean_dir, frac = parallel_fraction(e, tol)
    est, sol = _fit_general_state(x, e, w, noise, loss, f_scale, prior)
    if frac < (1.0 if loss == "linear" else 2.0 / 3.0):
        return est, sol
    est_par = fit_parallel(Problem(x, e, w, noise, loss, f_scale, prior), mean_dir)
    if est_par.degenerate or not (
        est.degenerate
        or prefer_parallel(Problem(x, e, w, noise, loss, f_scale, prior), sol, est_par)
    ):
        return est, sol
    return est_par, None


def _fit_general_state(x, e, w, noise, loss, f_scale, prior, multi_start=False):
    """:func:`_fit_state`'s general-case fit: a consensus first (robust losses, N >= 6)."""
    n = x.shape[0]
    prob = Problem(x, e, w, noise, loss, f_scale, prior)
    mask = np.ones(n, dtype=bool)
    if loss != "linear" and n >= CONSENSUS_MIN_N:
        found = line_consensus(prob)
        if found is not None and not found[0].all():
            inliers, signs = found
            e = e * signs[:, None]
            est, sub = _fit_subset(x, e, w, noise, loss, f_scale, prior, inliers, multi_start)
            if est.degenerate:
                return est, None
            mask = inliers
            # Let back in what the minimal-set consensus rejected but the fit explains, up to
            # the 5-sigma gate: the consensus is there for gross errors, the robust loss
            # weighs the rest (docs/design.md 6.4: a 99 % gate kept valid ones out).
            u = est.direction
            pc = est.point - prob.centre
            pc = pc - (pc @ u) * u
            k, c = invariants(prob.x, e, u, pc)
            prob.e = e
            again = np.minimum(*sign_norms(prob, u, pc, k, c)) < OUTLIER_GATE[2]
            if (again != inliers).any() and again.sum() >= 4:
                est, sub = _fit_subset(x, e, w, noise, loss, f_scale, prior, again, multi_start)
                mask = again
            return est, _solution_of(sub, mask, e)
    est = fit_general(prob, multi_start)
    return est, _solution_of(prob, mask, prob.e)


def _solution_of(prob, mask, e) -> Solution | None:
    if prob.solution is None:
        return None
    u, p, k, c = prob.solution
    edges = e.copy()
    edges[mask] = prob.e
    q = p + prob.centre
    return Solution(mask, edges, u, q - (q @ u) * u, k, c)


def _fit_subset(x, e, w, noise, loss, f_scale, prior, mask, multi_start=False):
    noise = None if noise is None else noise.take(mask)
    sub = Problem(x[mask], e[mask], w[mask], noise, loss, f_scale, prior)
    return fit_general(sub, multi_start), sub


def _update_state(x, e, noise: Noise, loss, state: Solution, prior=None):
    """Warm-started general-case refit after measurements were appended to those of state.

    ``x``, ``e`` (edges oriented by continuity) and ``noise`` hold all N measurements,
    the first ``len(state.mask)`` of them those of ``state``. Each new measurement keeps
    its edge sign unless it fits far better flipped under ``state`` (``sign_flips``); the
    fit then starts from ``state`` on its measurements plus the new ones and uses the same
    solver as :func:`fit_axis_3d`, with the :class:`AxisPrior` ``prior`` if given.
    Returns (estimate, solution), or None when a full refit is called for: a robust loss
    and a new measurement that is an outlier under ``state`` (the inlier set may be
    changing), or a degenerate result.
    """
    n_old = state.mask.shape[0]
    n = x.shape[0]
    mask = np.concatenate([state.mask, np.ones(n - n_old, dtype=bool)])
    edges = np.concatenate([state.edges, e[n_old:]])
    prob = Problem(
        x[mask], edges[mask], np.ones(int(mask.sum())), noise.take(mask), loss, None, prior
    )
    u = state.u
    p = state.p - prob.centre
    p = p - (p @ u) * u
    k, c = state.k, state.c
    # The new rows are the last ones of prob.
    m = n - n_old
    wh = whiten(prob, u, p)
    keep, flipped = sign_norms(prob, u, p, k, c, wh)
    keep, flipped = keep[-m:], flipped[-m:]
    flip = sign_flips(keep, flipped, 2)
    if flip.any():
        sign = np.where(flip, -1.0, 1.0)
        edges[n_old:] *= sign[:, None]
        ep = prob.e.copy()
        ep[-m:] *= sign[:, None]
        prob.e = ep
    if loss != "linear" and (np.where(flip, flipped, keep) >= CHI2_99[2]).any():
        return None
    u, p, k, c, wh = refine_general(prob, u, p, k, c, wh)
    est = finish_general(prob, u, p, k, c, wh)
    if est.degenerate:
        return None
    prob.solution = (u, p, k, c)
    return est, _solution_of(prob, mask, edges)


def _refine_axis(x, e, noise: Noise, loss, prior, u, p):
    """(estimate, :class:`Solution`) of the general model refined from the axis (u, p)
    (world frame), its invariants taken from the measurements; None if degenerate."""
    prob = Problem(x, e, np.ones(x.shape[0]), noise, loss, None, prior)
    pc = p - prob.centre
    pc = pc - (pc @ u) * u
    est, (u, pc, k, c) = refine_start(prob, u, pc, *invariants(prob.x, prob.e, u, pc))
    if est.degenerate:
        return None
    prob.solution = (u, pc, k, c)
    return est, _solution_of(prob, np.ones(x.shape[0], dtype=bool), prob.e)


def _total_cost(x, e, noise: Noise, loss, state: Solution, prior=None) -> float:
    """:func:`~tactile_gym.estimation.general.total_cost` of all the measurements at the
    axis of ``state``."""
    prob = Problem(x, e, np.ones(x.shape[0]), noise, loss, None, prior)
    p = state.p - prob.centre
    p = p - (p @ state.u) * state.u
    return total_cost(prob, state.u, p, state.k, state.c)


class Fit3D(AxisFit):
    """:func:`fit_axis_3d` as an :class:`~tactile_gym.estimation.interface.AxisFit`.

    ``edge_noise`` rows are (3, 3) edge covariances, rad^2. A fit is :func:`fit_axis_3d`'s
    (consensus first with a robust loss, docs/design.md 6.4; the parallel model when the
    edges call for it). An update starts the general model from the last solution on the
    measurements it kept plus the new ones; it refuses (None) after a parallel or
    degenerate fit, once the measurements grew by ``FULL_REFIT_GROWTH`` since the last
    full fit, with a robust loss when a new measurement is an outlier under the last
    solution (the inlier set may be changing), or when its result is degenerate. The state
    is a :class:`~tactile_gym.estimation.general.Solution`.

    The calibrated estimator fits one line per link angle instead (:meth:`fit_lines`).
    """

    def edge_noise(
        self, edge: np.ndarray, dims: int, edge_std: float, edge_cov: np.ndarray | None
    ) -> np.ndarray:
        if edge_cov is not None:
            return edge_cov
        el = edge.tolist()
        length = math.sqrt(el[0] * el[0] + el[1] * el[1] + el[2] * el[2])
        return isotropic_edge_covs(np.array(el)[None] / length, edge_std)[0]

    def fit(self, data: Measurements) -> AxisEstimate:
        noise = Noise(data.point_std.copy(), data.edge_noise.copy())
        est, self._state = _fit_state(
            data.points.copy(),
            data.edges.copy(),
            np.ones(data.n),
            noise,
            self.loss,
            None,
            _DEFAULT_PARALLEL_TOL,
            self.prior,
        )
        self._n_full = data.n
        return est

    def fit_lines(
        self, lines: Measurements, parallel_lines: Callable[[], Measurements] | None = None
    ) -> AxisEstimate:
        """The calibrated estimator's fit (docs/design.md 6.9) of one line per link angle.

        The general model is refined from each of its starts (the closed form, the prior's
        axis, and the last call's solution, whose lines have since changed) and the one of
        least :func:`~tactile_gym.estimation.general.total_cost` is kept: a consensus over
        minimal fits can settle the robust fit in a local minimum far from the last solution
        (docs/design.md 6.9: 15 mm off with a 1.7 mm std, where the refined last solution
        explains the presses better and lies 1.2 mm off). The parallel
        model (eq. 9-10) is fitted to ``parallel_lines()`` (the presses grouped by their
        lines alone: at every link angle its edges have one direction) when their edges lie
        along one direction, as in :func:`fit_axis_3d`, and chosen as there
        (:func:`~tactile_gym.estimation.selection.prefer_parallel`), unless the prior rules
        its axis out (its direction beyond the prior's 5-sigma gate) while the general
        model's it does not: the presses of one link angle are parallel lines that the
        parallel model explains exactly, and a model that the prior rules out is not chosen
        on the strength of measurements the other leaves unexplained.

        With a prior, data that do not identify the axis leave the estimate at the prior's,
        with its covariance (``method="prior"``): one line (one link angle) for the general
        model, and fewer than two lines for the parallel one.

        Args:
            lines: the fused lines of the link angles (``link_angles``).
            parallel_lines: the lines grouped for the parallel model, made on demand; None:
                the general model only.
        """
        prior = self.prior
        if prior is not None and lines.n == 0:
            return prior.estimate()
        x, e = lines.points.copy(), lines.edges.copy()
        noise = Noise(lines.point_std.copy(), lines.edge_noise.copy())
        if prior is not None and lines.n == 1:
            # One link angle: the line's angle and distance to the axis are free, so it says
            # nothing about the axis; the estimate stays the prior's (``method="prior"``).
            est, sol = prior.estimate(), None
        elif prior is None and lines.n < 3:
            est, sol = degenerate_estimate("3d", lines.n, planar=False), None
        else:
            w = np.ones(lines.n)
            est, sol = _fit_general_state(x, e, w, noise, self.loss, None, prior, True)
        last = self._state
        if last is not None and sol is not None:
            warm = _refine_axis(x, e, noise, self.loss, prior, last.u, last.p)
            if warm is not None and (
                sol is None
                or _total_cost(x, e, noise, self.loss, warm[1], prior)
                < _total_cost(x, e, noise, self.loss, sol, prior)
            ):
                est, sol = warm
        if sol is not None:
            self._state = sol
        # The parallel model's axis lies along the edges of one link angle: along the
        # general lines' largest group of parallel ones (one line when nothing turned).
        if parallel_lines is None or self._ruled_out(
            parallel_fraction(e, _DEFAULT_PARALLEL_TOL)[0]
        ):
            return est
        par = parallel_lines()
        noise = Noise(par.point_std.copy(), par.edge_noise.copy())
        tol = max(_DEFAULT_PARALLEL_TOL, 4.0 * float(np.median(noise.worst_edge_std())))
        mean_dir, frac = parallel_fraction(par.edges, tol)
        if (prior is not None and par.n < 2) or frac < 2.0 / 3.0 or self._ruled_out(mean_dir):
            return est
        w = np.ones(par.n)
        prob = Problem(par.points.copy(), par.edges.copy(), w, noise, self.loss, None, prior)
        est_par = fit_parallel(prob, mean_dir)
        if est_par.degenerate or (
            self._ruled_out(est_par.direction)
            and not (est.degenerate or self._ruled_out(est.direction))
        ):
            return est
        if sol is None or est.degenerate or prefer_parallel(prob, sol, est_par):
            return est_par
        return est

    def _ruled_out(self, direction: np.ndarray) -> bool:
        """Whether the prior (if any) rules out an axis along ``direction``: beyond its
        5-sigma gate (``OUTLIER_GATE``, two degrees of freedom)."""
        return self.prior is not None and self.prior.direction_z2(direction) > OUTLIER_GATE[2]

    def update(self, data: Measurements) -> AxisEstimate | None:
        if self._state is None or self._grown(data.n):
            return None
        noise = Noise(data.point_std.copy(), data.edge_noise.copy())
        out = _update_state(data.points, data.edges, noise, self.loss, self._state, self.prior)
        if out is None:
            return None
        est, self._state = out
        return est
