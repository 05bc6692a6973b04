"""Robust losses, minimal-set consensus and edge-sign decisions shared by the fits
(docs/design.md 6.4).

Residuals here are whitened (divided by their predicted standard deviation) or, when no
noise model is given, in metres. The losses are those of scipy's ``least_squares``, defined
once in :func:`robust_loss`: the cost of a residual z is ``0.5 f^2 rho((z / f)^2)`` with
``f = f_scale``. Chi-square quantiles come from ``scipy.stats.chi2``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.stats import chi2, norm

__all__ = ["LOSSES"]

LOSSES = ("linear", "soft_l1", "huber", "cauchy")
"""Loss functions accepted by the fits (those of scipy's least_squares)."""

# Chi-square 99 % quantiles by degrees of freedom: a squared whitened residual beyond them
# is an outlier.
CHI2_99 = {dof: float(chi2.ppf(0.99, dof)) for dof in (1, 2, 3)}

# Chi-square quantiles at the two-sided 5-sigma probability: beyond them a squared whitened
# residual is a gross error, not noise.
_FIVE_SIGMA = 2.0 * float(norm.sf(5.0))
OUTLIER_GATE = {dof: float(chi2.isf(_FIVE_SIGMA, dof)) for dof in (1, 2, 3)}

# Normalised median absolute deviation: 1.4826 MAD estimates a Gaussian std.
MAD_TO_STD = 1.0 / float(norm.ppf(0.75))

_CONSENSUS_TRIALS = 24


def check_loss(loss: str, f_scale: float | None = None) -> None:
    """Raise ValueError unless ``loss`` is one of ``LOSSES`` and ``f_scale`` None or > 0."""
    if loss not in LOSSES:
        raise ValueError(f"loss must be one of {LOSSES}, got {loss!r}")
    if f_scale is not None and not (math.isfinite(f_scale) and f_scale > 0):
        raise ValueError(f"f_scale must be a finite number > 0, got {f_scale!r}")


def mad_f_scale(residuals: np.ndarray) -> float:
    """Default ``f_scale`` without a noise model: twice a MAD-based noise estimate."""
    return max(2.0 * MAD_TO_STD * float(np.median(np.abs(residuals))), 1e-9)


def robust_loss(s: np.ndarray, loss: str, orders: tuple[int, ...] = (0, 1, 2)) -> tuple:
    """The loss ``rho`` and its first two derivatives at ``s = (z / f_scale)^2``.

    This is the one definition of the losses: the cost, the IRLS weights and the Newton
    weights below derive from it, and so does the callable loss given to scipy's
    ``least_squares`` (:func:`split_loss`).

    Args:
        s: (N,) squared scaled residuals, >= 0.
        loss: one of ``LOSSES``.
        orders: which of ``rho`` (0), ``rho'`` (1) and ``rho''`` (2) to compute, in
            increasing order (the fits' inner loops need only some; each is a few array
            operations on a few dozen residuals, where the per-call cost dominates).

    Returns:
        A tuple of (N,) arrays, one per order asked for.
    """
    out = []
    if loss == "soft_l1":
        t = 1.0 + s
        root = np.sqrt(t)
        if 0 in orders:
            out.append(2.0 * (root - 1.0))
        if 1 in orders or 2 in orders:
            w = 1.0 / root
            if 1 in orders:
                out.append(w)
            if 2 in orders:
                out.append(-0.5 * w * w * w)
    elif loss == "huber":
        far = s > 1.0
        root = np.sqrt(np.where(far, s, 1.0))
        if 0 in orders:
            out.append(np.where(far, 2.0 * root - 1.0, s))
        if 1 in orders:
            out.append(np.where(far, 1.0 / root, 1.0))
        if 2 in orders:
            out.append(np.where(far, -0.5 / (root * root * root), 0.0))
    elif loss == "cauchy":
        w = 1.0 / (1.0 + s)
        if 0 in orders:
            out.append(np.log1p(s))
        if 1 in orders:
            out.append(w)
        if 2 in orders:
            out.append(-(w * w))
    else:
        if 0 in orders:
            out.append(s)
        if 1 in orders:
            out.append(np.ones_like(s))
        if 2 in orders:
            out.append(np.zeros_like(s))
    return tuple(out)


def loss_cost(z: np.ndarray, loss: str, f_scale: float) -> float:
    """scipy's least_squares cost ``0.5 f^2 sum rho((z / f)^2)`` of whitened residuals."""
    if loss == "linear":
        return 0.5 * float(z @ z)
    (rho,) = robust_loss((z / f_scale) ** 2, loss, (0,))
    return 0.5 * f_scale * f_scale * float(rho.sum())


def split_loss_cost(z: np.ndarray, m: int, loss: str, f_scale: float) -> float:
    """:func:`loss_cost` of the first m whitened residuals (the measurements') plus the
    least-squares cost of the rest (a prior's: robust losses never apply to them)."""
    tail = z[m:]
    return loss_cost(z[:m], loss, f_scale) + 0.5 * float(tail @ tail)


def split_loss(loss: str, m: int):
    """A callable ``loss`` for scipy's least_squares: ``loss`` on the first m residuals,
    least squares on the rest (see :func:`split_loss_cost`).

    scipy calls it with ``s = (f / f_scale)^2`` and takes ``(rho, rho', rho'')`` in s.
    """

    def rho(s: np.ndarray) -> np.ndarray:
        out = np.array(robust_loss(s, "linear"))
        out[:, :m] = robust_loss(s[:m], loss)
        return out

    return rho


def robust_weights(r: np.ndarray, loss: str, f_scale: float, curvature: bool = False):
    """IRLS weights ``rho'(s)``, ``s = (r / f_scale)^2``, of :func:`robust_loss`.

    With ``curvature`` also the weights of the Newton matrix, the second derivative of the
    cost ``0.5 f_scale^2 rho(s)`` in r: ``rho' + 2 s rho''``, clipped to at least
    ``0.05 rho'`` where it can vanish (Huber's is 0 and Cauchy's negative far out), so
    that every residual keeps some curvature in the Gauss-Newton matrix.
    """
    s = (r / f_scale) ** 2
    if not curvature:
        return robust_loss(s, loss, (1,))[0]
    d1, d2 = robust_loss(s, loss, (1, 2))
    newton = d1 + 2.0 * s * d2
    if loss == "soft_l1":
        # Positive everywhere: its cost is strictly convex in r.
        return d1, newton
    return d1, np.maximum(newton, 0.05 * d1)


def sign_flips(keep: np.ndarray, flipped: np.ndarray, dof: int) -> np.ndarray:
    """Which edges to flip, from squared whitened norms with each edge as oriented and
    flipped: those that fit flipped at most a quarter as badly, and better by more than
    ``OUTLIER_GATE[dof]`` (5 sigma).

    A weaker rule lets noise pick the sign wherever both fit about alike (an edge line
    near the axis and normal to it, or a distance d that is small against the noise), and
    a valid edge flipped costs these badly conditioned fits dearly.
    """
    return (flipped < 0.25 * keep) & (keep - flipped > OUTLIER_GATE[dof])


def consensus(
    n: int,
    fit_triple: Callable[[np.ndarray], object | None],
    sq_norms: Callable[[object], np.ndarray],
    dof: int,
    whitened: bool = True,
    shares: np.ndarray | None = None,
) -> tuple[np.ndarray, object, float] | None:
    """The inlier mask and fit of the best minimal (3-measurement) fit, RANSAC-style.

    Candidate triples are spread over the sequence (deterministically, then from a
    fixed-seed generator), so results are reproducible; the number of trials adapts to a
    99 % chance of one all-inlier triple (at most 24). Whitened norms: the best candidate
    has the most inliers (``sq_norms(fit) < CHI2_99[dof]``), ties going to the lower
    truncated sum. Without a noise model a candidate's own residuals cannot tell its noise
    level (a wrong fit has large residuals everywhere, and all look alike), so the best
    candidate has the least median norm (Rousseeuw's least median of squares), and the
    noise variance comes from that median.

    ``shares`` count repeated measurements of one thing once: inliers are counted by their
    shares, and the triples are spread over the cumulative shares (random ones drawn in
    proportion to them). Many measurements of one edge line then neither crowd out the
    triples of distinct lines nor make any axis through that line win the count.

    Args:
        n: number of measurements (>= 3).
        fit_triple: the fit of the measurements at three indices, or None where they do
            not determine one.
        sq_norms: (n,) squared residual norms of all measurements under a fit, whitened or
            (``whitened=False``) not.
        dof: degrees of freedom of one measurement's residual.
        whitened: whether ``sq_norms`` are in units of their predicted variance.
        shares: optional (n,) shares > 0 of the measurements in the inlier count, e.g.
            ``1 / (number of measurements of the same line)``; default all 1.

    Returns:
        ``(inliers, fit, scale)``: ``scale`` is the noise variance that whitens the norms
        (1 when they are whitened). None when no triple gave a fit with 4 inliers or more.
    """
    threshold = CHI2_99[dof]
    share = np.ones(n) if shares is None else shares
    total = float(share.sum())
    best = best_key = best_fit = None
    needed = _CONSENSUS_TRIALS
    for trial, tri in enumerate(_triples(n, shares)):
        if trial >= needed:
            break
        if len(set(tri)) < 3:
            continue
        fit = fit_triple(np.array(tri))
        if fit is None:
            continue
        z = sq_norms(fit)
        scale = 1.0 if whitened else _lmeds_variance(z, dof)
        inl = z < threshold * scale
        count = float(share @ inl)
        if whitened:
            key = (count, -float(np.minimum(z, threshold).sum()))
        else:
            key = (-scale,)
        if best_key is None or key > best_key:
            best, best_key, best_fit, best_scale = inl, key, fit, scale
            # Trials for a 99 % chance of one all-inlier triple; as many as allowed when the
            # best triple so far explains (almost) nothing, where the formula's log is 0.
            good = min(count / total, 1.0 - 1e-9) ** 3
            needed = _CONSENSUS_TRIALS
            if good > 1e-12:
                needed = min(needed, int(math.ceil(math.log(0.01) / math.log1p(-good))))
    if best is None or best.sum() < 4:
        return None
    return best, best_fit, best_scale


# Medians of chi-square variables by degrees of freedom.
_CHI2_MEDIAN = {dof: float(chi2.median(dof)) for dof in (1, 2)}


def _lmeds_variance(sq_norms: np.ndarray, dof: int) -> float:
    """Noise variance from the median squared norm of a minimal (3-measurement) fit, with
    Rousseeuw's small-sample factor ``(1 + 5 / (n - 3))^2``."""
    n = sq_norms.size
    factor = (1.0 + 5.0 / max(n - 3, 1)) ** 2
    return max(factor * float(np.median(sq_norms)) / _CHI2_MEDIAN[dof], 1e-300)


def _triples(n: int, shares: np.ndarray | None = None):
    """Up to ``_CONSENSUS_TRIALS`` index triples: spread over the sequence (over the
    cumulative ``shares`` when given), then random from a fixed-seed generator (drawn in
    proportion to the shares, and only when needed: most fits stop after a few)."""
    if shares is None:
        third = max(n // 3, 1)
        for i in range(min(n, _CONSENSUS_TRIALS)):
            yield (i, (i + third) % n, (i + 2 * third) % n)
        prob = None
    else:
        # Measurement i covers [end_i - shares_i, end_i) of the cumulative shares.
        end = np.cumsum(shares)
        total = float(end[-1])
        m = min(n, _CONSENSUS_TRIALS)
        start = (np.arange(m) + 0.5) * total / m
        at = (start[:, None] + total * np.array([0.0, 1.0, 2.0]) / 3.0) % total
        idx = np.searchsorted(end, at, side="right").clip(max=n - 1)
        yield from map(tuple, idx.tolist())
        prob = shares / total
    gen = np.random.default_rng(0)
    for _ in range(_CONSENSUS_TRIALS - n):
        yield tuple(gen.choice(n, size=3, replace=False, p=prob).tolist())
