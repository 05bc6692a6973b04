"""3D joint-axis fit from contact points and edge directions (paper eq. 3, 8, 9-10).

Conventions: world frame, metres, radians; the result follows
:class:`~tactile_gym.estimation.axis.AxisEstimate` (``point . direction = 0``, direction with
its largest-magnitude component positive).

Model. Edge line i passes through contact point ``x_i`` with unit direction ``e_i``; the axis
passes through ``p`` with unit direction ``u``. A rotation about the axis keeps two
invariants of the edge line relative to the axis (in Pluecker terms, with
``m_i = x_i x e_i`` and ``m_a = p x u``):

* the angle between them, ``c = e_i . u = cos(theta)``;
* the reciprocal product ``k = e_i . m_a + u . m_i = (x_i - p) . (e_i x u) = d sin(theta)``,
  where d is the common distance of the paper's eq. 8 (signed by the edge orientation).

Both residuals, ``r1_i = (x_i - p) . (e_i x u) - k`` and ``r2_i = e_i . u - c``, are
polynomials in the unknowns, so they stay smooth where the skew-line distance
``|r1| / |e_i x u|`` would not. The edges must be oriented consistently (sign resolution
below). ``d = |k| / sin(theta)``.

When every edge is parallel to the axis (a door's free edge beside a vertical hinge) the
reciprocal product vanishes and says nothing about p. That case (eq. 9-10) uses the
point-to-axis distance ``|(x_i - p) x u| - d`` and the edge-axis misalignment
``(e_i x u) . b_j`` (b_1, b_2 spanning the plane normal to the axis) instead.

Solution. A closed-form initial guess: r1 and r2 are linear and homogeneous in
``z = (u, m_a, c, k)``, so the guess comes from the two smallest right singular vectors of
the stacked system (the second one is the gauge ``m_a -> m_a + s u``, ``k -> k + s c``),
followed by ``|u| = 1`` and ``u . m_a = 0``. It is refined over a minimal local
parameterisation: u moved by two small angles in a basis normal to the current u, p by two
offsets in that plane (the point along the axis is a gauge, fixed by ``p . u = 0``), plus
(k, c) or d; by a plain-NumPy Levenberg-Marquardt in the general case and by
``scipy.optimize.least_squares`` in the parallel case.

Weights. With ``point_std`` (m) and ``edge_std`` or ``edge_cov`` (rad, rad^2) the 2x2
covariance of (r1, r2) of each measurement is predicted at the current axis (isotropic
point noise; the edge noise ``edge_cov``, isotropic about the edge when only ``edge_std``
is given, see :func:`fit_axis_3d`) and the residuals are whitened by it; the covariance of
the result is then absolute. Without stds, r2 is scaled by the RMS spread of the contact
points (a length) and one common noise level is estimated from the residuals.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from tactile_gym.estimation.axis import (
    DEGENERATE_CONDITION,
    AxisEstimate,
    as_noise,
    as_points,
    as_unit_edges,
    as_weights,
    canonical_direction,
    degenerate_estimate,
    isotropic_edge_covs,
    stds_from_covariance,
)
from tactile_gym.estimation.prior import AxisPrior, check_prior
from tactile_gym.estimation.robust import (
    CHI2_99,
    MAD_TO_STD,
    OUTLIER_GATE,
    check_loss,
    consensus,
    mad_f_scale,
    robust_weights,
    sign_flips,
    split_loss,
    split_loss_cost,
)
from tactile_gym.spatial import orient_edges

__all__ = ["fit_axis_3d"]

_DEFAULT_PARALLEL_TOL = math.radians(1.0)
# Least angle between the edges of a consensus triple, rad (see _consensus).
_DISTINCT_TOL = math.radians(0.5)
_VAR_FLOOR = 1e-24


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
            isotropic about the edge: ``edge_cov = (edge_std^2 / 2) (I - e e^T)``. (Before
            edge_cov existed this was the std in each of the two normal directions.)
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
            the other way round (at least two; see ``_prefer_parallel``). Edges parallel
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
    noise = None if sx is None else _Noise(sx, isotropic_edge_covs(e, se) if cov is None else cov)
    w = np.ones(n) if weights is None else as_weights(weights, n)
    keep = w > 0
    if not keep.all():
        x, e, w = x[keep], e[keep], w[keep]
        if noise is not None:
            noise = noise.take(keep)
    if resolve_signs:
        e = orient_edges(e)
    return _fit_state(x, e, w, noise, loss, f_scale, parallel_tol, prior)[0]


# ------------------------------------------------------------------------------ the solver


class _Noise:
    """Predicted noise of each measurement (all sign-invariant in the edge).

    ``sx``: (N,) contact-point std per axis, m; ``cov``: (N, 3, 3) edge covariance, rad^2,
    normal to the edge; ``mean_var``: (N,) its mean variance per normal direction
    (``trace / 2``); ``sq_norm``: (N,) its squared Frobenius norm, rad^4.
    """

    __slots__ = ("sx", "cov", "mean_var", "sq_norm")

    def __init__(self, sx: np.ndarray, cov: np.ndarray):
        self.sx = sx
        self.cov = cov
        self.mean_var = 0.5 * (cov[:, 0, 0] + cov[:, 1, 1] + cov[:, 2, 2])
        self.sq_norm = np.square(cov).sum(axis=(1, 2))

    def take(self, idx) -> _Noise:
        return _Noise(self.sx[idx], self.cov[idx])

    def worst_edge_std(self) -> np.ndarray:
        """(N,) edge std in the worst direction, rad (the root of cov's largest eigenvalue)."""
        # Eigenvalues 0, a, b with a + b = 2 mean_var and a^2 + b^2 = sq_norm.
        spread = np.sqrt(np.maximum(0.5 * self.sq_norm - self.mean_var**2, 0.0))
        return np.sqrt(self.mean_var + spread)


class _PriorTerm:
    """The prior's four whitened residuals (:mod:`~tactile_gym.estimation.prior`), in the
    centred frame of a :class:`_Problem`.

    Direction: the angle theta between the axis and u0 (either sign of the axis) along the
    direction of the deviation, in a basis A (2, 3) of the plane normal to the prior
    direction u0: ``(theta / sin(theta)) s A u / sigma_d``, ``s = sign(u . u0)``,
    ``sigma_d = angle_std / sqrt(2)`` (the logarithm map of the sphere at u0: the prior is
    Gaussian in the tangent plane, with ``angle_std`` the RMS of theta). Position:
    ``W B^T (I - u u^T)(pin - p)``, the offset of the prior pin from the axis line, with B
    (3, 2) a basis of the plane normal to the axis and W the inverse Cholesky factor of the
    pin covariance projected on it. B and W are those of the axis of the last
    :meth:`set_axis`: held fixed during a solve, like the measurements' whitening.
    """

    def __init__(self, prior, centre: np.ndarray):
        self.prior = prior
        self.pin = prior.pin - centre
        self.u0 = prior.direction
        self.basis = prior.normal_basis
        self.inv_sigma = math.sqrt(2.0) / prior.effective_angle_std
        self.wb = None

    def set_axis(self, u: np.ndarray) -> None:
        """Whiten the position residual for the axis direction u."""
        b = np.array(_basis(u))
        chol = np.linalg.cholesky(self.prior.projected_pin_cov(b))
        self.wb = np.linalg.solve(chol, b)

    def residuals(self, u: np.ndarray, p: np.ndarray):
        """(4,) whitened residuals at the axis (u, p) and their (4, 3) Jacobians in u (for
        a perturbation normal to the unit u) and in p."""
        w = self.pin - p
        uw = float(u @ w)
        cos = float(u @ self.u0)
        sign = 1.0 if cos >= 0.0 else -1.0
        tangent = self.basis @ u
        sin = math.sqrt(float(tangent @ tangent))
        theta = math.atan2(sin, abs(cos))
        # theta / sin(theta) and its derivative in theta over sin(theta),
        # (sin - theta cos) / sin^3 -> 1/3 at theta = 0.
        if sin > 1e-4:
            ratio = theta / sin
            slope = (sin - theta * abs(cos)) / sin**3
        else:
            ratio, slope = 1.0, 1.0 / 3.0
        z = np.empty(4)
        z[0:2] = (self.inv_sigma * sign * ratio) * tangent
        z[2:4] = self.wb @ (w - uw * u)
        ju = np.empty((4, 3))
        # d theta = -s u0 . du / sin(theta).
        ju[0:2] = self.inv_sigma * (sign * ratio * self.basis - slope * np.outer(tangent, self.u0))
        # d/du of (I - u u^T) w applied to du: -(u . w) du - u (w . du).
        ju[2:4] = -uw * self.wb - np.outer(self.wb @ u, w)
        jp = np.zeros((4, 3))
        jp[2:4] = -(self.wb - np.outer(self.wb @ u, u))
        return z, ju, jp


class _Problem:
    """Centred, validated data plus what the residual functions need.

    ``noise`` is a :class:`_Noise`, or None when no stds were given; ``prior`` an
    :class:`~tactile_gym.estimation.prior.AxisPrior` or None (it needs ``noise``), kept as a
    :class:`_PriorTerm`; its four residuals follow the measurements' in the fits.
    """

    def __init__(self, x, e, w, noise, loss, f_scale, prior=None):
        self.centre = x.mean(axis=0)
        self.prior = None if prior is None else _PriorTerm(prior, self.centre)
        self.x = x - self.centre
        self.e = e
        self.sqrt_w = np.sqrt(w)
        self.noise = noise
        self.loss = loss
        spread = float(np.sqrt(np.mean(np.einsum("ij,ij->i", self.x, self.x))))
        self.length = max(spread, 1e-3)
        self.f_scale = f_scale
        self.n = x.shape[0]
        self.solution = None  # (u, p, k, c) of a successful general-case fit

    @property
    def e(self) -> np.ndarray:
        return self._e

    @e.setter
    def e(self, value: np.ndarray) -> None:
        # The design rows (x_i x e_i, e_i) follow the edges' orientation.
        self._e = value
        self.xe = _design(self.x, value)


class _Solution:
    """What a general-case fit ended with, for warm starts (the online estimator).

    ``mask``: (N,) the measurements the fit used; ``edges``: (N, 3) the edges as oriented
    for it; ``u``, ``p`` (world frame, ``p . u = 0``), ``k``, ``c``: the axis and invariants.
    """

    __slots__ = ("mask", "edges", "u", "p", "k", "c")

    def __init__(self, mask, edges, u, p, k, c):
        self.mask, self.edges, self.u, self.p, self.k, self.c = mask, edges, u, p, k, c


def _fit_state(x, e, w, noise, loss, f_scale, parallel_tol, prior=None):
    """The estimate of validated, oriented data and the :class:`_Solution` of a
    general-case fit (else None); with the :class:`AxisPrior` ``prior`` if given (it needs
    ``noise``), from one measurement on (none: the prior's estimate).

    When enough edges lie near their mean direction (all of them, robust losses: two
    thirds) the parallel model (eq. 9-10) is fitted too, and the models are compared (see
    :func:`_prefer_parallel`): edges parallel to *each other* are not enough, as when most
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
    mean_dir, frac = _parallel_fraction(e, tol)
    est, sol = _fit_general_state(x, e, w, noise, loss, f_scale, prior)
    if frac < (1.0 if loss == "linear" else 2.0 / 3.0):
        return est, sol
    est_par = _fit_parallel(_Problem(x, e, w, noise, loss, f_scale, prior), mean_dir)
    if est_par.degenerate or not (
        est.degenerate
        or _prefer_parallel(_Problem(x, e, w, noise, loss, f_scale, prior), sol, est_par)
    ):
        return est, sol
    return est_par, None


def _fit_general_state(x, e, w, noise, loss, f_scale, prior):
    """:func:`_fit_state`'s general-case fit: a consensus first (robust losses, N >= 6)."""
    n = x.shape[0]
    prob = _Problem(x, e, w, noise, loss, f_scale, prior)
    mask = np.ones(n, dtype=bool)
    if loss != "linear" and n >= 6:
        found = _consensus(prob)
        if found is not None and not found[0].all():
            inliers, signs = found
            e = e * signs[:, None]
            est, sub = _fit_subset(x, e, w, noise, loss, f_scale, prior, inliers)
            if est.degenerate:
                return est, None
            mask = inliers
            # Let back in what the minimal-set consensus rejected but the fit explains, up to
            # the 5-sigma gate: the consensus is there for gross errors, the robust loss
            # weighs the rest. (A 99 % gate kept out a valid measurement in a fifth of the
            # fits of 8 simulated presses, whose covariance then claimed far too much.)
            u = est.direction
            pc = est.point - prob.centre
            pc = pc - (pc @ u) * u
            k, c = _invariants(prob.x, e, u, pc)
            prob.e = e
            again = np.minimum(*_sign_norms(prob, u, pc, k, c)) < OUTLIER_GATE[2]
            if (again != inliers).any() and again.sum() >= 4:
                est, sub = _fit_subset(x, e, w, noise, loss, f_scale, prior, again)
                mask = again
            return est, _solution_of(sub, mask, e)
    est = _fit_general(prob)
    return est, _solution_of(prob, mask, prob.e)


def _solution_of(prob, mask, e) -> _Solution | None:
    if prob.solution is None:
        return None
    u, p, k, c = prob.solution
    edges = e.copy()
    edges[mask] = prob.e
    q = p + prob.centre
    return _Solution(mask, edges, u, q - (q @ u) * u, k, c)


def _fit_subset(x, e, w, noise, loss, f_scale, prior, mask):
    noise = None if noise is None else noise.take(mask)
    sub = _Problem(x[mask], e[mask], w[mask], noise, loss, f_scale, prior)
    return _fit_general(sub), sub


def _update_state(x, e, noise: _Noise, loss, state: _Solution, prior=None):
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
    prob = _Problem(
        x[mask], edges[mask], np.ones(int(mask.sum())), noise.take(mask), loss, None, prior
    )
    u = state.u
    p = state.p - prob.centre
    p = p - (p @ u) * u
    k, c = state.k, state.c
    # The new rows are the last ones of prob.
    m = n - n_old
    wh = _whiten(prob, u, p)
    keep, flipped = _sign_norms(prob, u, p, k, c, wh)
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
    u, p, k, c, wh = _refine_general(prob, u, p, k, c, wh)
    est = _finish_general(prob, u, p, k, c, wh)
    if est.degenerate:
        return None
    prob.solution = (u, p, k, c)
    return est, _solution_of(prob, mask, edges)


def _invariants(x, e, u, p) -> tuple[float, float]:
    """Median reciprocal product k and angle cosine c of the edges (given orientation)."""
    k = float(np.median(np.einsum("ij,ij->i", x - p, _cross(e, u[None, :]))))
    return k, float(np.median(e @ u))


def _consensus(prob: _Problem) -> tuple[np.ndarray, np.ndarray] | None:
    """Inlier mask and edge signs (+-1) of the best minimal (3-line) closed-form fit
    (:func:`~tactile_gym.estimation.robust.consensus`).

    A per-residual robust loss is not enough here: for nearly planar motion an axis lying
    in the plane of the contacts zeroes every reciprocal-product residual, and wild edges
    then make that wrong axis cheaper under L1-like losses.

    A triple is a candidate only when its edges are pairwise more than
    ``max(0.5 deg, 3 hypot(s_i, s_j))`` apart (s: the edge std in its worst direction):
    two lines measured at one link angle are one line twice (parallel edges of a general
    axis come from the same angle), and the triple's axis would be fitted to their noise.
    Such an axis explains every measurement at that angle; so that it does not win the
    inlier count when most were taken there, each measurement counts (and is drawn into
    triples) with the share ``1 / (number of edges within that angle of it)``.
    """
    s = np.zeros(prob.n) if prob.noise is None else prob.noise.worst_edge_std()
    tol = np.maximum(_DISTINCT_TOL, 3.0 * np.hypot(s[:, None], s[None, :]))
    same = np.abs(prob.e @ prob.e.T) >= np.cos(tol)

    def fit_triple(idx):
        i, j, k = idx.tolist()
        if same[i, j] or same[i, k] or same[j, k]:
            return None
        sub = _Problem.__new__(_Problem)
        sub.__dict__.update(prob.__dict__)
        sub.x, sub.n = prob.x[idx], 3
        sub.e = prob.e[idx]
        sub.sqrt_w = prob.sqrt_w[idx]
        sub.noise = None if prob.noise is None else prob.noise.take(idx)
        sub.loss = "linear"
        return _linear_init(sub, _whitening_scale_only(sub))

    def sq_norms(fit):
        return np.minimum(*_sign_norms(prob, *fit, raw=True))

    found = consensus(
        prob.n,
        fit_triple,
        sq_norms,
        2,
        whitened=prob.noise is not None,
        shares=1.0 / same.sum(axis=1),
    )
    if found is None:
        return None
    inliers, fit, scale = found
    keep, flipped = _sign_norms(prob, *fit, raw=True)
    return inliers, np.where(sign_flips(keep / scale, flipped / scale, 2), -1.0, 1.0)


def _sign_norms(
    prob: _Problem, u, p, k, c, wh=None, raw: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Squared whitened (r1, r2) norms per measurement: each edge as oriented, and flipped.

    ``wh``: the whitening at (u, p) when already computed. Without stds the norms are
    scaled so that the median of the better of the two is 0.5 (a noise level from the
    residuals of a fitted axis), unless ``raw``.
    """
    (k1, k2), (f1, f2) = _sign_residuals(prob, u, p, k, c, wh)
    keep = k1 * k1 + k2 * k2
    flipped = f1 * f1 + f2 * f2
    if prob.noise is None and not raw:
        scale = 0.5 / max(float(np.median(np.minimum(keep, flipped))), 1e-30)
        keep, flipped = keep * scale, flipped * scale
    return keep, flipped


def _sign_residuals(prob: _Problem, u, p, k, c, wh=None):
    """Whitened residual pairs ``(z1, z2)``, each (N,), with each edge as oriented and
    flipped (whitening as for :func:`_sign_norms`)."""
    if wh is None:
        wh = (
            _whitening_general(prob, u, p)
            if prob.noise is not None
            else _whitening_scale_only(prob)
        )
    d = np.einsum("ij,ij->i", prob.x - p, _cross(prob.e, u[None, :]))
    a = prob.e @ u
    out = []
    for sgn in (1.0, -1.0):
        r1 = sgn * d - k
        r2 = sgn * a - c
        out.append((wh[:, 0] * r1, wh[:, 1] * r1 + wh[:, 2] * r2))
    return out


def _prefer_parallel(prob: _Problem, sol: _Solution, est_par: AxisEstimate) -> bool:
    """Whether the parallel model (eq. 9-10) holds: unless more of the edges it rejects
    are explained by the general model than the other way round.

    A measurement contradicts a model when its squared whitened residual norm under it is
    beyond the 5-sigma gate (``OUTLIER_GATE``; 3 degrees of freedom under the parallel
    model: radial distance and the edge's misalignment, 2 under the general one) while the
    other model explains it (within the 99 % quantile). The general model wins when it is
    contradicted less often than the parallel one, and the parallel one at least twice:
    with the group of parallel edges, those are the three distinct edge lines a general
    axis needs. With a prior the general model is determined anyway and one contradiction
    suffices; the prior's direction and position residuals count like two measurements
    (2 degrees of freedom each). Edges parallel to each other but not to the axis (most
    measurements taken at one link angle) make every measurement taken elsewhere
    contradict the parallel model; a wild edge is wild under both models and does not
    count, unless a wrong general fit happens to pass through it, and then the parallel
    model's edges contradict that fit many times over.

    Why not a likelihood-ratio test: the parallel model is the general one at theta = 0,
    where the general model is singular (its distance ``|k| / sin(theta)`` is undefined);
    the ratio there does not follow its chi-square law (on parallel data the general model
    fits far closer than its N + 1 extra parameters predict, increasingly with N).

    Without stds the test needs a noise model, estimated robustly from what is noise under
    either model: the contact-point noise from the parallel model's radial residuals (the
    points of one edge line lie at one distance from an axis parallel to it), the edge
    noise from the angles of the edges to the parallel model's axis (Rayleigh median).
    Each edge takes its better sign under the general model (its consensus may have set
    some aside).

    Args:
        prob: the problem of all measurements, edges as oriented for the fits.
        sol: the general model's solution.
        est_par: the parallel model's estimate.
    """
    u_par = est_par.direction
    p_par = est_par.point - prob.centre
    if prob.noise is None:
        wv = prob.x - p_par
        wp = wv - (wv @ u_par)[:, None] * u_par
        radial = np.sqrt(np.einsum("ij,ij->i", wp, wp)) - est_par.distance
        angle = np.arccos(np.minimum(np.abs(prob.e @ u_par), 1.0))
        # Median of a Rayleigh variable: sigma sqrt(2 ln 2); the total edge std is
        # sqrt(2) sigma.
        edge_std = math.sqrt(2.0) * float(np.median(angle)) / math.sqrt(2.0 * math.log(2.0))
        point_std = MAD_TO_STD * float(np.median(np.abs(radial)))
        prob.noise = _Noise(np.full(prob.n, point_std), isotropic_edge_covs(prob.e, edge_std))
    b1, b2 = _basis(u_par)
    fun, _ = _residuals_parallel(prob, u_par, b1, b2)
    z_par = fun(np.array([0.0, 0.0, p_par @ b1, p_par @ b2, est_par.distance]))
    q_par = np.square(z_par[: 3 * prob.n]).reshape(3, -1).sum(axis=0)
    u = sol.u
    p = sol.p - prob.centre
    p = p - (p @ u) * u
    (k1, k2), (f1, f2) = _sign_residuals(prob, u, p, sol.k, sol.c)
    q_gen = np.minimum(k1 * k1 + k2 * k2, f1 * f1 + f2 * f2)
    against_par = int(np.sum((q_par > OUTLIER_GATE[3]) & (q_gen < CHI2_99[2])))
    against_gen = int(np.sum((q_gen > OUTLIER_GATE[2]) & (q_par < CHI2_99[3])))
    needed = 2
    if prob.prior is not None:
        needed = 1
        prob.prior.set_axis(u_par)
        z_par = np.square(prob.prior.residuals(u_par, p_par)[0]).reshape(2, 2).sum(axis=1)
        prob.prior.set_axis(u)
        z_gen = np.square(prob.prior.residuals(u, p)[0]).reshape(2, 2).sum(axis=1)
        against_par += int(np.sum((z_par > OUTLIER_GATE[2]) & (z_gen < CHI2_99[2])))
        against_gen += int(np.sum((z_gen > OUTLIER_GATE[2]) & (z_par < CHI2_99[2])))
    return against_par < needed or against_par <= against_gen


def _parallel_fraction(e: np.ndarray, tol: float) -> tuple[np.ndarray, float]:
    """Principal (sign-free) mean direction of the largest group of edges within tol of
    one of them, and the fraction of all the edges within tol of that direction.

    The group is found around the edge with the most others within tol: the principal
    direction of all the edges would be dragged off by a few wild ones, beyond the tol of
    every edge.
    """
    near = np.abs(e @ e.T) >= math.cos(tol)
    group = near[int(np.argmax(near.sum(axis=1)))]
    vals, vecs = np.linalg.eigh(e[group].T @ e[group])
    u = vecs[:, 2]
    return u, float(np.mean(np.abs(e @ u) >= math.cos(tol)))


def _basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing u to a right-handed orthonormal basis (b1, b2, u)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = a - (a @ u) * u
    b1 /= np.linalg.norm(b1)
    return b1, _cross3(u, b1)


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (np.cross has a large fixed cost)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (N, 3) arrays (np.cross has a large fixed cost)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


# ---------------------------------------------------------------------------- general case


def _whitening_general(prob: _Problem, u: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(N, 3) entries (w00, w10, w11) of the lower-triangular inverse Cholesky factors.

    Whitened residuals are ``(w00 r1, w10 r1 + w11 r2)``.
    """
    n = prob.n
    if prob.noise is None:
        out = np.empty((n, 3))
        out[:, 0] = 1.0
        out[:, 1] = 0.0
        out[:, 2] = prob.length
        return out * prob.sqrt_w[:, None]
    noise = prob.noise
    wv = prob.x - p
    nrm = _cross(prob.e, u[None, :])
    # r1 = e . (u x (x - p)) and r2 = e . u: their gradients in e are g and u, and
    # noise.cov holds only the edge's normal directions.
    g = _cross(np.broadcast_to(u, wv.shape), wv)
    cu = noise.cov @ u
    sx2 = noise.sx**2
    s11 = sx2 * np.einsum("ij,ij->i", nrm, nrm) + np.einsum("ij,ijk,ik->i", g, noise.cov, g)
    s22 = cu @ u
    s12 = np.einsum("ij,ij->i", g, cu)
    # Second-order floors: at theta = 0 the first-order variances vanish. Half the squared
    # norm of cov is the mean squared variance per normal direction.
    fourth = 0.25 * noise.sq_norm
    s11 = s11 + fourth * prob.length**2 + sx2 * noise.mean_var + _VAR_FLOOR
    s22 = s22 + fourth + _VAR_FLOOR
    return _inverse_cholesky(s11, s12, s22) * prob.sqrt_w[:, None]


def _inverse_cholesky(s11: np.ndarray, s12: np.ndarray, s22: np.ndarray) -> np.ndarray:
    """(N, 3) entries (w00, w10, w11) of the inverse of the lower Cholesky factor of each
    2x2 covariance ``[[s11, s12], [s12, s22]]``: ``(w00 r1, w10 r1 + w11 r2)`` is white."""
    l11 = np.sqrt(s11)
    l21 = s12 / l11
    l22 = np.sqrt(np.maximum(s22 - l21 * l21, _VAR_FLOOR))
    out = np.empty((s11.shape[0], 3))
    out[:, 0] = 1.0 / l11
    out[:, 1] = -l21 / (l11 * l22)
    out[:, 2] = 1.0 / l22
    return out


def _linear_init(prob: _Problem, wh: np.ndarray):
    """Closed-form (u, p, k, c) from the homogeneous system in z = (u, m_a / L, c, k / L).

    Returns None when the system does not determine the axis.
    """
    x, e, n, length = prob.x, prob.e, prob.n, prob.length
    m = _cross(x, e) / length
    a1 = np.zeros((n, 8))  # r1 / L rows: m_i / L . u + e_i . m_a / L - k / L
    a1[:, 0:3] = m
    a1[:, 3:6] = e
    a1[:, 7] = -1.0
    a2 = np.zeros((n, 8))  # r2 rows: e_i . u - c
    a2[:, 0:3] = e
    a2[:, 6] = -1.0
    # Whitening of (r1, r2); r1 / L has L times smaller a standard deviation.
    w00 = wh[:, 0:1] * length
    w10 = wh[:, 1:2] * length
    a = np.concatenate([w00 * a1, w10 * a1 + wh[:, 2:3] * a2])
    if a.shape[0] < 8:
        a = np.concatenate([a, np.zeros((8 - a.shape[0], 8))])
    _, s, vt = np.linalg.svd(a)
    if not s[0] > 0 or s[5] <= s[0] / DEGENERATE_CONDITION:
        return None
    v2 = vt[6:8]  # the two smallest right singular vectors
    uu, su, wt = np.linalg.svd(v2[:, 0:3].T)
    if su[0] < 1e-6:
        return None
    z = wt[0] @ v2
    scale = np.linalg.norm(z[0:3])
    u = z[0:3] / scale
    m_a = z[3:6] * length / scale
    m_a = m_a - (u @ m_a) * u
    p = _cross3(u, m_a)
    # Medians keep wild edges from dragging (k, c) when a robust loss follows.
    centre = np.mean if prob.loss == "linear" else np.median
    c = float(centre(e @ u))
    k = float(centre(np.einsum("ij,ij->i", x - p, _cross(e, u[None, :]))))
    return u, p, k, c


def _design(x: np.ndarray, e: np.ndarray) -> np.ndarray:
    """(N, 6) rows ``(x_i x e_i, e_i)``: ``r1_i = row_i . (u, m_a) - k`` (Pluecker form)."""
    out = np.empty((x.shape[0], 6))
    out[:, 0:3] = _cross(x, e)
    out[:, 3:6] = e
    return out


def _linearise(prob, wh, u, p, k, c, jacobian=True):
    """Whitened residuals (2N,) and their Jacobian (2N, 6) at (u, p, k, c); with a prior
    its four residuals follow ((2N + 4,), (2N + 4, 6)).

    Local parameters ``(alpha, beta, s1, s2, k, c)``: u moved to ``normalise(u + alpha b1
    + beta b2)``, p to ``s1 b1 + s2 b2`` (``(b1, b2, u)`` from :func:`_basis`). Everything
    comes from one product of the cached design rows with a 6 x 6 matrix: with
    ``r1 = m_i . u + e_i . m_a - k``, ``d r1 / d alpha = (x_i - p) x e_i . b1 = m_i . b1 +
    e_i . (p x b1)``, ``d r1 / d s1 = -e_i . (u x b1) = -e_i . b2``, ``d r1 / d s2 = e_i . b1``
    and ``r2 = e_i . u - c``.
    """
    n = prob.n
    b1, b2 = _basis(u)
    q = np.zeros((6, 6))
    q[0:3, 0] = u
    q[3:6, 0] = _cross3(p, u)
    q[3:6, 5] = u
    if jacobian:
        q[0:3, 1] = b1
        q[3:6, 1] = _cross3(p, b1)
        q[0:3, 2] = b2
        q[3:6, 2] = _cross3(p, b2)
        q[3:6, 3] = -b2
        q[3:6, 4] = b1
    a = prob.xe @ q
    r1 = a[:, 0] - k
    r2 = a[:, 5] - c
    w00, w10, w11 = wh[:, 0], wh[:, 1], wh[:, 2]
    extra = 0 if prob.prior is None else 4
    z = np.empty(2 * n + extra)
    z[:n] = w00 * r1
    z[n : 2 * n] = w10 * r1 + w11 * r2
    if extra:
        z[2 * n :], ju, jp = prob.prior.residuals(u, p)
    if not jacobian:
        return z, None, b1, b2
    jm = np.zeros((2 * n + extra, 6))
    if extra:
        # p moves by s1 b1 + s2 b2; the shift along u that keeps p . u = 0 as u turns
        # does not move the line.
        jm[2 * n :, 0:4] = np.column_stack([ju @ b1, ju @ b2, jp @ b1, jp @ b2])
    j1 = a[:, 1:5]
    jm[:n, 0:4] = w00[:, None] * j1
    jm[:n, 4] = -w00
    jm[n : 2 * n, 0:4] = w10[:, None] * j1
    jm[n : 2 * n, 0] += w11 * a[:, 4]
    jm[n : 2 * n, 1] -= w11 * a[:, 3]
    jm[n : 2 * n, 4] = -w10
    jm[n : 2 * n, 5] = -w11
    return z, jm, b1, b2


_SOLVER_MAX_ITER = 50


def _solve_general(prob, wh, u, p, k, c, f_scale):
    """Minimise the (robust) cost of the whitened residuals from (u, p, k, c).

    Levenberg-Marquardt on the local parameterisation of :func:`_linearise`. Robust losses
    take Newton-like steps: the gradient weighted by ``rho'`` and the Gauss-Newton matrix by
    the residual's exact curvature ``rho' + 2 s rho''`` (clipped from below), so that they
    converge as fast as plain least squares. A step is kept only when the cost drops. Plain
    NumPy: for the few dozen residuals here scipy's least_squares spent most of its time in
    bookkeeping. Warm starts (the online estimator) converge in one or two iterations.
    A prior's residuals (after the 2N of the measurements) always count by least squares.
    """
    loss = prob.loss
    m = 2 * prob.n
    z, jm, b1, b2 = _linearise(prob, wh, u, p, k, c)
    cost = split_loss_cost(z, m, loss, f_scale)
    # Damping: Nielsen's rule, from 0 (pure Gauss-Newton, what a good start needs).
    lam, nu = 0.0, 2.0
    ang_tol = 1e-11
    pos_tol = 1e-11 * prob.length
    for _ in range(_SOLVER_MAX_ITER):
        if loss == "linear":
            g = jm.T @ z
            h = jm.T @ jm
        else:
            rw, hw = robust_weights(z, loss, f_scale, curvature=True)
            rw[m:] = hw[m:] = 1.0
            g = jm.T @ (rw * z)
            h = (jm * hw[:, None]).T @ jm
        dh = np.diag(h).copy()
        s1, s2 = float(p @ b1), float(p @ b2)
        while True:
            a = h + np.diag(lam * dh)
            try:
                step = np.linalg.solve(a, -g)
            except np.linalg.LinAlgError:
                step = np.linalg.lstsq(a, -g, rcond=None)[0]
            sl = step.tolist()
            tiny = abs(sl[0]) + abs(sl[1]) < ang_tol and abs(sl[2]) + abs(sl[3]) < pos_tol
            v = u + sl[0] * b1 + sl[1] * b2
            un = v / math.sqrt(float(v @ v))
            pn = (s1 + sl[2]) * b1 + (s2 + sl[3]) * b2
            pn = pn - (pn @ un) * un
            kn, cn = k + sl[4], c + sl[5]
            zn, _, _, _ = _linearise(prob, wh, un, pn, kn, cn, jacobian=False)
            new = split_loss_cost(zn, m, loss, f_scale)
            if new <= cost:
                pred = -float(step @ g) - 0.5 * float(step @ (h @ step))
                ratio = (cost - new) / pred if pred > 0 else 1.0
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
                nu = 2.0
                break
            if tiny:
                return u, p, k, c
            lam = max(lam * nu, 1e-6)
            nu *= 2.0
            if lam > 1e10:
                return u, p, k, c
        done = tiny or cost - new <= 1e-10 * cost
        u, p, k, c, cost = un, pn, kn, cn, new
        if done:
            break
        z, jm, b1, b2 = _linearise(prob, wh, u, p, k, c)
    return u, p, k, c


def _fit_general(prob: _Problem) -> AxisEstimate:
    # No axis yet: the first guess is whitened without geometry.
    wh = _whitening_scale_only(prob)
    init = _linear_init(prob, wh)
    if prob.prior is not None:
        init = _prior_start(prob, init)
    if init is None:
        return degenerate_estimate("3d", prob.n, planar=False)
    u, p, k, c = init
    if prob.noise is not None:
        wh = _whiten(prob, u, p)
    u, p, k, c, wh = _refine_general(prob, u, p, k, c, wh)
    # Re-orient edges that fit the other way round (a wild edge between two good ones can
    # have misled the continuity rule), then polish once.
    if _reorient(prob, u, p, k, c):
        u, p, k, c, wh = _refine_general(prob, u, p, k, c, wh)
    est = _finish_general(prob, u, p, k, c, wh)
    if not est.degenerate:
        prob.solution = (u, p, k, c)
    return est


def _prior_start(prob: _Problem, init):
    """Of the closed-form start ``init`` (None when the measurements do not determine one)
    and the prior's axis, the start (u, p, k, c) with the lower cost (few measurements, or
    a small turn of the link, leave the closed form far off)."""
    u = prob.prior.u0
    p = prob.prior.pin - (prob.prior.pin @ u) * u
    starts = [(u, p, *_invariants(prob.x, prob.e, u, p))]
    if init is not None:
        starts.append(init)
    costs = []
    for start in starts:
        wh = _whiten(prob, *start[:2])
        z = _linearise(prob, wh, *start, jacobian=False)[0]
        costs.append(split_loss_cost(z, 2 * prob.n, prob.loss, _resolve_f_scale(prob)))
    return starts[int(np.argmin(costs))]


def _whiten(prob: _Problem, u: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The measurements' whitening at the axis (u, p) (:func:`_whitening_general`), with
    the prior's, if any, set for u."""
    if prob.prior is not None:
        prob.prior.set_axis(u)
    return _whitening_general(prob, u, p)


def _whitening_scale_only(prob: _Problem) -> np.ndarray:
    """Whitening before any axis is known: r1 ~ sigma_x + L sigma_e, r2 ~ sigma_e."""
    if prob.noise is None:
        return _whitening_general(prob, np.zeros(3), np.zeros(3))
    var_e = prob.noise.mean_var
    s1 = np.sqrt(prob.noise.sx**2 + prob.length**2 * var_e + _VAR_FLOOR)
    s2 = np.sqrt(var_e + _VAR_FLOOR)
    out = np.zeros((prob.n, 3))
    out[:, 0] = 1.0 / s1
    out[:, 2] = 1.0 / s2
    return out * prob.sqrt_w[:, None]


def _refine_general(prob, u, p, k, c, wh):
    f_scale = _resolve_f_scale(prob, (u, p, k, c), wh)
    u, p, k, c = _solve_general(prob, wh, u, p, k, c, f_scale)
    if prob.noise is not None:
        wh = _whiten(prob, u, p)
    return u, p, k, c, wh


def _resolve_f_scale(prob, axis=None, wh=None) -> float:
    """The loss's f_scale: as given, else 2 (standard deviations, or any for least
    squares), else (no stds) from the residuals at ``axis = (u, p, k, c)``."""
    if prob.f_scale is not None:
        return prob.f_scale
    if prob.noise is not None or prob.loss == "linear":
        return 2.0
    r, _, _, _ = _linearise(prob, wh, *axis, jacobian=False)
    return mad_f_scale(r)


def _reorient(prob, u, p, k, c) -> bool:
    """Flip the edges that fit far better flipped (``sign_flips``); True if any was."""
    bad = sign_flips(*_sign_norms(prob, u, p, k, c), 2)
    if bad.any():
        prob.e = np.where(bad[:, None], -prob.e, prob.e)
        return True
    return False


def _covariance_local(prob, r, jm, n_params, f_scale, m):
    """(cov, cond) of the local parameters from the residuals and Jacobian at the solution;
    the loss weights the first m (the measurements'), not the prior's."""
    rho = robust_weights(r, prob.loss, f_scale)
    rho[m:] = 1.0
    jw = jm * np.sqrt(rho)[:, None]
    col = np.linalg.norm(jw, axis=0)
    if not (col > 0).all():
        return None, math.inf
    s = np.linalg.svd(jw / col, compute_uv=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    if not cond < DEGENERATE_CONDITION:
        return None, math.inf
    info = jw.T @ jw
    cov = np.linalg.inv(info)
    if prob.noise is None:
        dof = r.size - n_params
        if dof <= 0:
            return "nodof", cond
        cov = cov * float(np.sum(rho * r * r)) / dof
    return cov, cond


def _finish_general(prob, u, p, k, c, wh) -> AxisEstimate:
    z, jm, b1, b2 = _linearise(prob, wh, u, p, k, c)
    f_scale = _resolve_f_scale(prob, (u, p, k, c), wh)
    cov_local, cond = _covariance_local(prob, z, jm, 6, f_scale, 2 * prob.n)
    # At theta = 0 (edges parallel to the axis, the parallel model's case) the distance
    # d = |k| / sin(theta) is undefined.
    if cov_local is None or not 1.0 - c * c > 1e-12:
        return degenerate_estimate("3d", prob.n, planar=False)
    sin_t = math.sqrt(1.0 - c * c)
    d = abs(k) / sin_t
    # Geometric distance residual: (r1 - k) / sin(theta).
    r1 = np.einsum("ij,ij->i", prob.x - p, _cross(prob.e, u[None, :])) - k
    rms = float(np.sqrt(np.mean(r1 * r1))) / sin_t
    # Jacobian of (point, direction, distance) w.r.t. (alpha, beta, s1, s2, k, c).
    q = p + prob.centre
    g = _axis_jacobian(q, u, b1, b2, 6)
    g[6, 4] = math.copysign(1.0, k) / sin_t
    g[6, 5] = abs(k) * c / sin_t**3
    return _assemble(prob, u, q, d, cov_local, g, cond, rms, "3d")


def _axis_jacobian(q, u, b1, b2, n_params: int) -> np.ndarray:
    """Jacobian of (point, direction, distance) w.r.t. the local parameters, whose first four
    are the direction angles (alpha, beta) and the point offsets (s1, s2); the distance row
    is left for the caller."""
    g = np.zeros((7, n_params))
    g[0:3, 0] = -(q @ b1) * u - (q @ u) * b1
    g[0:3, 1] = -(q @ b2) * u - (q @ u) * b2
    g[0:3, 2] = b1
    g[0:3, 3] = b2
    g[3:6, 0] = b1
    g[3:6, 1] = b2
    return g


def _assemble(prob, u, q, d, cov_local, g, cond, rms, method) -> AxisEstimate:
    direction, sign = canonical_direction(u)
    point = q - (q @ u) * u
    if isinstance(cov_local, str):
        cov = None
        pos_std = ang_std = math.inf
    else:
        g = g.copy()
        g[3:6] *= sign
        cov = g @ cov_local @ g.T
        cov = 0.5 * (cov + cov.T)
        pos_std, ang_std = stds_from_covariance(cov, direction)
    return AxisEstimate(
        point=point,
        direction=direction,
        distance=float(d),
        covariance=cov,
        position_std=pos_std,
        angle_std=ang_std,
        residual_rms=rms,
        n_used=prob.n,
        degenerate=False,
        condition_number=cond,
        method=method,
    )


# --------------------------------------------------------------------------- parallel case


def _whitening_parallel(prob: _Problem, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
    """(N, 4): the scale of the radial residual, then the entries (w00, w10, w11) of the
    lower-triangular inverse Cholesky factor of the misalignment pair
    ``((e x u) . b1, (e x u) . b2)``, whose gradients in e are ``(b2, -b1)``."""
    out = np.zeros((prob.n, 4))
    if prob.noise is None:
        out[:, 0] = 1.0
        out[:, 1] = out[:, 3] = prob.length
    else:
        cov = prob.noise.cov
        c1 = cov @ b1
        out[:, 0] = 1.0 / np.sqrt(prob.noise.sx**2 + _VAR_FLOOR)
        out[:, 1:] = _inverse_cholesky(
            (cov @ b2) @ b2 + _VAR_FLOOR, -(c1 @ b2), c1 @ b1 + _VAR_FLOOR
        )
    return out * prob.sqrt_w[:, None]


def _residuals_parallel(prob, u0, b1, b2):
    """Whitened residual function (3N,) and Jacobian (3N, 5) of the parallel case in the
    local parameters ``(alpha, beta, s1, s2, d)`` about ``u0`` with basis ``(b1, b2)``;
    with a prior its four residuals follow, whitened for u0."""
    x, e, n = prob.x, prob.e, prob.n
    wh = _whitening_parallel(prob, b1, b2)
    prior = prob.prior
    extra = 0
    if prior is not None:
        prior.set_axis(u0)
        extra = 4

    def unpack(t):
        v = u0 + t[0] * b1 + t[1] * b2
        nv = math.sqrt(float(v @ v))
        return v / nv, nv, t[2] * b1 + t[3] * b2

    def fun(t):
        u, _, p = unpack(t)
        wv = x - p
        wp = wv - (wv @ u)[:, None] * u
        rho = np.sqrt(np.einsum("ij,ij->i", wp, wp))
        exu = _cross(e, u[None, :])
        out = np.empty(3 * n + extra)
        m1 = exu @ b1
        out[:n] = wh[:, 0] * (rho - t[4])
        out[n : 2 * n] = wh[:, 1] * m1
        out[2 * n : 3 * n] = wh[:, 2] * m1 + wh[:, 3] * (exu @ b2)
        if extra:
            out[3 * n :] = prior.residuals(u, p)[0]
        return out

    def jac(t):
        u, nv, p = unpack(t)
        ju = (np.eye(3) - np.outer(u, u)) / nv @ np.column_stack([b1, b2])
        wv = x - p
        along = wv @ u
        wp = wv - along[:, None] * u
        rho = np.maximum(np.sqrt(np.einsum("ij,ij->i", wp, wp)), 1e-300)
        unit = wp / rho[:, None]
        out = np.zeros((3 * n + extra, 5))
        out[:n, 0:2] = (-(along[:, None]) * unit) @ ju
        out[:n, 2] = -(unit @ b1)
        out[:n, 3] = -(unit @ b2)
        out[:n, 4] = -1.0
        # d/du of (e x u) . b = u . (b x e)
        j1 = _cross(np.broadcast_to(b1, e.shape), e) @ ju
        j2 = _cross(np.broadcast_to(b2, e.shape), e) @ ju
        out[:n] *= wh[:, 0:1]
        out[n : 2 * n, 0:2] = wh[:, 1:2] * j1
        out[2 * n : 3 * n, 0:2] = wh[:, 2:3] * j1 + wh[:, 3:4] * j2
        if extra:
            _, jpu, jpp = prior.residuals(u, p)
            out[3 * n :, 0:2] = jpu @ ju
            out[3 * n :, 2] = jpp @ b1
            out[3 * n :, 3] = jpp @ b2
        return out

    return fun, jac


def _circle_start(prob: _Problem, b1: np.ndarray, b2: np.ndarray) -> np.ndarray | None:
    """Parallel-case start ``(0, 0, s1, s2, d)``: the circle through the contact points
    projected on the plane (b1, b2) (algebraic fit: x^2 + y^2 = 2 a x + 2 b y + c0); None
    when they do not determine one (fewer than 3, collinear)."""
    px = prob.x @ b1
    py = prob.x @ b2
    a = np.column_stack([2.0 * px, 2.0 * py, np.ones(prob.n)])
    rhs = px * px + py * py
    col = np.linalg.norm(a, axis=0)
    if prob.n < 3 or not (col > 0).all():
        return None
    s = np.linalg.svd(a / col, compute_uv=False)
    if s[2] <= s[0] / DEGENERATE_CONDITION:
        return None
    sol = np.linalg.lstsq(a, rhs, rcond=None)[0]
    d = math.sqrt(max(sol[2] + sol[0] ** 2 + sol[1] ** 2, 0.0))
    return np.array([0.0, 0.0, sol[0], sol[1], d])


def _fit_parallel(prob: _Problem, mean_dir: np.ndarray) -> AxisEstimate:
    e = prob.e
    prob.e = np.where((e @ mean_dir < 0)[:, None], -e, e)
    u = mean_dir
    b1, b2 = _basis(u)
    m = 3 * prob.n
    fun, jac = _residuals_parallel(prob, u, b1, b2)
    starts = []
    circle = _circle_start(prob, b1, b2)
    if circle is not None:
        starts.append(circle)
    if prob.prior is not None:
        # The prior's pin, at the median distance of the contact points.
        pin = prob.prior.pin
        wv = prob.x - pin
        wp = wv - (wv @ u)[:, None] * u
        starts.append(
            np.array([0.0, 0.0, pin @ b1, pin @ b2, np.median(np.linalg.norm(wp, axis=1))])
        )
    if not starts:
        return degenerate_estimate("3d-parallel", prob.n, planar=False)
    if prob.f_scale is not None:
        f_scale = prob.f_scale
    elif prob.noise is not None:
        f_scale = 2.0
    else:
        f_scale = mad_f_scale(fun(starts[0]))
    t0 = min(starts, key=lambda t: split_loss_cost(fun(t), m, prob.loss, f_scale))
    if prob.loss == "linear" and m >= 5:
        res = least_squares(fun, t0, jac=jac, method="lm", x_scale="jac", xtol=1e-10, ftol=1e-10)
    else:
        res = least_squares(
            fun,
            t0,
            jac=jac,
            method="trf",
            loss=prob.loss if prob.prior is None else split_loss(prob.loss, m),
            f_scale=f_scale,
            x_scale="jac",
            xtol=1e-10,
            ftol=1e-10,
        )
    t = res.x
    v = u + t[0] * b1 + t[1] * b2
    u = v / np.linalg.norm(v)
    p = t[2] * b1 + t[3] * b2
    p = p - (p @ u) * u
    d = abs(float(t[4]))
    b1, b2 = _basis(u)
    fun, jac = _residuals_parallel(prob, u, b1, b2)
    t = np.array([0.0, 0.0, p @ b1, p @ b2, d])
    cov_local, cond = _covariance_local(prob, fun(t), jac(t), 5, f_scale, m)
    if cov_local is None:
        return degenerate_estimate("3d-parallel", prob.n, planar=False)
    wv = prob.x - p
    wp = wv - (wv @ u)[:, None] * u
    rad = np.sqrt(np.einsum("ij,ij->i", wp, wp)) - d
    rms = float(np.sqrt(np.mean(rad * rad)))
    q = p + prob.centre
    g = _axis_jacobian(q, u, b1, b2, 5)
    g[6, 4] = 1.0
    return _assemble(prob, u, q, d, cov_local, g, cond, rms, "3d-parallel")
