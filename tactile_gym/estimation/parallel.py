"""The parallel model of a 3D joint-axis fit: edges parallel to the axis (paper eq. 9-10).

Conventions as in :mod:`tactile_gym.estimation.problem` (docs/design.md 6.2). When every
edge is parallel to the axis (a door's free edge beside a vertical hinge) the general
model's reciprocal product vanishes and says nothing about p. This model uses the
point-to-axis distance ``|(x_i - p) x u| - d`` and the edge-axis misalignment
``(e_i x u) . b_j`` (b_1, b_2 spanning the plane normal to the axis) instead, over the local
parameters ``(alpha, beta, s1, s2, d)``, started from a circle through the contact points
and solved by ``scipy.optimize.least_squares``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from tactile_gym.estimation.axis import (
    DEGENERATE_CONDITION,
    AxisEstimate,
    degenerate_estimate,
)
from tactile_gym.estimation.problem import (
    VAR_FLOOR,
    Problem,
    assemble,
    axis_jacobian,
    basis,
    covariance_local,
    inverse_cholesky,
)
from tactile_gym.estimation.robust import (
    mad_f_scale,
    split_loss,
    split_loss_cost,
)
from tactile_gym.vec3 import cross_rows

__all__ = ["fit_parallel", "residuals_parallel"]


def _whitening_parallel(prob: Problem, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
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
        out[:, 0] = 1.0 / np.sqrt(prob.noise.sx**2 + VAR_FLOOR)
        out[:, 1:] = inverse_cholesky((cov @ b2) @ b2 + VAR_FLOOR, -(c1 @ b2), c1 @ b1 + VAR_FLOOR)
    return out * prob.sqrt_w[:, None]


def residuals_parallel(prob, u0, b1, b2):
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
        exu = cross_rows(e, u[None, :])
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
        j1 = cross_rows(np.broadcast_to(b1, e.shape), e) @ ju
        j2 = cross_rows(np.broadcast_to(b2, e.shape), e) @ ju
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


def _circle_start(prob: Problem, b1: np.ndarray, b2: np.ndarray) -> np.ndarray | None:
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


def fit_parallel(prob: Problem, mean_dir: np.ndarray) -> AxisEstimate:
    e = prob.e
    prob.e = np.where((e @ mean_dir < 0)[:, None], -e, e)
    u = mean_dir
    b1, b2 = basis(u)
    m = 3 * prob.n
    fun, jac = residuals_parallel(prob, u, b1, b2)
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
    b1, b2 = basis(u)
    fun, jac = residuals_parallel(prob, u, b1, b2)
    t = np.array([0.0, 0.0, p @ b1, p @ b2, d])
    cov_local, cond = covariance_local(prob, fun(t), jac(t), 5, f_scale, m)
    if cov_local is None:
        return degenerate_estimate("3d-parallel", prob.n, planar=False)
    wv = prob.x - p
    wp = wv - (wv @ u)[:, None] * u
    rad = np.sqrt(np.einsum("ij,ij->i", wp, wp)) - d
    rms = float(np.sqrt(np.mean(rad * rad)))
    q = p + prob.centre
    g = axis_jacobian(q, u, b1, b2, 5)
    g[6, 4] = 1.0
    return assemble(prob, u, q, d, cov_local, g, cond, rms, "3d-parallel")
