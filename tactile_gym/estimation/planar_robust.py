"""The planar fit with a robust loss: consensus, reweighting and sign decisions.

Conventions as in :mod:`tactile_gym.estimation.planar` (docs/design.md 6.1). A consensus over
exact 3-measurement fits sets the wild measurements aside (docs/design.md 6.4), iteratively
reweighted least squares of the loss fits the rest with their residual variances predicted
at each step's axis, then edges that fit far better flipped are flipped and the
measurements the fit explains are let back in.
"""

from __future__ import annotations

import numpy as np

from tactile_gym.estimation.axis import (
    AxisEstimate,
    degenerate_estimate,
)
from tactile_gym.estimation.planar import (
    NO_XY,
    VARIANCE_FLOOR,
    checked_estimate,
    planar_fit,
    sym3_solve,
    with_prior,
)
from tactile_gym.estimation.prior import AxisPrior
from tactile_gym.estimation.robust import (
    CHI2_99,
    consensus,
    mad_f_scale,
    robust_weights,
    sign_flips,
)

__all__ = ["robust_planar", "Rows"]

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


class Rows:
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
        use = nxy > NO_XY * np.sqrt(np.einsum("ij,ij->i", e3, e3))
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
            return sx2 + lever * lever * var_z + VARIANCE_FLOOR

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


def robust_planar(rows: Rows, loss: str, f_scale: float | None, start=None):
    """:func:`~tactile_gym.estimation.fits.fit_axis_planar` with a robust loss, on validated
    rows with oriented edges.

    Args:
        rows: the rows.
        loss, f_scale: as for :func:`~tactile_gym.estimation.fits.fit_axis_planar`.
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
        normal, rhs = with_prior(normal, rhs, prior)
    solved = sym3_solve(normal, rhs)
    return None if solved is None else np.array(solved[0])


def _irls(rows: Rows, sel, theta, loss: str, f_scale: float) -> np.ndarray | None:
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


def _solution_weights(rows: Rows, sel, theta, loss: str, f_scale: float):
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


def _robust_estimate(rows: Rows, sel, theta, loss: str, f_scale: float) -> AxisEstimate:
    """The estimate at the robust solution: the weighted fit with the solution's weights
    (its covariance is then that of the robust fit)."""
    e3 = rows.e3.copy()
    e3[rows.idx] *= rows.sign[:, None]
    if not rows.noise and sel.sum() <= 3:
        kept = rows.idx[sel]
        return checked_estimate(planar_fit(rows.x[kept], e3[kept], None))
    weights = np.zeros(rows.x.shape[0])
    weights[rows.idx] = _solution_weights(rows, sel, theta, loss, f_scale)[0]
    return checked_estimate(planar_fit(rows.x, e3, weights, rows.prior))
