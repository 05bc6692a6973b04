"""Planar joint-axis fits: the paper's proposed method and its "simple method" baseline.

Both assume the joint axis is parallel to world z (the scissors of Matsuo et al. 2010 lie on
the table), so only (p, q), the axis position in the x-y plane, is estimated.

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
from tactile_gym.spatial import orient_edges

__all__ = [
    "edge_rotation_variance",
    "fit_axis_planar",
    "fit_axis_simple",
    "planar_residual_variance",
]

# Floor on a residual variance so that exact data with zero stds keep finite weights, m^2.
_VARIANCE_FLOOR = 1e-18

# The planar system is solved through its normal equations, which square the condition
# number; beyond this (Frobenius) condition of the weighted design matrix the solution has
# lost most of its digits and the data count as rank deficient.
_PLANAR_DEGENERATE_CONDITION = 1e7


def planar_residual_variance(
    points: np.ndarray,
    edges: np.ndarray,
    axis_xy: np.ndarray,
    point_std: np.ndarray | float,
    edge_var: np.ndarray | float,
) -> np.ndarray:
    """Predicted variance of the eq. 16 residual of each measurement, m^2.

    ``sigma_r^2 = point_std^2 + lever^2 edge_var``: the point error across the edge moves
    the residual one for one; an edge rotation by ``delta`` about z moves it by
    ``lever * delta``, where ``lever = e_i . (x_i - axis)`` is the distance along the edge
    from the contact point to the foot of the perpendicular from the axis.

    Args:
        points: (N, 2) contact points, world x-y, m.
        edges: (N, 2) unit x-y edge directions.
        axis_xy: (2,) current axis position estimate, m.
        point_std: contact-point std per axis, m; scalar or (N,).
        edge_var: variance of the edge's rotation about world z, rad^2; scalar or (N,)
            (see :func:`edge_rotation_variance`).
    """
    lever = np.einsum("ij,ij->i", edges, points - axis_xy)
    return np.square(point_std) + np.square(lever) * edge_var + _VARIANCE_FLOOR


def edge_rotation_variance(
    edges: np.ndarray, edge_std: np.ndarray | float, edge_cov: np.ndarray | None = None
) -> np.ndarray:
    """(N,) variance of the rotation about world z of each edge's x-y direction, rad^2.

    A perturbation ``de`` of the unit edge e turns its x-y direction by ``h . de``, with
    ``h = (-e_y, e_x, 0) / rho^2`` and ``rho = |(e_x, e_y)|``: the variance is
    ``h^T edge_cov h``. Without ``edge_cov`` the noise is isotropic about the edge: for 3D
    edges ``edge_cov = (edge_std^2 / 2) (I - e e^T)``, so ``edge_std^2 / (2 rho^2)``; a 2D
    edge has one normal direction only, in the plane, so ``edge_std^2``.

    Args:
        edges: (N, 2) or (N, 3) edge directions, world frame, with an x-y part.
        edge_std: total RMS angle error of each edge, rad; scalar or (N,). Used without
            ``edge_cov``.
        edge_cov: optional (N, 3, 3) validated edge covariances, world frame, rad^2.
    """
    e = edges / np.linalg.norm(edges, axis=1)[:, None]
    if edge_cov is None and e.shape[1] == 2:
        return np.full(e.shape[0], 1.0) * np.square(edge_std)
    # Edges with less x-y part than this are dropped by the fit; keep them finite.
    rho2 = np.maximum(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1], _NO_XY * _NO_XY)
    if edge_cov is None:
        return np.square(edge_std) / (2.0 * rho2)
    hx = -e[:, 1] / rho2
    hy = e[:, 0] / rho2
    c = edge_cov
    return hx * hx * c[:, 0, 0] + 2.0 * hx * hy * c[:, 0, 1] + hy * hy * c[:, 1, 1]


def fit_axis_planar(
    points: np.ndarray,
    edges: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    point_std: np.ndarray | float | None = None,
    edge_std: np.ndarray | float | None = None,
    edge_cov: np.ndarray | None = None,
    resolve_signs: bool = True,
) -> AxisEstimate:
    """Fit a joint axis parallel to world z from contact points and edge directions.

    Paper eq. 16-21: each measurement gives one row of
    ``(e_yi, -e_xi, -1) (p, q, d)^T = e_yi x_i - e_xi y_i``, the signed distance from the axis
    (p, q) to the edge line minus the common distance d; the rows are solved in the
    (weighted) least-squares sense by SVD.

    Covariance of (p, q, d): ``sigma^2 (A^T W A)^-1``. With ``weights`` (or stds) the weights
    are taken as absolute inverse variances, so ``sigma^2 = 1``; without, all rows weigh the
    same and ``sigma^2 = RSS / (N - 3)`` (no covariance when N = 3).

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
        resolve_signs: orient the edges consistently (see the module docstring).
            Pass False when the edges are already oriented.

    Returns:
        The estimate, ``method="planar"``. ``degenerate=True`` with fewer than 3 usable
        measurements or a rank-deficient system (e.g. all edges parallel, fewer than three
        distinct edge directions, identical measurements).

    Raises:
        ValueError: on malformed input (shapes, non-finite values, negative weights or stds,
            zero edges, weights given together with stds).
    """
    x = as_points(points, "points")
    n = x.shape[0]
    e3 = as_unit_edges(edges, n)
    unit3 = e3 if e3.shape[1] == 3 else np.column_stack([e3, np.zeros(n)])
    sx, se, cov = as_noise(point_std, edge_std, edge_cov, unit3)
    if weights is not None and sx is not None:
        raise ValueError("give either weights or point_std with edge_std or edge_cov, not both")
    w = None if weights is None else as_weights(weights, n)
    if resolve_signs:
        # Signs from the x-y parts (those the fit uses), applied to the whole edges.
        xy = np.column_stack([e3[:, :2], np.zeros(n)])
        e3 = np.where((np.einsum("ij,ij->i", orient_edges(xy), xy) < 0)[:, None], -e3, e3)
    if sx is None:
        return _checked(_planar_fit(x, e3, w))
    var_z = edge_rotation_variance(e3, se, cov)
    est = _checked(_planar_fit(x, e3, None))
    # Predict the residual variances from the current axis and refit; twice is enough for
    # the levers to settle (they change by the axis error, a few mm).
    e2 = _unit_xy_edges(e3)
    for _ in range(2):
        if est.degenerate:
            return est
        var = planar_residual_variance(x[:, :2], e2, est.point[:2], sx, var_z)
        est = _checked(_planar_fit(x, e3, 1.0 / var))
    return est


def _checked(est: AxisEstimate | None) -> AxisEstimate:
    """The estimate of validated input; None there means that the normal equations overflowed."""
    if est is None:
        raise ValueError("points, edges or weights are too large: the normal equations overflow")
    return est


def _unit_xy_edges(e3: np.ndarray) -> np.ndarray:
    """(N, 2) unit x-y parts of the edges (zero rows where an edge has no x-y part).

    Only used for the residual variances, which do not depend on the edge orientation.
    """
    e = e3[:, :2]
    nxy = np.hypot(e[:, 0], e[:, 1])
    ok = nxy > _NO_XY * np.linalg.norm(e3, axis=1)
    return np.where(ok[:, None], e / np.where(ok, nxy, 1.0)[:, None], 0.0)


# An edge whose x-y part is below this fraction of its length is taken as parallel to z.
_NO_XY = 1e-9

# From this many measurements on, numpy's vectorised arithmetic beats a plain-Python loop.
_PLANAR_NUMPY_MIN_N = 12


def _planar_fit(x: np.ndarray, e3: np.ndarray, w: np.ndarray | None) -> AxisEstimate | None:
    """Eq. 18-21 on shape-checked arrays; None when an input is non-finite, an edge zero or
    the arithmetic overflows.

    w holds inverse variances (rows with w = 0 are dropped). The normal equations
    ``A^T W A (p, q, d) = A^T W b`` are accumulated and solved in closed form. This is the
    hot path of the online estimator: for a few rows a plain-Python loop beats numpy's
    per-call overhead, and for many rows a lean vectorised version takes over.
    """
    n = x.shape[0]
    if n >= _PLANAR_NUMPY_MIN_N and (w is None or w.all()):
        est = _planar_fit_numpy(x, e3, w)
        if est is not None:
            return est
    xl = x.tolist()
    el = e3.tolist()
    wl = None if w is None else w.tolist()
    three = e3.shape[1] == 3
    rows = []
    a00 = a01 = a02 = a11 = a12 = a22 = r0 = r1 = r2 = 0.0
    for i in range(n):
        ei = el[i]
        ex = ei[0]
        ey = ei[1]
        nxy2 = ex * ex + ey * ey
        n2 = nxy2 + ei[2] * ei[2] if three else nxy2
        if not n2 > 0.0:
            return None
        if nxy2 <= _NO_XY * _NO_XY * n2:
            continue
        wi = 1.0 if wl is None else wl[i]
        if wi == 0.0:
            continue
        k = 1.0 / math.sqrt(nxy2)
        ex *= k
        ey *= k
        xi = xl[i]
        b = ey * xi[0] - ex * xi[1]
        rows.append((ex, ey, b))
        wey = wi * ey
        wex = wi * ex
        a00 += wey * ey
        a01 -= wey * ex
        a02 -= wey
        a11 += wex * ex
        a12 += wex
        a22 += wi
        r0 += wey * b
        r1 -= wex * b
        r2 -= wi * b
    if not math.isfinite(a00 + a01 + a02 + a11 + a12 + a22 + r0 + r1 + r2):
        return None

    def rss(p: float, q: float, d: float) -> float:
        total = 0.0
        for ex, ey, b in rows:
            r = b - ey * p + ex * q + d
            total += r * r
        return total

    return _planar_solve((a00, a01, a02, a11, a12, a22), (r0, r1, r2), len(rows), w, rss)


def _planar_fit_numpy(x: np.ndarray, e3: np.ndarray, w: np.ndarray | None) -> AxisEstimate | None:
    """Vectorised twin of the loop in :func:`_planar_fit` for many rows with usable edges.

    Returns None (the caller falls back to the loop) when an edge has no x-y part or an
    input is not finite.
    """
    n = x.shape[0]
    ex = e3[:, 0]
    ey = e3[:, 1]
    nxy2 = ex * ex + ey * ey
    if e3.shape[1] == 2:
        usable = float(nxy2.min()) > 0.0
    else:
        usable = float(nxy2.min()) > _NO_XY * _NO_XY * float((e3 * e3).sum(axis=1).max())
    if not usable:
        return None
    s = 1.0 / np.sqrt(nxy2)
    # Rows of m: the columns of A = (e_y, -e_x, -1), then b.
    m = np.empty((4, n))
    np.multiply(ey, s, out=m[0])
    np.multiply(ex, s, out=m[1])
    b = m[3]
    np.multiply(m[0], x[:, 0], out=b)
    b -= m[1] * x[:, 1]
    m[1] *= -1.0
    m[2] = -1.0
    g = (m @ m.T if w is None else (m * w) @ m.T).tolist()
    if not math.isfinite(sum(g[0]) + sum(g[1]) + sum(g[2]) + g[3][3]):
        return None
    a = m[:3]

    def rss(p: float, q: float, d: float) -> float:
        r = b - np.array([p, q, d]) @ a
        return float(r @ r)

    return _planar_solve(
        (g[0][0], g[0][1], g[0][2], g[1][1], g[1][2], g[2][2]),
        (g[0][3], g[1][3], g[2][3]),
        n,
        w,
        rss,
    )


def _planar_solve(
    normal: tuple[float, ...],
    rhs: tuple[float, float, float],
    n: int,
    w: np.ndarray | None,
    rss_at: object,
) -> AxisEstimate | None:
    """Solve the 3x3 normal equations by cofactors and assemble the estimate.

    ``rss_at(p, q, d)`` returns the unweighted residual sum of squares. None when the
    solution or its covariance overflows (inputs of order 1e150 m and beyond).
    """
    if n < 3:
        return degenerate_estimate("planar", n, planar=True)
    a00, a01, a02, a11, a12, a22 = normal
    r0, r1, r2 = rhs
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    if not det > 0.0:
        return degenerate_estimate("planar", n, planar=True)
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    norm2 = a00 * a00 + a11 * a11 + a22 * a22 + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12)
    inv_norm2 = (c00 * c00 + c11 * c11 + c22 * c22 + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)) / (
        det * det
    )
    # The Frobenius condition number of A^T W A is about the square of that of sqrt(W) A.
    cond = math.sqrt(math.sqrt(norm2 * inv_norm2))
    if not cond < _PLANAR_DEGENERATE_CONDITION:
        return degenerate_estimate("planar", n, planar=True)
    inv_det = 1.0 / det
    p = (c00 * r0 + c01 * r1 + c02 * r2) * inv_det
    q = (c01 * r0 + c11 * r1 + c12 * r2) * inv_det
    d = (c02 * r0 + c12 * r1 + c22 * r2) * inv_det
    rss = rss_at(p, q, d)
    size = abs(c00) + abs(c01) + abs(c02) + abs(c11) + abs(c12) + abs(c22)
    if not math.isfinite(p + q + d + rss + size * inv_det):
        return None
    if w is not None:
        scale = 1.0
    elif n > 3:
        scale = rss / (n - 3)
    else:
        scale = None
    if scale is None:
        cov = None
        pos_std = math.inf
    else:
        # distance = |d|: the d row and column change sign with d.
        s = inv_det * scale
        sd = -s if d < 0 else s
        cov = np.zeros((7, 7))
        cov[0, 0] = c00 * s
        cov[1, 1] = c11 * s
        cov[0, 1] = cov[1, 0] = c01 * s
        cov[6, 6] = c22 * s
        cov[0, 6] = cov[6, 0] = c02 * sd
        cov[1, 6] = cov[6, 1] = c12 * sd
        pos_std = math.sqrt(max((c00 + c11) * s, 0.0))
    return AxisEstimate(
        point=np.array([p, q, 0.0]),
        direction=np.array([0.0, 0.0, 1.0]),
        distance=abs(d),
        covariance=cov,
        position_std=pos_std,
        angle_std=0.0,
        residual_rms=math.sqrt(rss / n),
        n_used=n,
        degenerate=False,
        condition_number=cond,
        method="planar",
    )


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
