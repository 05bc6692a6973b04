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
from tactile_gym.estimation.prior import AxisPrior, check_prior
from tactile_gym.estimation.robust import (
    CHI2_99,
    check_loss,
    consensus,
    mad_f_scale,
    robust_weights,
    sign_flips,
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
    # Edges with less x-y part than this are dropped by the fit; keep them finite.
    rho2 = np.maximum(e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1], _NO_XY * _NO_XY)
    if edge_cov is None:
        std = np.asarray(edge_std, dtype=float)
        return np.ones(e.shape[0]) * _isotropic_rotation_variance(std, rho2, e.shape[1])
    hx = -e[:, 1] / rho2
    hy = e[:, 0] / rho2
    c = edge_cov
    return hx * hx * c[:, 0, 0] + 2.0 * hx * hy * c[:, 0, 1] + hy * hy * c[:, 1, 1]


def _isotropic_rotation_variance(edge_std, rho2, dims: int):
    """:func:`edge_rotation_variance` of isotropic noise, for scalars or arrays: a 2D edge
    (``dims`` 2) turns about z by all of ``edge_std``, a 3D edge whose x-y part has the
    squared length ``rho2`` (unit edge) by ``edge_std^2 / (2 rho2)``."""
    if dims == 2:
        return edge_std * edge_std
    return edge_std * edge_std / (2.0 * rho2)


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
        return _robust_planar(_Rows(x, e3, w, sx, var_z, prior), loss, f_scale)[0]
    if sx is None:
        return _checked(_planar_fit(x, e3, w, prior))
    est = _checked(_planar_fit(x, e3, None)) if prior is None else prior.estimate(planar=True)
    # Predict the residual variances from the current axis (the prior's, if any) and
    # refit; twice is enough for the levers to settle (they change by the axis error, a
    # few mm).
    e2 = _unit_xy_edges(e3)
    for _ in range(2):
        if est.degenerate:
            return est
        var = planar_residual_variance(x[:, :2], e2, est.point[:2], sx, var_z)
        est = _checked(_planar_fit(x, e3, 1.0 / var, prior))
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


def _planar_fit(
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
    if n >= _PLANAR_NUMPY_MIN_N and (w is None or w.all()):
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

    return _planar_solve((a00, a01, a02, a11, a12, a22), (r0, r1, r2), len(rows), w, rss, prior)


def _planar_fit_numpy(
    x: np.ndarray, e3: np.ndarray, w: np.ndarray | None, prior: AxisPrior | None
) -> AxisEstimate | None:
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
        prior,
    )


def _sym3_solve(normal: tuple[float, ...], rhs: tuple[float, ...]):
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
        normal, rhs = _with_prior(normal, rhs, prior)
    elif n < 3:
        return degenerate_estimate("planar", n, planar=True)
    solved = _sym3_solve(normal, rhs)
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


def _with_prior(normal, rhs, prior: AxisPrior):
    """The upper triangle of the normal matrix and the right-hand side of the normal
    equations of (p, q, d), with the prior's information on (p, q) added."""
    l00, l01, l11, h0, h1 = prior.planar_information
    a00, a01, a02, a11, a12, a22 = normal
    return (a00 + l00, a01 + l01, a02, a11 + l11, a12, a22), (rhs[0] + h0, rhs[1] + h1, rhs[2])


# ------------------------------------------------------------------------- robust fit

# From this many usable measurements on, a consensus over exact 3-measurement fits
# precedes the robust fit: an L1-like loss alone does not reject a wild edge far from the
# axis (its residual is its lever times its angle error, and it pulls on the axis).
_CONSENSUS_MIN_N = 6

# The robust fit stops when (p, q, d) move by less than this, m: far below the estimate's
# own std (mm), and reweighting converges only linearly.
_ROBUST_TOL = 1e-7
_ROBUST_MAX_ITER = 50
# Rounds of (robust fit, sign and inlier update).
_ROBUST_ROUNDS = 3


class _Rows:
    """The eq. 16 rows of the measurements that have an x-y edge (and weight > 0).

    Row i: ``r_i = s_i + d`` with ``s_i = sign_i (b_i - e_yi p + e_xi q)``, the signed distance
    from the axis to the edge line (sign +-1: the edge as given or flipped). The predicted
    variance of ``r_i`` is fixed (``1 / w``, or 1 m^2 without weights or stds) or, with
    stds, ``point_std^2 + lever^2 var_z`` at the current axis.

    Attributes:
        x, e3: the measurements as given (for the final fit); ``idx``: (M,) the rows' indices.
        ex, ey: (M,) unit x-y edges; ``b``: (M,) ``e_y x - e_x y``; ``t``: (M,) ``e . x``
            (the lever is ``t - e . axis``); ``sign``: (M,) +-1.
        noise: whether the variances are absolute (weights or stds given).
        prior: the :class:`~tactile_gym.estimation.prior.AxisPrior` or None (needs noise);
            ``prior_theta``: its (p, q, 0) or None.
    """

    def __init__(self, x, e3, w, sx, var_z, prior=None):
        nxy = np.hypot(e3[:, 0], e3[:, 1])
        use = nxy > _NO_XY * np.sqrt(np.einsum("ij,ij->i", e3, e3))
        if w is not None:
            use &= w > 0
        self.x, self.e3 = x, e3
        self.idx = idx = np.flatnonzero(use)
        self.ex = e3[idx, 0] / nxy[idx]
        self.ey = e3[idx, 1] / nxy[idx]
        px, py = x[idx, 0], x[idx, 1]
        self.b = self.ey * px - self.ex * py
        self.t = self.ex * px + self.ey * py
        self.sign = np.ones(idx.size)
        self.noise = w is not None or sx is not None
        if sx is None:
            self.var_z = None
            self.fixed_var = np.ones(idx.size) if w is None else 1.0 / w[idx]
        else:
            self.var_z = var_z[idx]
            self.sx2 = np.square(sx[idx])
        self.prior = prior
        self.prior_theta = None if prior is None else np.array([*prior.pin[:2], 0.0])

    @property
    def m(self) -> int:
        return self.idx.size

    def design(self, sel) -> tuple[np.ndarray, np.ndarray]:
        """(A, b) of the selected rows, with their signs: ``r = b - A (p, q, d)``."""
        sg = self.sign[sel]
        a = np.empty((sg.size, 3))
        a[:, 0] = sg * self.ey[sel]
        a[:, 1] = -sg * self.ex[sel]
        a[:, 2] = -1.0
        return a, sg * self.b[sel]

    def variance_model(self, sel=slice(None)):
        """The predicted variances of the selected rows' residuals, m^2, as a function of
        the axis ``theta = (p, q, d)``."""
        if self.var_z is None:
            fixed = self.fixed_var[sel]
            return lambda theta: fixed
        t, ex, ey = self.t[sel], self.ex[sel], self.ey[sel]
        sx2, var_z = self.sx2[sel], self.var_z[sel]

        def variances(theta):
            lever = t - ex * theta[0] - ey * theta[1]
            return sx2 + lever * lever * var_z + _VARIANCE_FLOOR

        return variances

    def sq_norms(self, theta, fit=None) -> tuple[np.ndarray, np.ndarray]:
        """(M,) squared whitened residuals with each edge as signed, and flipped.

        ``fit``: optional ``(cov, sigma2)`` of a fit at ``theta``: the covariance of
        (p, q, d) and, without a noise model, the noise variance. The residuals are then
        whitened by their prediction variance, which adds the fit's own uncertainty at each
        row: a row that the fit, made without it, barely constrains (a large lever, an odd
        direction) is not taken for an outlier. Without either a noise model or ``fit``
        they are the squared residuals, m^2.
        """
        p, q, d = theta
        dist = self.sign * (self.b - self.ey * p + self.ex * q)
        keep = (dist + d) ** 2
        flipped = (d - dist) ** 2
        var = self.variance_model()(theta)
        if fit is None:
            return keep / var, flipped / var
        cov, sigma2 = fit
        if sigma2 is not None:
            var = sigma2
        u = self.sign * self.ey
        v = -self.sign * self.ex
        even = u * u * cov[0, 0] + v * v * cov[1, 1] + 2.0 * u * v * cov[0, 1] + cov[2, 2]
        odd = 2.0 * (u * cov[0, 2] + v * cov[1, 2])
        return keep / (var + even - odd), flipped / (var + even + odd)

    def exact(self, tri: np.ndarray) -> np.ndarray | None:
        """(p, q, d) through three rows, or None when their edges are (nearly) parallel.

        With a prior: the maximum a posteriori (p, q, d) of the three rows, weighted by
        their variances at the prior's axis (exact rows fitted to their noise, after a
        small turn of the link, are far off).
        """
        a, b = self.design(tri)
        if self.prior is not None:
            var = self.variance_model(tri)(self.prior_theta)
            return _weighted_solve(a, b, 1.0 / var, self.prior)
        if not abs(np.linalg.det(a)) > 1e-6:
            return None
        return np.linalg.solve(a, b)

    def information(self, a: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The information matrix ``A^T W A`` of (p, q, d), with the prior's added."""
        info = (a * w[:, None]).T @ a
        if self.prior is not None:
            l00, l01, l11, _, _ = self.prior.planar_information
            info[:2, :2] += [[l00, l01], [l01, l11]]
        return info


def _robust_planar(rows: _Rows, loss: str, f_scale: float | None, start=None):
    """:func:`fit_axis_planar` with a robust loss, on validated rows with oriented edges.

    Args:
        rows: the rows.
        loss, f_scale: as for :func:`fit_axis_planar`.
        start: optional ``(theta, sel, sign)`` of an earlier fit of the first rows (the
            online estimator's): it replaces the consensus, the rows after them join
            as candidates.

    Returns:
        ``(estimate, (theta, sel, sign))``: the estimate and the solution for a later
        ``start`` (None when the estimate is degenerate).
    """
    m = rows.m
    if rows.prior is not None and m == 0:
        return rows.prior.estimate(planar=True), None
    if rows.prior is None and m < 3:
        return degenerate_estimate("planar", m, planar=True), None
    sel = np.ones(m, dtype=bool)
    found = None
    if start is not None:
        theta, old_sel, old_sign = start
        sel[: old_sel.size] = old_sel
        rows.sign[: old_sign.size] = old_sign
        found = sel, theta, 1.0
    elif m >= _CONSENSUS_MIN_N:
        found = consensus(
            m, rows.exact, lambda th: np.minimum(*rows.sq_norms(th)), 1, whitened=rows.noise
        )
    if found is None:
        a, b = rows.design(sel)
        if rows.prior is None:
            theta = _weighted_solve(a, b, np.ones(m))
        else:
            theta = _weighted_solve(a, b, 1.0 / rows.variance_model()(rows.prior_theta), rows.prior)
    else:
        # Signs are decided at the robust fit below: an exact 3-measurement fit is too rough
        # to judge them, and a valid edge flipped costs this badly conditioned fit dearly.
        sel, theta, _ = found
    if theta is None:
        return degenerate_estimate("planar", m, planar=True), None
    if f_scale is None:
        a, b = rows.design(sel)
        f_scale = 2.0 if rows.noise else mad_f_scale(b - a @ theta)
    for _ in range(_ROBUST_ROUNDS):
        theta = _irls(rows, sel, theta, loss, f_scale)
        if theta is None:
            return degenerate_estimate("planar", m, planar=True), None
        weights, sigma2 = _solution_weights(rows, sel, theta, loss, f_scale)
        a, _ = rows.design(sel)
        try:
            cov = np.linalg.inv(rows.information(a, weights[sel]))
        except np.linalg.LinAlgError:
            return degenerate_estimate("planar", m, planar=True), None
        # Edges that fit far better flipped, and (after a consensus) the measurements the
        # fit explains, then once more.
        keep, flipped = rows.sq_norms(theta, (cov, sigma2))
        flip = sign_flips(keep, flipped, 1)
        again = sel
        if found is not None:
            again = np.where(flip, flipped, keep) < CHI2_99[1]
            if again.sum() < 4:
                again = sel
        if not flip.any() and (again == sel).all():
            break
        rows.sign = np.where(flip, -rows.sign, rows.sign)
        sel = again
    est = _robust_estimate(rows, sel, theta, loss, f_scale)
    return est, None if est.degenerate else (theta, sel, rows.sign)


def _weighted_solve(
    a: np.ndarray, b: np.ndarray, w: np.ndarray, prior: AxisPrior | None = None
) -> np.ndarray | None:
    """Weighted least squares ``argmin sum w (b - a theta)^2`` (plus the prior's cost on
    (p, q), w then absolute); None if rank deficient."""
    return _augmented_solve(np.column_stack([a, b]), w, prior)


def _augmented_solve(
    m: np.ndarray, w: np.ndarray, prior: AxisPrior | None = None
) -> np.ndarray | None:
    """:func:`_weighted_solve` of the augmented rows ``m = [a | b]`` (M, 4)."""
    g = ((m * w[:, None]).T @ m).tolist()
    normal = (g[0][0], g[0][1], g[0][2], g[1][1], g[1][2], g[2][2])
    rhs = g[3][:3]
    if prior is not None:
        normal, rhs = _with_prior(normal, rhs, prior)
    solved = _sym3_solve(normal, rhs)
    return None if solved is None else np.array(solved[0])


def _irls(rows: _Rows, sel, theta, loss: str, f_scale: float) -> np.ndarray | None:
    """Iteratively reweighted least squares of the robust loss over the selected rows,
    with the residual variances re-predicted at each step's axis."""
    a, b = rows.design(sel)
    m = np.column_stack([a, b])
    variances = rows.variance_model(sel)
    for _ in range(_ROBUST_MAX_ITER):
        var = variances(theta)
        r = b - a @ theta
        w = robust_weights(r / np.sqrt(var), loss, f_scale) / var
        new = _augmented_solve(m, w, rows.prior)
        if new is None:
            return None
        step = (new - theta).tolist()
        theta = new
        if max(abs(step[0]), abs(step[1]), abs(step[2])) <= _ROBUST_TOL:
            break
    return theta


def _solution_weights(rows: _Rows, sel, theta, loss: str, f_scale: float):
    """(M,) absolute inverse variances of the rows at the robust solution, the loss weights
    included (0 outside ``sel``), and the noise variance estimated from the residuals
    without a noise model (``sum(rho' r^2) / (n - 3)``, m^2; None with one, or with no
    residual degrees of freedom)."""
    a, b = rows.design(sel)
    r = b - a @ theta
    var = rows.variance_model(sel)(theta)
    w = robust_weights(r / np.sqrt(var), loss, f_scale) / var
    sigma2 = None
    n_sel = int(sel.sum())
    if not rows.noise and n_sel > 3:
        sigma2 = float(w @ (r * r)) / (n_sel - 3)
        w = w / sigma2
    out = np.zeros(rows.m)
    out[sel] = w
    return out, sigma2


def _robust_estimate(rows: _Rows, sel, theta, loss: str, f_scale: float) -> AxisEstimate:
    """The estimate at the robust solution: the weighted fit with the solution's weights
    (its covariance is then that of the robust fit)."""
    e3 = rows.e3.copy()
    e3[rows.idx] *= rows.sign[:, None]
    if not rows.noise and sel.sum() <= 3:
        kept = rows.idx[sel]
        return _checked(_planar_fit(rows.x[kept], e3[kept], None))
    weights = np.zeros(rows.x.shape[0])
    weights[rows.idx] = _solution_weights(rows, sel, theta, loss, f_scale)[0]
    return _checked(_planar_fit(rows.x, e3, weights, rows.prior))


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
