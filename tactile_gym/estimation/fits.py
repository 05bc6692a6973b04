"""Planar joint-axis fits: the paper's proposed method and its "simple method" baseline.

Both assume the joint axis is parallel to world z (the scissors of Matsuo et al. 2010 lie on
the table), so only (p, q), the axis position in the x-y plane, is estimated
(docs/design.md 6.1). :class:`PlanarFit` is :func:`fit_axis_planar` behind the
:class:`~tactile_gym.estimation.interface.AxisFit` interface, for the online estimator.

Conventions:

* World frame, metres, radians. Points and edges may be given as (N, 2) or (N, 3); the z
  components are ignored and 3-vector edges are projected onto the x-y plane and normalised.
* The returned :class:`~tactile_gym.estimation.axis.AxisEstimate` has
  ``direction = (0, 0, 1)`` and ``point = (p, q, 0)``.
* Edge orientation: by default the x-y parts of the edges are signed consistently before the
  fit, each like the best-aligned of the few before it (:func:`tactile_gym.spatial.orient_edges`);
  the constant-distance model (paper eq. 16) holds only for consistently oriented edges.
  Successive measurements must therefore be less than 90 degrees of link rotation apart.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import (
    DEGENERATE_CONDITION,
    AxisEstimate,
    as_noise,
    as_points,
    as_unit_edges,
    as_weights,
    degenerate_estimate,
)
from tactile_gym.estimation.interface import AxisFit, Measurements
from tactile_gym.estimation.planar import (
    checked_estimate,
    edge_rotation_variance,
    isotropic_rotation_variance,
    planar_fit,
    planar_residual_variance,
    unit_xy_edges,
)
from tactile_gym.estimation.planar_robust import (
    Rows,
    robust_planar,
)
from tactile_gym.estimation.prior import AxisPrior, check_prior
from tactile_gym.estimation.robust import (
    check_loss,
)
from tactile_gym.spatial import orient_edges

__all__ = ["fit_axis_planar", "fit_axis_simple", "PlanarFit"]


def fit_axis_planar(
    points: np.ndarray,
    edges: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    point_std: np.ndarray | float | None = None,
    edge_std: np.ndarray | float | None = None,
    edge_cov: np.ndarray | None = None,
    loss: str = "linear",
    f_scale: float | None = None,
    resolve_signs: bool = True,
    prior: AxisPrior | None = None,
) -> AxisEstimate:
    """Fit a joint axis parallel to world z from contact points and edge directions.

    Paper eq. 16-21: each measurement gives one row of
    ``(e_yi, -e_xi, -1) (p, q, d)^T = e_yi x_i - e_xi y_i``, the signed distance from the axis
    (p, q) to the edge line minus the common distance d; the rows are solved in the
    (weighted) least-squares sense through the 3x3 normal equations.

    Covariance of (p, q, d): ``sigma^2 (A^T W A)^-1``. With ``weights`` (or stds) the weights
    are taken as absolute inverse variances, so ``sigma^2 = 1``; without, all rows weigh the
    same and ``sigma^2 = RSS / (N - 3)`` (no covariance when N = 3). With a robust loss W
    also holds the loss weights ``rho'`` at the solution and, without weights or stds,
    ``sigma^2 = sum(rho' r^2) / (N - 3)``, as in the 3D fit.

    Args:
        points: (N, 2) or (N, 3) contact points, world frame, m (z ignored).
        edges: (N, 2) or (N, 3) edge directions, world frame (z ignored, then normalised).
            Edges with no x-y component carry no information and are dropped.
        weights: optional (N,) inverse variances of the eq. 16 residuals, 1/m^2.
        point_std: alternative to ``weights``: contact-point std per axis, m (scalar or
            (N,)). Needs ``edge_std`` or ``edge_cov`` too. The residual variances are then
            predicted by :func:`planar_residual_variance` from an unweighted fit and
            refined twice.
        edge_std: total RMS angle error of each edge, rad (scalar or (N,)), isotropic about
            the edge: for 3D edges half its variance turns the edge about z (more when the
            edge is tilted out of the plane), for 2D edges all of it (see
            :func:`edge_rotation_variance`).
        edge_cov: alternative to ``edge_std``: (N, 3, 3) covariance of the perturbation of
            each unit edge, world frame, rad^2, as for
            :func:`~tactile_gym.estimation.fit3d.fit_axis_3d`; only its rotation about z
            matters here.
        loss: ``"linear"`` (least squares) or a robust loss, one of ``LOSSES``, on the
            whitened residuals (with weights or stds) or on the residuals in metres. With
            N >= 6 usable measurements a RANSAC-style consensus over exact 3-measurement
            fits (least median of squares without weights or stds) first sets the wild
            ones aside. After the robust fit, edges that fit far better flipped are
            flipped, and the measurements whose prediction residual lies within the 99 %
            quantile are let back in (then it refits). ``n_used`` counts the measurements
            kept.
        f_scale: residual level where the robust loss starts to bend, in standard
            deviations with weights or stds (default 2), else in metres (default: 2 x a
            MAD-based noise estimate at the starting fit).
        resolve_signs: orient the edges consistently (see the module docstring).
            Pass False when the edges are already oriented.
        prior: optional :class:`~tactile_gym.estimation.prior.AxisPrior`: a Gaussian prior
            on (p, q) from the pin's x-y mean and covariance, added to the normal equations
            (maximum a posteriori; d keeps a flat prior). Needs ``weights`` or stds. The
            estimate then exists from one usable measurement on (none: the prior's own,
            ``method="prior"``), and its covariance includes the prior. The robust loss
            weighs the measurements only.

    Returns:
        The estimate, ``method="planar"``. ``degenerate=True`` with fewer than 3 usable
        measurements or a rank-deficient system (e.g. all edges parallel, fewer than three
        distinct edge directions, identical measurements), unless a prior is given.

    Raises:
        ValueError: on malformed input (shapes, non-finite values, negative weights or stds,
            zero edges, weights given together with stds, unknown loss, f_scale <= 0, a
            prior that is not an AxisPrior or without weights or stds).
    """
    check_loss(loss, f_scale)
    x = as_points(points, "points")
    n = x.shape[0]
    e3 = as_unit_edges(edges, n)
    sx, se, cov = as_noise(point_std, edge_std, edge_cov, e3)
    if weights is not None and sx is not None:
        raise ValueError("give either weights or point_std with edge_std or edge_cov, not both")
    w = None if weights is None else as_weights(weights, n)
    check_prior(prior, w is not None or sx is not None)
    if resolve_signs:
        # Signs from the x-y parts (those the fit uses), applied to the whole edges.
        xy = np.column_stack([e3[:, :2], np.zeros(n)])
        e3 = np.where((np.einsum("ij,ij->i", orient_edges(xy), xy) < 0)[:, None], -e3, e3)
    var_z = None if sx is None else edge_rotation_variance(e3, se, cov)
    if loss != "linear":
        return robust_planar(Rows(x, e3, w, sx, var_z, prior), loss, f_scale)[0]
    if sx is None:
        return checked_estimate(planar_fit(x, e3, w, prior))
    est = (
        checked_estimate(planar_fit(x, e3, None)) if prior is None else prior.estimate(planar=True)
    )
    # Predict the residual variances from the current axis (the prior's, if any) and
    # refit; twice is enough for the levers to settle (they change by the axis error, a
    # few mm).
    e2 = unit_xy_edges(e3)
    for _ in range(2):
        if est.degenerate:
            return est
        var = planar_residual_variance(x[:, :2], e2, est.point[:2], sx, var_z)
        est = checked_estimate(planar_fit(x, e3, 1.0 / var, prior))
    return est


def fit_axis_simple(points: np.ndarray) -> AxisEstimate:
    """The paper's "simple method" baseline (eq. 22-26): intersect perpendicular bisectors.

    Every pair (i, j) of contact points gives ``(x_j - x_i, y_j - y_i) (p, q)^T =
    (x_j^2 - x_i^2 + y_j^2 - y_i^2) / 2``; the N(N-1)/2 rows are solved by least squares.
    It assumes the contact point does not slide on the link.

    The covariance is approximate: that of the geometric circle fit at the estimate, with the
    noise estimated from the radial residuals (``RSS / (N - 3)``; none when N = 3).

    Args:
        points: (N, 2) or (N, 3) contact points, world frame, m (z ignored).

    Returns:
        The estimate, ``method="simple"``; ``distance`` is the mean distance of the contact
        points from the axis. ``degenerate=True`` for fewer than 3 points, coincident points
        or collinear points.

    Raises:
        ValueError: on malformed input.
    """
    x = as_points(points, "points")[:, :2]
    n = x.shape[0]
    if n < 3:
        return degenerate_estimate("simple", n, planar=True)
    i, j = np.triu_indices(n, k=1)
    a = x[j] - x[i]
    sq = np.einsum("ij,ij->i", x, x)
    b = 0.5 * (sq[j] - sq[i])
    scale = float(np.max(np.abs(a)))
    if scale == 0.0:
        return degenerate_estimate("simple", n, planar=True)
    s = np.linalg.svd(a / scale, compute_uv=False)
    if s[1] <= s[0] / DEGENERATE_CONDITION:
        return degenerate_estimate("simple", n, planar=True)
    sol = np.linalg.lstsq(a, b, rcond=None)[0]
    radial = x - sol
    rad = np.sqrt(np.einsum("ij,ij->i", radial, radial))
    r_mean = float(rad.mean())
    res = rad - r_mean
    cov = None
    pos_std = float("inf")
    if n > 3 and np.all(rad > 0):
        jac = np.empty((n, 3))
        jac[:, :2] = -radial / rad[:, None]
        jac[:, 2] = -1.0
        jtj = jac.T @ jac
        if np.linalg.cond(jtj) < DEGENERATE_CONDITION**2:
            cov3 = np.linalg.inv(jtj) * float(res @ res) / (n - 3)
            cov = np.zeros((7, 7))
            idx = [0, 1, 6]
            cov[np.ix_(idx, idx)] = cov3
            pos_std = float(np.sqrt(cov3[0, 0] + cov3[1, 1]))
    return AxisEstimate(
        point=np.array([sol[0], sol[1], 0.0]),
        direction=np.array([0.0, 0.0, 1.0]),
        distance=r_mean,
        covariance=cov,
        position_std=pos_std,
        angle_std=0.0,
        residual_rms=float(np.sqrt(res @ res / n)),
        n_used=n,
        degenerate=False,
        condition_number=float(s[0] / s[1]),
        method="simple",
    )


class PlanarFit(AxisFit):
    """:func:`fit_axis_planar` as an :class:`~tactile_gym.estimation.interface.AxisFit`.

    ``edge_noise`` rows are the variances of the edges' rotation about z, rad^2
    (:func:`~tactile_gym.estimation.planar.edge_rotation_variance`); the edges have z = 0.
    Each measurement is weighted by the inverse of its predicted residual variance
    ``point_std^2 + lever^2 var_z`` (docs/design.md 6.3), the lever taken at an axis.

    * ``"linear"``: a fit weighs the measurements at an unweighted fit's axis (the prior's
      when given) and refits once more at its own; an update weighs them once at the state,
      the last estimate that was not degenerate (with a prior: the last estimate).
    * robust losses: :func:`fit_axis_planar`'s robust fit (consensus from 6 measurements
      on, docs/design.md 6.4); an update starts from the state, the last solution, without
      consensus, until the measurements grew by ``FULL_REFIT_GROWTH`` since the last full
      fit.

    Args:
        loss: as for :class:`~tactile_gym.estimation.interface.AxisFit`.
        prior: as for :class:`~tactile_gym.estimation.interface.AxisFit`; only its pin's
            x-y counts (the axis is vertical by assumption).
    """

    def edge_noise(
        self, edge: np.ndarray, dims: int, edge_std: float, edge_cov: np.ndarray | None
    ) -> float:
        if edge_cov is not None:
            return float(edge_rotation_variance(edge[None, :dims], edge_std, edge_cov[None])[0])
        el = edge.tolist()
        length = math.sqrt(el[0] * el[0] + el[1] * el[1] + el[2] * el[2])
        rho2 = (el[0] * el[0] + el[1] * el[1]) / (length * length)
        return isotropic_rotation_variance(edge_std, rho2, dims)

    def fit(self, data: Measurements) -> AxisEstimate:
        if self.loss != "linear":
            return self._robust(data, None)
        if self.prior is None:
            start = planar_fit(data.points, data.edges, None)
        else:
            start = self.prior.estimate(planar=True)
        return self._weighted(data, start, 2)

    def update(self, data: Measurements) -> AxisEstimate | None:
        if self._state is None:
            return None
        if self.loss != "linear":
            return None if self._grown(data.n) else self._robust(data, self._state)
        if self._state.degenerate:
            return None
        return self._weighted(data, self._state, 1)

    def _robust(self, data: Measurements, start) -> AxisEstimate:
        rows = Rows(data.points, data.edges, None, data.point_std, data.edge_noise, self.prior)
        est, self._state = robust_planar(rows, self.loss, None, start)
        if start is None:
            self._n_full = data.n
        return est

    def _weighted(self, data: Measurements, est: AxisEstimate | None, passes: int):
        """``passes`` weighted fits, the levers taken at ``est`` and then at each result."""
        x, e = data.points, data.edges
        n = data.n
        for _ in range(passes):
            if est is None or est.degenerate:
                est = degenerate_estimate("planar", n, planar=True)
                break
            var = planar_residual_variance(
                x[:, :2], e[:, :2], est.point[:2], data.point_std, data.edge_noise
            )
            est = planar_fit(x, e, 1.0 / var, self.prior)
        if est is None:
            est = degenerate_estimate("planar", n, planar=True)
        if self.prior is not None or not est.degenerate:
            self._state = est
        return est
