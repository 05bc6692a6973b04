"""The general model of a 3D joint-axis fit: any angle between edges and axis (paper eq. 3, 8).

Conventions as in :mod:`tactile_gym.estimation.problem` (docs/design.md 6.2). A rotation
about the axis keeps two invariants of the edge line relative to the axis (in Pluecker terms,
with ``m_i = x_i x e_i`` and ``m_a = p x u``):

* the angle between them, ``c = e_i . u = cos(theta)``;
* the reciprocal product ``k = e_i . m_a + u . m_i = (x_i - p) . (e_i x u) = d sin(theta)``,
  where d is the common distance of the paper's eq. 8 (signed by the edge orientation).

Both residuals, ``r1_i = (x_i - p) . (e_i x u) - k`` and ``r2_i = e_i . u - c``, are
polynomials in the unknowns, so they stay smooth where the skew-line distance
``|r1| / |e_i x u|`` would not. The edges must be oriented consistently; edges that fit far
better flipped are flipped (:func:`sign_norms`). ``d = |k| / sin(theta)``.

Solution. A closed-form initial guess (:func:`linear_init`): r1 and r2 are linear and
homogeneous in ``z = (u, m_a, c, k)``, so it comes from the two smallest right singular
vectors of the stacked system (the second one is the gauge ``m_a -> m_a + s u``,
``k -> k + s c``), followed by ``|u| = 1`` and ``u . m_a = 0``. It is refined over the local
parameters ``(alpha, beta, s1, s2, k, c)`` by a Levenberg-Marquardt written for this problem
(:func:`solve_general`; docs/design.md 6.2 says why it is not scipy's).
"""

from __future__ import annotations

import math

import numpy as np

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
    robust_loss,
    robust_weights,
    sign_flips,
    split_loss_cost,
)
from tactile_gym.vec3 import cross_array, cross_rows

__all__ = [
    "finish_general",
    "fit_general",
    "invariants",
    "linear_init",
    "linearise",
    "refine_general",
    "refine_start",
    "sign_norms",
    "sign_residuals",
    "Solution",
    "solve_general",
    "total_cost",
    "whiten",
    "whitening_scale_only",
]


def _whitening_general(prob: Problem, u: np.ndarray, p: np.ndarray) -> np.ndarray:
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
    nrm = cross_rows(prob.e, u[None, :])
    # r1 = e . (u x (x - p)) and r2 = e . u: their gradients in e are g and u, and
    # noise.cov holds only the edge's normal directions.
    g = cross_rows(np.broadcast_to(u, wv.shape), wv)
    cu = noise.cov @ u
    sx2 = noise.sx**2
    s11 = sx2 * np.einsum("ij,ij->i", nrm, nrm) + np.einsum("ij,ijk,ik->i", g, noise.cov, g)
    s22 = cu @ u
    s12 = np.einsum("ij,ij->i", g, cu)
    # Second-order floors: at theta = 0 the first-order variances vanish. Half the squared
    # norm of cov is the mean squared variance per normal direction.
    fourth = 0.25 * noise.sq_norm
    s11 = s11 + fourth * prob.length**2 + sx2 * noise.mean_var + VAR_FLOOR
    s22 = s22 + fourth + VAR_FLOOR
    return inverse_cholesky(s11, s12, s22) * prob.sqrt_w[:, None]


def whitening_scale_only(prob: Problem) -> np.ndarray:
    """Whitening before any axis is known: r1 ~ sigma_x + L sigma_e, r2 ~ sigma_e."""
    if prob.noise is None:
        return _whitening_general(prob, np.zeros(3), np.zeros(3))
    var_e = prob.noise.mean_var
    s1 = np.sqrt(prob.noise.sx**2 + prob.length**2 * var_e + VAR_FLOOR)
    s2 = np.sqrt(var_e + VAR_FLOOR)
    out = np.zeros((prob.n, 3))
    out[:, 0] = 1.0 / s1
    out[:, 2] = 1.0 / s2
    return out * prob.sqrt_w[:, None]


def linear_init(prob: Problem, wh: np.ndarray):
    """Closed-form (u, p, k, c) from the homogeneous system in z = (u, m_a / L, c, k / L).

    Returns None when the system does not determine the axis.
    """
    x, e, n, length = prob.x, prob.e, prob.n, prob.length
    m = cross_rows(x, e) / length
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
    p = cross_array(u, m_a)
    # Medians keep wild edges from dragging (k, c) when a robust loss follows.
    centre = np.mean if prob.loss == "linear" else np.median
    c = float(centre(e @ u))
    k = float(centre(np.einsum("ij,ij->i", x - p, cross_rows(e, u[None, :]))))
    return u, p, k, c


def linearise(prob, wh, u, p, k, c, jacobian=True):
    """Whitened residuals (2N,) and their Jacobian (2N, 6) at (u, p, k, c); with a prior
    its four residuals follow ((2N + 4,), (2N + 4, 6)).

    Local parameters ``(alpha, beta, s1, s2, k, c)``: u moved to ``normalise(u + alpha b1
    + beta b2)``, p to ``s1 b1 + s2 b2`` (``(b1, b2, u)`` from :func:`basis`). Everything
    comes from one product of the cached design rows with a 6 x 6 matrix: with
    ``r1 = m_i . u + e_i . m_a - k``, ``d r1 / d alpha = (x_i - p) x e_i . b1 = m_i . b1 +
    e_i . (p x b1)``, ``d r1 / d s1 = -e_i . (u x b1) = -e_i . b2``, ``d r1 / d s2 = e_i . b1``
    and ``r2 = e_i . u - c``.
    """
    n = prob.n
    b1, b2 = basis(u)
    q = np.zeros((6, 6))
    q[0:3, 0] = u
    q[3:6, 0] = cross_array(p, u)
    q[3:6, 5] = u
    if jacobian:
        q[0:3, 1] = b1
        q[3:6, 1] = cross_array(p, b1)
        q[0:3, 2] = b2
        q[3:6, 2] = cross_array(p, b2)
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


def solve_general(prob, wh, u, p, k, c, f_scale):
    """Minimise the (robust) cost of the whitened residuals from (u, p, k, c).

    Levenberg-Marquardt on the local parameterisation of :func:`linearise`. Robust losses
    take Newton-like steps: the gradient weighted by ``rho'`` and the Gauss-Newton matrix by
    the residual's exact curvature ``rho' + 2 s rho''`` (clipped from below), so that they
    converge as fast as plain least squares. A step is kept only when the cost drops. Why
    not scipy's ``least_squares``: docs/design.md 6.2. A prior's residuals (after the 2N of
    the measurements) always count by least squares.
    """
    loss = prob.loss
    m = 2 * prob.n
    z, jm, b1, b2 = linearise(prob, wh, u, p, k, c)
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
            zn, _, _, _ = linearise(prob, wh, un, pn, kn, cn, jacobian=False)
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
        z, jm, b1, b2 = linearise(prob, wh, u, p, k, c)
    return u, p, k, c


def fit_general(prob: Problem, multi_start: bool = False) -> AxisEstimate:
    """The general model's fit of a problem: from the closed-form start (with a prior, the
    start of lower cost of it and the prior's axis), refined, edges that fit the other way
    round re-oriented, refined again.

    With ``multi_start`` and a prior both starts are refined and the solution of the lower
    :func:`total_cost` is kept: a start's cost before refining does not tell which basin it
    lies in (a prior's axis at 3 presses settled 70 deg off, the closed form's 5 deg).
    """
    # No axis yet: the first guess is whitened without geometry.
    wh = whitening_scale_only(prob)
    init = linear_init(prob, wh)
    if prob.prior is None:
        starts = [init]
    elif multi_start:
        starts = [_prior_axis(prob)] + ([] if init is None else [init])
    else:
        starts = [_prior_start(prob, init)]
    edges = prob.e
    best = None
    for start in starts:
        if start is None:
            continue
        prob.e = edges
        est, solution = refine_start(prob, *start)
        if est.degenerate:
            continue
        cost = total_cost(prob, *solution) if len(starts) > 1 else 0.0
        if best is None or cost < best[0]:
            best = (cost, est, solution, prob.e)
    if best is None:
        prob.e = edges
        return degenerate_estimate("3d", prob.n, planar=False)
    _, est, prob.solution, prob.e = best
    if len(starts) > 1 and prob.noise is not None:
        whiten(prob, *prob.solution[:2])  # the prior's whitening at the kept axis
    return est


def refine_start(prob: Problem, u, p, k, c):
    """(estimate, (u, p, k, c)) refined from one start; edges that fit the other way round
    (a wild edge between two good ones can have misled the continuity rule) are re-oriented
    in ``prob`` and the fit polished once."""
    wh = whiten(prob, u, p) if prob.noise is not None else whitening_scale_only(prob)
    u, p, k, c, wh = refine_general(prob, u, p, k, c, wh)
    if _reorient(prob, u, p, k, c):
        u, p, k, c, wh = refine_general(prob, u, p, k, c, wh)
    return finish_general(prob, u, p, k, c, wh), (u, p, k, c)


def total_cost(prob: Problem, u, p, k, c) -> float:
    """The cost of every measurement of ``prob`` at the axis (u, p) (centred, ``p . u = 0``)
    with invariants (k, c), each edge with the sign that fits it better, whitened at that
    axis, plus the prior's: what solutions of one problem are compared by, whichever
    measurements each kept.

    It is the negative log posterior with each measurement's link angle (and its place
    along the axis) profiled out, as the fit itself takes them: the squared whitened
    residuals are the measured line's distance from the model's nearest line in the metric
    of its noise, and the normalisation is that of the measurement's own covariance, which
    does not depend on the axis. The log-determinant of the residuals' covariance, which
    grows with the levers, does not belong in it: it is the flat prior on those latent
    angles mapped to the residuals, and it lowers the cost of an axis through the contact
    points whatever the measurements say (docs/design.md 6.9).
    """
    wh = whiten(prob, u, p)
    f_scale = _resolve_f_scale(prob, (u, p, k, c), wh)
    keep, flipped = (
        sum(robust_loss(np.square(z / f_scale), prob.loss, (0,))[0] for z in pair)
        for pair in sign_residuals(prob, u, p, k, c, wh)
    )
    cost = 0.5 * f_scale * f_scale * float(np.minimum(keep, flipped).sum())
    if prob.prior is not None:
        z = prob.prior.residuals(u, p)[0]
        cost += 0.5 * float(z @ z)
    return cost


def _prior_start(prob: Problem, init):
    """Of the closed-form start ``init`` (None when the measurements do not determine one)
    and the prior's axis, the start (u, p, k, c) with the lower cost (few measurements, or
    a small turn of the link, leave the closed form far off)."""
    starts = [_prior_axis(prob)]
    if init is not None:
        starts.append(init)
    costs = []
    for start in starts:
        wh = whiten(prob, *start[:2])
        z = linearise(prob, wh, *start, jacobian=False)[0]
        costs.append(split_loss_cost(z, 2 * prob.n, prob.loss, _resolve_f_scale(prob)))
    return starts[int(np.argmin(costs))]


def _prior_axis(prob: Problem):
    """The prior's axis as a start (u, p, k, c) in the centred frame of ``prob``."""
    u = prob.prior.u0
    p = prob.prior.pin - (prob.prior.pin @ u) * u
    return (u, p, *invariants(prob.x, prob.e, u, p))


def whiten(prob: Problem, u: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The measurements' whitening at the axis (u, p) (:func:`_whitening_general`), with
    the prior's, if any, set for u."""
    if prob.prior is not None:
        prob.prior.set_axis(u)
    return _whitening_general(prob, u, p)


def refine_general(prob, u, p, k, c, wh):
    f_scale = _resolve_f_scale(prob, (u, p, k, c), wh)
    u, p, k, c = solve_general(prob, wh, u, p, k, c, f_scale)
    if prob.noise is not None:
        wh = whiten(prob, u, p)
    return u, p, k, c, wh


def _resolve_f_scale(prob, axis=None, wh=None) -> float:
    """The loss's f_scale: as given, else 2 (standard deviations, or any for least
    squares), else (no stds) from the residuals at ``axis = (u, p, k, c)``."""
    if prob.f_scale is not None:
        return prob.f_scale
    if prob.noise is not None or prob.loss == "linear":
        return 2.0
    r, _, _, _ = linearise(prob, wh, *axis, jacobian=False)
    return mad_f_scale(r)


def _reorient(prob, u, p, k, c) -> bool:
    """Flip the edges that fit far better flipped (``sign_flips``); True if any was."""
    bad = sign_flips(*sign_norms(prob, u, p, k, c), 2)
    if bad.any():
        prob.e = np.where(bad[:, None], -prob.e, prob.e)
        return True
    return False


def finish_general(prob, u, p, k, c, wh) -> AxisEstimate:
    z, jm, b1, b2 = linearise(prob, wh, u, p, k, c)
    f_scale = _resolve_f_scale(prob, (u, p, k, c), wh)
    cov_local, cond = covariance_local(prob, z, jm, 6, f_scale, 2 * prob.n)
    # At theta = 0 (edges parallel to the axis, the parallel model's case) the distance
    # d = |k| / sin(theta) is undefined.
    if cov_local is None or not 1.0 - c * c > 1e-12:
        return degenerate_estimate("3d", prob.n, planar=False)
    sin_t = math.sqrt(1.0 - c * c)
    d = abs(k) / sin_t
    # Geometric distance residual: (r1 - k) / sin(theta).
    r1 = np.einsum("ij,ij->i", prob.x - p, cross_rows(prob.e, u[None, :])) - k
    rms = float(np.sqrt(np.mean(r1 * r1))) / sin_t
    # Jacobian of (point, direction, distance) w.r.t. (alpha, beta, s1, s2, k, c).
    q = p + prob.centre
    g = axis_jacobian(q, u, b1, b2, 6)
    g[6, 4] = math.copysign(1.0, k) / sin_t
    g[6, 5] = abs(k) * c / sin_t**3
    return assemble(prob, u, q, d, cov_local, g, cond, rms, "3d")


def invariants(x, e, u, p) -> tuple[float, float]:
    """Median reciprocal product k and angle cosine c of the edges (given orientation)."""
    k = float(np.median(np.einsum("ij,ij->i", x - p, cross_rows(e, u[None, :]))))
    return k, float(np.median(e @ u))


def sign_norms(
    prob: Problem, u, p, k, c, wh=None, raw: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Squared whitened (r1, r2) norms per measurement: each edge as oriented, and flipped.

    ``wh``: the whitening at (u, p) when already computed. Without stds the norms are
    scaled so that the median of the better of the two is 0.5 (a noise level from the
    residuals of a fitted axis), unless ``raw``.
    """
    (k1, k2), (f1, f2) = sign_residuals(prob, u, p, k, c, wh)
    keep = k1 * k1 + k2 * k2
    flipped = f1 * f1 + f2 * f2
    if prob.noise is None and not raw:
        scale = 0.5 / max(float(np.median(np.minimum(keep, flipped))), 1e-30)
        keep, flipped = keep * scale, flipped * scale
    return keep, flipped


def sign_residuals(prob: Problem, u, p, k, c, wh=None):
    """Whitened residual pairs ``(z1, z2)``, each (N,), with each edge as oriented and
    flipped (whitening as for :func:`sign_norms`)."""
    if wh is None:
        wh = (
            _whitening_general(prob, u, p) if prob.noise is not None else whitening_scale_only(prob)
        )
    d = np.einsum("ij,ij->i", prob.x - p, cross_rows(prob.e, u[None, :]))
    a = prob.e @ u
    out = []
    for sgn in (1.0, -1.0):
        r1 = sgn * d - k
        r2 = sgn * a - c
        out.append((wh[:, 0] * r1, wh[:, 1] * r1 + wh[:, 2] * r2))
    return out


class Solution:
    """What a general-case fit ended with, for warm starts (the online estimator).

    ``mask``: (N,) the measurements the fit used; ``edges``: (N, 3) the edges as oriented
    for it; ``u``, ``p`` (world frame, ``p . u = 0``), ``k``, ``c``: the axis and invariants.
    """

    __slots__ = ("mask", "edges", "u", "p", "k", "c")

    def __init__(self, mask, edges, u, p, k, c):
        self.mask, self.edges, self.u, self.p, self.k, self.c = mask, edges, u, p, k, c
