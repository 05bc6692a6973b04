"""The planar fit's linear algebra: eq. 16-21 solved in closed form, and its noise model.

The paper's proposed method (Matsuo et al. 2010, docs/design.md 6.1) assumes the joint axis
is parallel to world z, so only (p, q), the axis position in the x-y plane, and the common
distance d are estimated: each measurement gives one row of
``(e_yi, -e_xi, -1) (p, q, d)^T = e_yi x_i - e_xi y_i``. The rows are weighted by the inverse
of their predicted variance (:func:`planar_residual_variance`, docs/design.md 6.3).

Conventions: world frame, metres, radians; points and edges (N, 2) or (N, 3), the z parts
ignored and the x-y parts of the edges normalised; the result has ``direction = (0, 0, 1)``
and ``point = (p, q, 0)``.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import (
    AxisEstimate,
    degenerate_estimate,
)
from tactile_gym.estimation.prior import AxisPrior

__all__ = [
    "NO_XY",
    "NUMPY_MIN_N",
    "VARIANCE_FLOOR",
    "checked_estimate",
    "edge_rotation_variance",
    "isotropic_rotation_variance",
    "planar_fit",
    "planar_residual_variance",
    "sym3_solve",
    "unit_xy_edges",
    "with_prior",
]

# Floor on a residual variance so that exact data with zero stds keep finite weights, m^2.
VARIANCE_FLOOR = 1e-18


# The planar system is solved through its normal equations, which square the condition
# number; beyond this (Frobenius) condition of the weighted design matrix the solution has
# lost most of its digits and the data count as rank deficient.
_PLANAR_DEGENERATE_CONDITION = 1e7


# An edge whose x-y part is below this fraction of its length is taken as parallel to z.
NO_XY = 1e-9


# From this many measurements on, numpy's vectorised arithmetic beats a plain-Python loop.
NUMPY_MIN_N = 12


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
    return np.square(point_std) + np.square(lever) * edge_var + VARIANCE_FLOOR


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
    # Edges with less x-y part than this are dropped by the fit; keep them finite.
    rho2 = np.maximum(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1], NO_XY * NO_XY)
    if edge_cov is None:
        std = np.asarray(edge_std, dtype=float)
        return np.ones(e.shape[0]) * isotropic_rotation_variance(std, rho2, e.shape[1])
    hx = -e[:, 1] / rho2
    hy = e[:, 0] / rho2
    c = edge_cov
    return hx * hx * c[:, 0, 0] + 2.0 * hx * hy * c[:, 0, 1] + hy * hy * c[:, 1, 1]


def isotropic_rotation_variance(edge_std, rho2, dims: int):
    """:func:`edge_rotation_variance` of isotropic noise, for scalars or arrays: a 2D edge
    (``dims`` 2) turns about z by all of ``edge_std``, a 3D edge whose x-y part has the
    squared length ``rho2`` (unit edge) by ``edge_std^2 / (2 rho2)``."""
    if dims == 2:
        return edge_std * edge_std
    return edge_std * edge_std / (2.0 * rho2)


def checked_estimate(est: AxisEstimate | None) -> AxisEstimate:
    """The estimate of validated input; None there means that the normal equations overflowed."""
    if est is None:
        raise ValueError("points, edges or weights are too large: the normal equations overflow")
    return est


def unit_xy_edges(e3: np.ndarray) -> np.ndarray:
    """(N, 2) unit x-y parts of the edges (zero rows where an edge has no x-y part).

    Only used for the residual variances, which do not depend on the edge orientation.
    """
    e = e3[:, :2]
    nxy = np.hypot(e[:, 0], e[:, 1])
    ok = nxy > NO_XY * np.linalg.norm(e3, axis=1)
    return np.where(ok[:, None], e / np.where(ok, nxy, 1.0)[:, None], 0.0)


def planar_fit(
    x: np.ndarray, e3: np.ndarray, w: np.ndarray | None, prior: AxisPrior | None = None
) -> AxisEstimate | None:
    """Eq. 18-21 on shape-checked arrays; None when an input is non-finite, an edge zero or
    the arithmetic overflows.

    w holds inverse variances (rows with w = 0 are dropped). The normal equations
    ``A^T W A (p, q, d) = A^T W b`` are accumulated and solved in closed form, with the
    prior's information on (p, q) added (it needs w). This is the hot path of the online
    estimator: for a few rows a plain-Python loop beats numpy's per-call overhead, and for
    many rows a lean vectorised version takes over.
    """
    n = x.shape[0]
    if n >= NUMPY_MIN_N and (w is None or w.all()):
        est = _planar_fit_numpy(x, e3, w, prior)
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
        if nxy2 <= NO_XY * NO_XY * n2:
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

    return _planar_solve((a00, a01, a02, a11, a12, a22), (r0, r1, r2), len(rows), w, rss, prior)


def _planar_fit_numpy(
    x: np.ndarray, e3: np.ndarray, w: np.ndarray | None, prior: AxisPrior | None
) -> AxisEstimate | None:
    """Vectorised twin of the loop in :func:`planar_fit` for many rows with usable edges.

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
        usable = float(nxy2.min()) > NO_XY * NO_XY * float((e3 * e3).sum(axis=1).max())
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
        prior,
    )


def sym3_solve(normal: tuple[float, ...], rhs: tuple[float, ...]):
    """Solve a symmetric positive definite 3x3 system by cofactors (plain Python: for one
    small system numpy's per-call overhead dominates).

    Args:
        normal: the upper triangle ``(a00, a01, a02, a11, a12, a22)``.
        rhs: ``(r0, r1, r2)``.

    Returns:
        ``(solution, cofactors, det)`` with the cofactors in the order of ``normal``, or
        None when the determinant is not positive.
    """
    a00, a01, a02, a11, a12, a22 = normal
    r0, r1, r2 = rhs
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    if not det > 0.0:
        return None
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    inv_det = 1.0 / det
    solution = (
        (c00 * r0 + c01 * r1 + c02 * r2) * inv_det,
        (c01 * r0 + c11 * r1 + c12 * r2) * inv_det,
        (c02 * r0 + c12 * r1 + c22 * r2) * inv_det,
    )
    return solution, (c00, c01, c02, c11, c12, c22), det


def _planar_solve(
    normal: tuple[float, ...],
    rhs: tuple[float, float, float],
    n: int,
    w: np.ndarray | None,
    rss_at: object,
    prior: AxisPrior | None = None,
) -> AxisEstimate | None:
    """Solve the 3x3 normal equations of n rows, the prior's information on (p, q) added,
    by cofactors and assemble the estimate.

    ``rss_at(p, q, d)`` returns the unweighted residual sum of squares. None when the
    solution or its covariance overflows (inputs of order 1e150 m and beyond).
    """
    if prior is not None:
        if n == 0:
            return prior.estimate(planar=True)
        normal, rhs = with_prior(normal, rhs, prior)
    elif n < 3:
        return degenerate_estimate("planar", n, planar=True)
    solved = sym3_solve(normal, rhs)
    if solved is None:
        return degenerate_estimate("planar", n, planar=True)
    (p, q, d), (c00, c01, c02, c11, c12, c22), det = solved
    a00, a01, a02, a11, a12, a22 = normal
    norm2 = a00 * a00 + a11 * a11 + a22 * a22 + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12)
    inv_norm2 = (c00 * c00 + c11 * c11 + c22 * c22 + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)) / (
        det * det
    )
    # The Frobenius condition number of A^T W A is about the square of that of sqrt(W) A.
    cond = math.sqrt(math.sqrt(norm2 * inv_norm2))
    if not cond < _PLANAR_DEGENERATE_CONDITION:
        return degenerate_estimate("planar", n, planar=True)
    inv_det = 1.0 / det
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


def with_prior(normal, rhs, prior: AxisPrior):
    """The upper triangle of the normal matrix and the right-hand side of the normal
    equations of (p, q, d), with the prior's information on (p, q) added."""
    l00, l01, l11, h0, h1 = prior.planar_information
    a00, a01, a02, a11, a12, a22 = normal
    return (a00 + l00, a01 + l01, a02, a11 + l11, a12, a22), (rhs[0] + h0, rhs[1] + h1, rhs[2])
