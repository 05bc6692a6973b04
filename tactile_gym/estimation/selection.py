"""Which model and which measurements: consensus and model selection of the 3D fit.

Conventions as in :mod:`tactile_gym.estimation.problem`. Three decisions (docs/design.md
6.2, 6.4):

* :func:`line_consensus`: the measurements a minimal (3-line) closed-form fit explains, with
  their edge signs, before a robust fit;
* :func:`parallel_fraction`: whether enough edges are parallel to each other for the
  parallel model (eq. 9-10) to be fitted at all;
* :func:`prefer_parallel`: whether the parallel model holds rather than the general one.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_gym.estimation.axis import (
    AxisEstimate,
    isotropic_edge_covs,
)
from tactile_gym.estimation.general import (
    Solution,
    linear_init,
    sign_norms,
    sign_residuals,
    whitening_scale_only,
)
from tactile_gym.estimation.parallel import (
    residuals_parallel,
)
from tactile_gym.estimation.problem import (
    Noise,
    Problem,
    basis,
)
from tactile_gym.estimation.robust import (
    CHI2_99,
    MAD_TO_STD,
    OUTLIER_GATE,
    consensus,
    sign_flips,
)

__all__ = ["line_consensus", "parallel_fraction", "prefer_parallel"]

# Least angle between the edges of a consensus triple, rad (see line_consensus).
_DISTINCT_TOL = math.radians(0.5)


def line_consensus(prob: Problem) -> tuple[np.ndarray, np.ndarray] | None:
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
        sub = Problem.__new__(Problem)
        sub.__dict__.update(prob.__dict__)
        sub.x, sub.n = prob.x[idx], 3
        sub.e = prob.e[idx]
        sub.sqrt_w = prob.sqrt_w[idx]
        sub.noise = None if prob.noise is None else prob.noise.take(idx)
        sub.loss = "linear"
        return linear_init(sub, whitening_scale_only(sub))

    def sq_norms(fit):
        return np.minimum(*sign_norms(prob, *fit, raw=True))

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
    keep, flipped = sign_norms(prob, *fit, raw=True)
    return inliers, np.where(sign_flips(keep / scale, flipped / scale, 2), -1.0, 1.0)


def prefer_parallel(prob: Problem, sol: Solution, est_par: AxisEstimate) -> bool:
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
        prob.noise = Noise(np.full(prob.n, point_std), isotropic_edge_covs(prob.e, edge_std))
    b1, b2 = basis(u_par)
    fun, _ = residuals_parallel(prob, u_par, b1, b2)
    z_par = fun(np.array([0.0, 0.0, p_par @ b1, p_par @ b2, est_par.distance]))
    q_par = np.square(z_par[: 3 * prob.n]).reshape(3, -1).sum(axis=0)
    u = sol.u
    p = sol.p - prob.centre
    p = p - (p @ u) * u
    (k1, k2), (f1, f2) = sign_residuals(prob, u, p, sol.k, sol.c)
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


def parallel_fraction(e: np.ndarray, tol: float) -> tuple[np.ndarray, float]:
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
