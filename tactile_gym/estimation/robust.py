"""Robust losses, minimal-set consensus and edge-sign decisions shared by the fits.

Residuals here are whitened (divided by their predicted standard deviation) or, when no
noise model is given, in metres. The losses are those of scipy's ``least_squares``: the
cost of a residual z is ``0.5 f^2 rho((z / f)^2)`` with ``f = f_scale``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["LOSSES"]

LOSSES = ("linear", "soft_l1", "huber", "cauchy")
"""Loss functions accepted by the fits (those of scipy's least_squares)."""

# Chi-square 99 % quantiles: a squared whitened residual beyond them is an outlier.
CHI2_99 = {1: 6.63, 2: 9.21}

# Normalised median absolute deviation: 1.4826 MAD estimates a Gaussian std.
MAD_TO_STD = 1.4826

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


def loss_cost(z: np.ndarray, loss: str, f_scale: float) -> float:
    """scipy's least_squares cost ``0.5 f^2 sum rho((z / f)^2)`` of whitened residuals."""
    if loss == "linear":
        return 0.5 * float(z @ z)
    s = (z / f_scale) ** 2
    if loss == "soft_l1":
        rho = 2.0 * (np.sqrt(1.0 + s) - 1.0)
    elif loss == "huber":
        rho = np.where(s <= 1.0, s, 2.0 * np.sqrt(s) - 1.0)
    else:  # cauchy
        rho = np.log1p(s)
    return 0.5 * f_scale * f_scale * float(rho.sum())


def robust_weights(r: np.ndarray, loss: str, f_scale: float, curvature: bool = False):
    """IRLS weights rho'(s), s = (r / f_scale)^2, of scipy's losses.

    With ``curvature`` also the weights of the Newton matrix, the second derivative of
    ``0.5 rho(s)`` in r: ``rho' + 2 s rho''``, clipped to at least ``0.05 rho'`` (Cauchy's
    is negative far out).
    """
    s = (r / f_scale) ** 2
    if loss == "soft_l1":
        w = 1.0 / np.sqrt(1.0 + s)
        return (w, w * w * w) if curvature else w
    if loss == "huber":
        out = s > 1.0
        w = np.where(out, 1.0 / np.sqrt(np.maximum(s, 1.0)), 1.0)
        return (w, np.where(out, 0.05 * w, 1.0)) if curvature else w
    if loss == "cauchy":
        w = 1.0 / (1.0 + s)
        return (w, np.maximum((1.0 - s) * w * w, 0.05 * w)) if curvature else w
    w = np.ones_like(r)
    return (w, w) if curvature else w


def sign_flips(keep: np.ndarray, flipped: np.ndarray, dof: int) -> np.ndarray:
    """Which edges to flip, from squared whitened norms with each edge as oriented and
    flipped: those that fit flipped at most a quarter as badly, and better by more than
    the chi-square 99 % quantile of ``dof`` degrees of freedom.

    Flipping on a mere better fit would let noise pick the sign wherever both fit alike
    (an edge line through the axis, normal to it).
    """
    return (flipped < 0.25 * keep) & (keep - flipped > CHI2_99[dof])


def consensus(
    n: int,
    fit_triple: Callable[[np.ndarray], object | None],
    sq_norms: Callable[[object], np.ndarray],
    dof: int,
) -> tuple[np.ndarray, object] | None:
    """The inlier mask and fit of the best minimal (3-measurement) fit, RANSAC-style.

    Candidate triples are spread over the sequence (deterministically, then from a
    fixed-seed generator), so results are reproducible; the number of trials adapts to a
    99 % chance of one all-inlier triple (at most 24). The best candidate has the most
    inliers (``sq_norms(fit) < CHI2_99[dof]``), ties going to the lower truncated sum.

    Args:
        n: number of measurements (>= 3).
        fit_triple: the fit of the measurements at three indices, or None where they do
            not determine one.
        sq_norms: (n,) squared whitened residual norms of all measurements under a fit.
        dof: degrees of freedom of one measurement's residual.

    Returns:
        ``(inliers, fit)``, or None when no triple gave a fit with at least 4 inliers.
    """
    threshold = CHI2_99[dof]
    third = max(n // 3, 1)
    triples = [(i, (i + third) % n, (i + 2 * third) % n) for i in range(n)]
    gen = np.random.default_rng(0)
    while len(triples) < _CONSENSUS_TRIALS:
        triples.append(tuple(gen.choice(n, size=3, replace=False).tolist()))
    best = best_key = best_fit = None
    needed = _CONSENSUS_TRIALS
    for trial, tri in enumerate(triples[:_CONSENSUS_TRIALS]):
        if trial >= needed:
            break
        if len(set(tri)) < 3:
            continue
        fit = fit_triple(np.array(tri))
        if fit is None:
            continue
        z = sq_norms(fit)
        inl = z < threshold
        key = (int(inl.sum()), -float(np.minimum(z, threshold).sum()))
        if best_key is None or key > best_key:
            best, best_key, best_fit = inl, key, fit
            frac = min(best_key[0] / n, 1.0 - 1e-9)
            needed = min(
                _CONSENSUS_TRIALS, int(math.ceil(math.log(0.01) / math.log(1.0 - frac**3)))
            )
    if best is None or best.sum() < 4:
        return None
    return best, best_fit
